//! An exec planner's command is run as given: naming the placeholder that image commands use for their private
//! directory (`{workdir}`) neither gets it substituted nor takes the planner out of its namespaces (it did: such a
//! command ran uncontained and as the worker's user, whatever `--planner-user` said).

use std::time::Duration;
use vb_worker::exec::start;
use vb_worker::sandbox::Containment;

#[tokio::test]
async fn an_exec_command_naming_the_image_placeholder_stays_contained() {
    let containment = match Containment::probe(None).await {
        Ok(c) => c,
        Err(why) => {
            eprintln!("SKIPPED: {why}");
            return;
        }
    };
    // Builtins only before the check: the shell is PID 1 of its namespace, and nothing else runs there yet.
    let script = "if [ -e /proc/2 ]; then echo SHARED; else echo ISOLATED; fi; echo \"ARG:$1\"; exec sleep 30";
    let argv: Vec<String> = ["sh", "-c", script, "sh", "{workdir}"]
        .map(String::from)
        .to_vec();
    let started = start(
        &argv,
        false,
        "exec:test".into(),
        Duration::from_secs(1),
        Duration::from_secs(2),
        containment,
    )
    .await;
    let Err((_, log)) = started else {
        panic!("the command serves nothing");
    };
    assert!(log.contains("ISOLATED"), "in namespaces of its own: {log}");
    assert!(log.contains("ARG:{workdir}"), "passed as given: {log}");
}
