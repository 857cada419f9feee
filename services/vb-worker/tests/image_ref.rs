//! Image references reach `docker` only when they follow Docker's reference grammar, and then after `--`.

use vb_worker::exec::{docker_available, image_command};
use vb_worker::EpisodeError;

#[tokio::test]
async fn flag_like_image_references_never_reach_docker() {
    for image in ["--privileged", "-v", "alpine --privileged", "Alpine"] {
        let e = image_command(image).await.unwrap_err();
        assert!(
            matches!(&e, EpisodeError::Infrastructure(m) if m.contains("is not a valid image reference")),
            "{image}: {e}"
        );
    }
}

#[tokio::test]
async fn a_valid_reference_is_inspected_and_run_after_a_double_dash() {
    if let Err(why) = docker_available().await {
        eprintln!("skipped: no docker here ({why})");
        return;
    }
    // `docker image inspect --format ... -- IMAGE` answers for a missing image as for any other: this worker lacks it.
    let e = image_command("vb-test/no-such-image:1").await.unwrap_err();
    assert!(
        matches!(&e, EpisodeError::CannotRun(m) if m.contains("no image `vb-test/no-such-image:1`")),
        "{e}"
    );
    // An image that exists (empty, imported from an empty tar archive): the command ends `-- IMAGE`.
    let image = format!("vb-test/empty-{}:1", std::process::id());
    let mut import = std::process::Command::new("docker")
        .args(["import", "-", &image])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .expect("docker import");
    {
        use std::io::Write;
        let mut stdin = import.stdin.take().expect("stdin");
        stdin.write_all(&[0u8; 10240]).expect("empty tar");
    }
    assert!(import.wait().expect("docker import").success());
    let got = image_command(&image).await;
    let _ = std::process::Command::new("docker")
        .args(["image", "rm", "--", &image])
        .output();
    let (argv, identity) = got.expect("the image exists");
    assert_eq!(argv[0], "docker");
    assert_eq!(&argv[argv.len() - 2..], ["--".to_string(), image.clone()]);
    assert!(
        identity.starts_with(&format!("image:{image}@sha256:")),
        "{identity}"
    );
}
