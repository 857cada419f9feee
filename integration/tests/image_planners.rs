//! Issue 35 over real processes and the real Docker daemon: an image planner's container and private directory go
//! when its worker dies by SIGKILL, and a worker's start removes what dead workers left, never a live one's.

use integration::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use vb_proto::v1 as pb;
use vb_worker::sandbox::reaper::{Owner, DIR_PREFIX, LABEL};

/// The tests run one at a time: a worker's start sweeps what every dead worker of the machine left, the other
/// test's planted leftovers included.
static SERIAL: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// Whether a Docker daemon answers; prints why the test is skipped when none does.
fn docker_answers() -> bool {
    let out = Command::new("docker")
        .args(["version", "--format", "{{.Server.Version}}"])
        .output();
    match out {
        Ok(o) if o.status.success() => true,
        Ok(o) => {
            let why = String::from_utf8_lossy(&o.stderr);
            eprintln!("SKIPPED: no Docker daemon answers: {}", why.trim());
            false
        }
        Err(e) => {
            eprintln!("SKIPPED: no docker command: {e}");
            false
        }
    }
}

fn docker(args: &[&str]) -> String {
    let out = Command::new("docker")
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("docker");
    assert!(
        out.status.success(),
        "docker {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// An image removed when dropped.
struct Image(String);

impl Drop for Image {
    fn drop(&mut self) {
        let _ = Command::new("docker")
            .args(["image", "rm", "--force", "--", &self.0])
            .output();
    }
}

/// An image built from scratch (`docker import`) holding the example planner and the shared libraries it needs,
/// which answers each control step after `delay_ms`.
fn slow_planner_image(dir: &Path, delay_ms: u32) -> Image {
    let tag = format!("vb-test/slow-planner-{}:1", std::process::id());
    let root = dir.join("image-root");
    let script = r#"set -eu
root="$1"; planner="$2"
mkdir -p "$root/tmp" "$root/run/vb"
cp -L "$planner" "$root/planner"
ldd "$planner" | grep -o '/[^ ]*' | sort -u | while read -r lib; do
    mkdir -p "$root$(dirname "$lib")"; cp -L "$lib" "$root$lib"
done
"#;
    let st = Command::new("sh")
        .args(["-c", script, "build"])
        .arg(&root)
        .arg(example_planner())
        .status()
        .expect("sh");
    assert!(st.success(), "assembling the image's files");
    let entrypoint = format!(
        r#"ENTRYPOINT ["/planner", "--delay-ms", "{delay_ms}", "--control-rate-hz", "10"]"#
    );
    let st = Command::new("sh")
        .args([
            "-c",
            "tar -C \"$1\" -c . | docker import -c \"$2\" - \"$3\" >/dev/null",
            "import",
        ])
        .arg(&root)
        .args([&entrypoint, &tag])
        .status()
        .expect("sh");
    assert!(st.success(), "docker import");
    Image(tag)
}

/// (name, owner label) of every planner container.
fn planner_containers() -> Vec<(String, String)> {
    let format = format!("{{{{.Names}}}} {{{{.Label \"{LABEL}\"}}}}");
    docker(&[
        "ps",
        "--all",
        "--filter",
        &format!("label={LABEL}"),
        "--format",
        &format,
    ])
    .lines()
    .filter_map(|l| l.split_once(' '))
    .map(|(n, o)| (n.to_string(), o.to_string()))
    .collect()
}

fn container_exists(name: &str) -> bool {
    !docker(&[
        "ps",
        "--all",
        "--quiet",
        "--filter",
        &format!("name=^{name}$"),
    ])
    .trim()
    .is_empty()
}

/// The private directories of process `pid` in the temporary directory.
fn dirs_of(pid: u32) -> Vec<PathBuf> {
    std::fs::read_dir(std::env::temp_dir())
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name.strip_prefix(DIR_PREFIX)
                .is_some_and(|rest| rest.split('.').nth(2) == Some(&pid.to_string()))
        })
        .map(|e| e.path())
        .collect()
}

fn eventually(limit: Duration, mut pred: impl FnMut() -> bool) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < limit {
        if pred() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    pred()
}

/// A `vb worker` that inherits descriptor 9 without close-on-exec (as from a careless supervisor): a shell opens it
/// and executes the worker in its place (same process id).
fn start_worker_with_a_stray_descriptor(dir: &Path, db: &str, port: u16) -> Proc {
    let token = create_token_with_role(db, "worker", "worker");
    let url = format!("http://127.0.0.1:{port}");
    let vb = vb();
    let vb = vb.to_str().expect("a UTF-8 path");
    let args = [
        "-c",
        "exec 9</dev/null; exec \"$0\" \"$@\"",
        vb,
        "worker",
        "--coordinator",
        &url,
        "--slots",
        "1",
        "--name",
        "worker",
    ];
    Proc::start_env(
        "worker",
        dir,
        Path::new("/bin/sh"),
        &args,
        &[("VB_WORKER_TOKEN", &token)],
    )
}

