//! The library calls behind `vb terrain calibrate|eval|render` and `vb tasks generate|stats`, without building the
//! whole `vb` binary (useful on a slow machine):
//! `cargo run --release -p swae --example pipeline -- calibrate | generate OUT | stats DIR | eval DATA N | render DATA OUT`.

use std::path::{Path, PathBuf};

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    // The committed weights (DEFAULT_WEIGHTS_PATH is relative to the workspace root).
    let weights = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(swae::source::DEFAULT_WEIGHTS_PATH);
    let src = || swae::SwaeSource::from_file(&weights, swae::source::FULL_SCALE_HEIGHT);
    match a.first().map(String::as_str) {
        Some("calibrate") => {
            let (h, t) = swae::eval::calibrate(&src()?, tasks::generate::DEFAULT_SEED)?;
            print!("{t}");
            println!("FULL_SCALE_HEIGHT = {h:.2}");
        }
        Some("generate") => {
            let m = tasks::cli::generate_set(
                Path::new(&a[1]),
                tasks::generate::DEFAULT_SEED,
                &swae::SwaeSource::committed()?,
            )?;
            println!("version {} generator {}", m.version, m.generator);
        }
        Some("stats") => {
            let s = tasks::cli::stats(&tasks::TaskSet::load(Path::new(&a[1]))?)?;
            print!("{}", tasks::cli::stats_text(&s));
        }
        Some("eval") => {
            let (train, val) = swae::train::load_split(Path::new(&a[1]))?;
            let model = swae::model::Swae::load(&weights)?;
            print!(
                "{}",
                swae::eval::report(&model, &src()?, &train, &val, a[2].parse()?)?
            );
        }
        Some("render") => {
            swae::picture::contact_sheet(Path::new(&a[1]), &weights, 8)?.save(&a[2])?;
        }
        _ => anyhow::bail!(
            "usage: pipeline calibrate | generate OUT | stats DIR | eval DATA N | render DATA OUT"
        ),
    }
    Ok(())
}
