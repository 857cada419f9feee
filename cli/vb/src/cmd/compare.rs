//! `vb compare DIR_A DIR_B`: paired comparison of two evaluations.

use std::path::PathBuf;

#[derive(clap::Args)]
pub struct CompareArgs {
    a: PathBuf,
    b: PathBuf,
}

pub fn run(args: CompareArgs) -> anyhow::Result<()> {
    let a = eval::run::read_results(&args.a.join("results.jsonl"))?;
    let b = eval::run::read_results(&args.b.join("results.jsonl"))?;
    anyhow::ensure!(!a.is_empty(), "{}: no results", args.a.display());
    anyhow::ensure!(!b.is_empty(), "{}: no results", args.b.display());
    let c = eval::compare::compare(&a, &b);
    anyhow::ensure!(c.paired_tasks > 0, "the two evaluations share no task");
    if let Some(note) = eval::compare::task_set_note(&a, &b) {
        println!("{note}");
    }
    println!(
        "{} paired tasks: success A {:.1}%, B {:.1}%",
        c.paired_tasks,
        100.0 * c.success_a,
        100.0 * c.success_b
    );
    println!(
        "difference A - B: {:+.1} points, 95% CI [{:+.1}, {:+.1}]",
        100.0 * c.difference,
        100.0 * c.difference_ci95.0,
        100.0 * c.difference_ci95.1
    );
    println!(
        "discordant: A only {}, B only {}; exact McNemar {}: {}",
        c.a_only,
        c.b_only,
        eval::compare::p_text(c.mcnemar_p),
        if c.significant {
            "significant at 5%"
        } else {
            "not significant at 5%"
        }
    );
    Ok(())
}