fn image_submission(image: &str) -> pb::SubmitRequest {
    pb::SubmitRequest {
        name: "slow image".into(),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Image(image.into())),
        }),
        task_ids: vec!["1".into()],
        step_deadline_s: 5.0,
        ..Default::default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_killed_worker_s_planner_container_and_directory_go() -> anyhow::Result<()> {
    let _serial = SERIAL.lock().await;
    if !docker_answers() {
        return Ok(());
    }
    let dir = temp_dir("image-kill");
    let image = slow_planner_image(&dir, 200);
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let token = create_token(&db);
    let port = free_port();
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let mut worker = start_worker_with_a_stray_descriptor(&dir, &db, port);
    let pid = worker.child.id();
    let mut c = client(port, &token).await;
    let id = vb_submit::submit(&mut c, image_submission(&image.0))
        .await?
        .submission_id;
    // The episode runs (200 ms a step: a minute of simulated time takes two), in its worker's labelled container.
    let mine = |(_, owner): &(String, String)| owner.split('.').nth(2) == Some(&pid.to_string());
    let mut name = None;
    assert!(
        eventually(Duration::from_secs(60), || {
            name = planner_containers().into_iter().find(mine).map(|(n, _)| n);
            name.is_some()
        }),
        "no planner container of worker {pid}: {}",
        worker.output()
    );
    let name = name.expect("a container");
    let running = || docker(&["inspect", "--format", "{{.State.Running}}", &name]).trim() == "true";
    assert!(eventually(Duration::from_secs(30), running), "{name} runs");
    let workdirs = dirs_of(pid);
    assert_eq!(workdirs.len(), 1, "one private directory: {workdirs:?}");
    assert!(
        eventually(Duration::from_secs(30), || workdirs[0]
            .join("planner.sock")
            .exists()),
        "the planner serves on its socket: {}",
        worker.output()
    );
    // Steps are being answered: the episode is under way, not starting.
    tokio::time::sleep(Duration::from_secs(2)).await;
    let status = vb_submit::status(&mut c, &id).await?;
    assert_eq!(status.finished, 0, "{}", vb_submit::status_line(&status));
    assert!(running(), "{name} still runs");

    // Its watchdog holds only its pipe and /dev/null (none of the worker's descriptors, not even those the worker
    // inherited without close-on-exec from this test), and not the worker's token.
    let dogs = watchdogs(|a| a == name);
    assert_eq!(dogs.len(), 1, "one watchdog for {name}");
    let fds: Vec<String> = std::fs::read_dir(format!("/proc/{}/fd", dogs[0]))?
        .flatten()
        .filter_map(|e| std::fs::read_link(e.path()).ok())
        .map(|l| l.display().to_string())
        .collect();
    assert_eq!(fds.len(), 3, "{fds:?}");
    assert!(
        fds.iter()
            .all(|l| l.starts_with("pipe:") || l == "/dev/null"),
        "{fds:?}"
    );
    let environ = std::fs::read(format!("/proc/{}/environ", dogs[0]))?;
    assert!(!String::from_utf8_lossy(&environ).contains("VB_WORKER_TOKEN"));

    worker.kill();
    assert!(
        eventually(Duration::from_secs(10), || !container_exists(&name)),
        "the container {name} outlived its worker's SIGKILL by 10 s"
    );
    assert!(
        eventually(Duration::from_secs(5), || !workdirs[0].exists()),
        "{} outlived its worker's SIGKILL",
        workdirs[0].display()
    );
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_ended_episode_s_container_and_directory_go() -> anyhow::Result<()> {
    let _serial = SERIAL.lock().await;
    if !docker_answers() {
        return Ok(());
    }
    let dir = temp_dir("image-end");
    let image = slow_planner_image(&dir, 0);
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let token = create_token(&db);
    let port = free_port();
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let worker = start_worker(&dir, "worker", &db, port, 1);
    let pid = worker.child.id();
    let mut c = client(port, &token).await;
    let id = vb_submit::submit(&mut c, image_submission(&image.0))
        .await?
        .submission_id;
    let status = wait_for(port, &token, &id, Duration::from_secs(120), |s| {
        s.state() == pb::SubmissionState::Done
    })
    .await;
    assert!(
        status.total > 0 && status.finished == status.total,
        "{}",
        vb_submit::status_line(&status)
    );
    let mine = |(_, owner): &(String, String)| owner.split('.').nth(2) == Some(&pid.to_string());
    assert!(
        eventually(Duration::from_secs(10), || !planner_containers()
            .iter()
            .any(mine)),
        "a container of the ended episode stays: {:?}",
        planner_containers()
    );
    assert!(
        eventually(Duration::from_secs(5), || dirs_of(pid).is_empty()),
        "its directory stays: {:?}",
        dirs_of(pid)
    );
    // Nor does its watchdog linger.
    assert!(
        eventually(Duration::from_secs(5), || watchdogs(
            |a| a.contains(&format!(".{pid}."))
        )
        .is_empty()),
        "a watchdog lingers"
    );
    Ok(())
}

/// The process ids of the watchdogs with an argument for which `pred` holds.
fn watchdogs(pred: impl Fn(&str) -> bool) -> Vec<u32> {
    std::fs::read_dir("/proc")
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let pid: u32 = e.file_name().to_str()?.parse().ok()?;
            let cmd = std::fs::read(e.path().join("cmdline")).ok()?;
            let cmd = String::from_utf8_lossy(&cmd).into_owned();
            let args: Vec<&str> = cmd.split('\0').collect();
            (args.contains(&"vb-planner-watchdog") && args.iter().any(|a| pred(a))).then_some(pid)
        })
        .collect()
}

