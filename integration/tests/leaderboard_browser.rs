//! The leaderboard in a real browser: headless Chromium renders the pages served by `vb serve` after an evaluation
//! through the gRPC path, and the screenshots must show what the pages promise (bars of the breakdown charts, the
//! driven trajectory over the map). Skipped, and said so, when Chromium is not installed (`.ci/run` installs it).

use integration::*;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn chromium() -> Option<PathBuf> {
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .find_map(|c| {
            let ok = Command::new(c)
                .arg("--version")
                .output()
                .map(|o| o.status.success())
                .unwrap_or(false);
            ok.then(|| PathBuf::from(c))
        })
}

fn headless(browser: &Path, dir: &Path, extra: &[String], url: &str) -> std::process::Output {
    Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--disable-dev-shm-usage",
        ])
        .arg(format!("--user-data-dir={}", dir.join("profile").display()))
        .args(extra)
        .arg(url)
        .output()
        .expect("running chromium")
}

/// Pixels of the screenshot within `tol` of `rgb`.
fn count_colour(png: &Path, rgb: [u8; 3], tol: i32) -> usize {
    let img = image::open(png).expect("screenshot").to_rgb8();
    img.pixels()
        .filter(|p| (0..3).all(|i| (p.0[i] as i32 - rgb[i] as i32).abs() <= tol))
        .count()
}

#[test]
fn leaderboard_pages_render_in_headless_chromium() {
    let Some(browser) = chromium() else {
        eprintln!(
            "SKIPPED: chromium is not installed (.ci/run installs Debian's chromium package)"
        );
        return;
    };
    let dir = temp_dir("browser");
    let (grpc, http) = (free_port(), free_port());
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let serve = Proc::start(
        "serve",
        &dir,
        &vb(),
        &[
            "serve",
            "--db",
            &db,
            "--grpc",
            &format!("127.0.0.1:{grpc}"),
            "--http",
            &format!("127.0.0.1:{http}"),
            "--slots",
            "2",
            "--evaluate",
            "pid",
            "--tasks",
            "1,9,12",
        ],
    );
    // `vb serve` prints the leaderboard URL of the submission once the evaluation has finished.
    let t0 = Instant::now();
    let url = loop {
        let out = serve.output();
        if let Some(line) = out
            .lines()
            .find(|l| l.starts_with("leaderboard: http") && l.contains("/submissions/"))
        {
            break line.trim_start_matches("leaderboard: ").trim().to_string();
        }
        assert!(
            t0.elapsed() < Duration::from_secs(180),
            "vb serve did not finish its evaluation:\n{out}"
        );
        std::thread::sleep(Duration::from_millis(200));
    };
    let id = url.rsplit('/').next().unwrap().to_string();

    // The DOM as the browser built it.
    let dom = headless(&browser, &dir, &["--dump-dom".into()], &url);
    let dom = String::from_utf8_lossy(&dom.stdout);
    for needle in [
        "id=\"by-level\"",
        "id=\"by-semantics\"",
        "id=\"by-density\"",
        "id=\"episodes\"",
        "pid (builtin)",
    ] {
        assert!(
            dom.contains(needle),
            "rendered submission page lacks {needle}"
        );
    }

    // Screenshots: the bar charts of the breakdowns are drawn (their blue), and the episode page draws the
    // trajectory (yellow) over the map picture.
    let shot = dir.join("submission.png");
    let out = headless(
        &browser,
        &dir,
        &[
            format!("--screenshot={}", shot.display()),
            "--window-size=1400,1600".into(),
        ],
        &url,
    );
    assert!(
        shot.exists(),
        "no screenshot: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let bars = count_colour(&shot, [0x4a, 0x7f, 0xb5], 6);
    assert!(
        bars > 2000,
        "breakdown bars not visible in the screenshot ({bars} px)"
    );

    // A successful episode: its trajectory crosses the map.
    let eps: serde_json::Value =
        serde_json::from_str(&http_text(http, &format!("/api/submissions/{id}/episodes")))
            .expect("episodes JSON");
    let task = eps
        .as_array()
        .and_then(|a| a.iter().find(|e| e["outcome"] == "success"))
        .and_then(|e| e["task_id"].as_str())
        .expect("at least one successful PID episode on worlds 1, 9 and 12")
        .to_string();
    let ep_url = format!("http://127.0.0.1:{http}/submissions/{id}/episodes/{task}");
    let shot = dir.join("episode.png");
    headless(
        &browser,
        &dir,
        &[
            format!("--screenshot={}", shot.display()),
            "--window-size=1200,1400".into(),
        ],
        &ep_url,
    );
    let yellow = count_colour(&shot, [0xff, 0xd4, 0x00], 10);
    assert!(
        yellow > 500,
        "the driven trajectory is not visible on the episode page ({yellow} px)"
    );
    // The map picture loaded under it: the page has many distinct colours, not just text on white.
    let img = image::open(&shot).unwrap().to_rgb8();
    let mut colours: Vec<[u8; 3]> = img
        .pixels()
        .map(|p| [p.0[0] & 0xf0, p.0[1] & 0xf0, p.0[2] & 0xf0])
        .collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(
        colours.len() > 100,
        "the map picture did not render ({} colours)",
        colours.len()
    );

    // `vb leaderboard-static`: one file whose inline style its own Content-Security-Policy allows (by hash). Were
    // the hash wrong, Chromium would refuse the style and the header would not be drawn in its dark blue.
    let evals = dir.join("evals");
    let status = Command::new(vb())
        .args([
            "eval",
            "--planner",
            "pid",
            "--tasks",
            "1",
            "--threads",
            "1",
            "--out",
        ])
        .arg(evals.join("pid"))
        .output()
        .expect("running vb eval");
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let page = evals.join("leaderboard.html");
    assert!(
        page.is_file(),
        "vb eval writes the static board next to its results"
    );
    let shot = dir.join("static.png");
    let out = headless(
        &browser,
        &dir,
        &[
            format!("--screenshot={}", shot.display()),
            "--window-size=1400,600".into(),
            "--enable-logging=stderr".into(),
        ],
        &format!("file://{}", page.display()),
    );
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(!log.contains("Refused to apply"), "{log}");
    let header = count_colour(&shot, [0x24, 0x31, 0x3f], 4);
    assert!(
        header > 20_000,
        "the static page's style did not apply ({header} px of header colour)"
    );
}