/// An owner label of this machine and PID namespace for `pid` (started at `start`).
fn label_for(pid: u32, start: &str) -> String {
    let me = Owner::current().expect("this process").label();
    let f: Vec<&str> = me.split('.').collect();
    format!("{}.{}.{pid}.{start}", f[0], f[1])
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_starting_worker_removes_only_what_dead_workers_left() -> anyhow::Result<()> {
    let _serial = SERIAL.lock().await;
    let dir = temp_dir("image-sweep");
    let me = Owner::current().expect("this process").label();
    let my_start = me.rsplit('.').next().expect("start").to_string();
    // A worker that died: a process that has exited.
    let mut gone = Command::new("true").spawn()?;
    let dead_pid = gone.id();
    gone.wait()?;
    let dead = label_for(dead_pid, &my_start);
    // A live one: this test process.
    let live = me.clone();
    let tag = |label: &str| {
        let f: Vec<&str> = label.split('.').collect();
        format!("{}.{}.{}.{}", &f[0][..8], f[1], f[2], f[3])
    };
    let tmp = std::env::temp_dir();
    let dead_dir = tmp.join(format!("{DIR_PREFIX}{}-00000000000000aa", tag(&dead)));
    let live_dir = tmp.join(format!("{DIR_PREFIX}{}-00000000000000bb", tag(&live)));
    let other_ns = label_for(dead_pid, &my_start).replacen(
        &format!(".{}.", me.split('.').nth(1).expect("pidns")),
        ".1.",
        1,
    );
    let other_ns_dir = tmp.join(format!("{DIR_PREFIX}{}-00000000000000cc", tag(&other_ns)));
    for d in [&dead_dir, &live_dir, &other_ns_dir] {
        std::fs::create_dir_all(d.join("sub"))?;
        std::fs::write(d.join("sub/file"), "x")?;
    }
    let with_docker = docker_answers();
    let mut image = None;
    let mut containers = Vec::new();
    if with_docker {
        let img = slow_planner_image(&dir, 0);
        for (what, label) in [("dead", &dead), ("live", &live), ("otherns", &other_ns)] {
            let name = format!("vb-test-sweep-{what}-{}", std::process::id());
            docker(&[
                "create",
                "--name",
                &name,
                "--label",
                &format!("{LABEL}={label}"),
                "--network",
                "none",
                "--",
                &img.0,
            ]);
            containers.push(name);
        }
        image = Some(img);
    }
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let worker = start_worker(&dir, "worker", &db, port, 1);
    let swept = eventually(Duration::from_secs(60), || {
        worker
            .output()
            .contains("removed what planners of dead workers left")
    });
    let left: Vec<String> = containers
        .iter()
        .filter(|n| container_exists(n))
        .cloned()
        .collect();
    let dirs = [dead_dir.exists(), live_dir.exists(), other_ns_dir.exists()];
    for n in &left {
        let _ = Command::new("docker").args(["rm", "--force", n]).output();
    }
    for d in [&dead_dir, &live_dir, &other_ns_dir] {
        let _ = std::fs::remove_dir_all(d);
    }
    drop(image);
    assert!(
        swept,
        "the worker says what it removed: {}",
        worker.output()
    );
    assert_eq!(
        dirs,
        [false, true, true],
        "only the dead worker's directory goes (dead, live, other PID namespace)"
    );
    if with_docker {
        assert_eq!(
            left,
            containers[1..].to_vec(),
            "only the dead worker's container goes"
        );
    }
    Ok(())
}
