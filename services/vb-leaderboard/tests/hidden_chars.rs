//! Names stored before submissions refused control, bidirectional and invisible characters (written here through the
//! store directly, as an old database holds them) are shown with those characters escaped on every page, SVG chart
//! and the static board; the JSON API serves the stored value as it is (data, for programs to show as they choose).

mod common;

use std::io::{Read, Write};
use vb_store::*;

/// A direction override (`evil\u{202E}gnp.exe` reads "evilexe.png"), a zero-width space, a bell and a tag character.
const NAME: &str = "evil\u{202E}gnp.exe pi\u{200B}d";
const OWNER: &str = "al\u{200B}ice\u{7}";
const DETAIL: &str = "planner said \u{2066}hi\u{2069}\u{E0041}\r";
const HIDDEN: [char; 7] = [
    '\u{202E}',
    '\u{200B}',
    '\u{7}',
    '\u{2066}',
    '\u{2069}',
    '\u{E0041}',
    '\r',
];

fn get(port: u16, path: &str) -> (String, String) {
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).unwrap();
    let text = String::from_utf8(raw).unwrap();
    let (head, body) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
    (head.to_string(), body.to_string())
}

fn assert_neutralised(what: &str, text: &str) {
    for c in HIDDEN {
        assert!(
            !text.contains(c),
            "{what} shows U+{:04X} as it is:\n{text}",
            c as u32
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hidden_characters_in_stored_names_are_shown_escaped_on_every_page() -> anyhow::Result<()> {
    let dir = std::env::temp_dir().join(format!("vb-hidden-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    let url = format!("sqlite://{}", dir.join("vb.db").display());
    let store = Store::open(&url).await?;
    let (set, served) = common::committed()?;
    let sub = NewSubmission {
        name: NAME.into(),
        owner: OWNER.into(),
        owner_token: "t".into(),
        planner: vb_store::PlannerSpec::Builtin(format!("pid{}", '\u{202E}').into()),
        planner_identity: "builtin:pid".into(),
        vehicle: "hmmwv".into(),
        scale: 1.0,
        seed: 0,
        step_deadline_s: 1.0,
        task_set_version: set.version().into(),
        sim_version: "s".into(),
        perception: Default::default(),
    };
    let episode = NewEpisode {
        task_id: contracts::TaskId::new(1, 0),
        level: contracts::ElevationLevel::Low,
        semantics: contracts::SemanticsKind::Rigid,
        density: contracts::ObstacleDensity::Sparse,
    };
    let id = store.create_submission(&sub, &[episode], 0.0).await?;
    let w = store.register_worker("w", 1, "s", "tw", 0.0).await?;
    let lease = store.lease(&w, 1, 30.0, true, 1.0).await?.remove(0);
    let r = EpisodeResultIn {
        lease_id: lease.lease_id.clone(),
        submission_id: id.clone(),
        task_id: contracts::TaskId::new(1, 0),
        outcome: contracts::RecordedOutcome::Episode(contracts::Outcome::PlannerFailure),
        reason: contracts::EndReason::PlannerCrash,
        detail: DETAIL.into(),
        metrics: Some(contracts::EpisodeMetrics::default()),
        trajectory_csv: format!("{}\n", contracts::trajectory::CSV_HEADER),
        trajectory_gz: None,
        planner_log: String::new(),
        sim_version: "s".into(),
        planner_identity: "builtin:pid".into(),
        wall_time_s: 0.1,
    };
    assert_eq!(store.report(&w, &r, 2.0).await?, ReportOutcome::Accepted);
    let lb =
        vb_leaderboard::Leaderboard::new(store.reader(), common::SIM_VERSION, Some(served.clone()));
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let port = listener.local_addr()?.port();
    tokio::spawn(vb_leaderboard::serve(lb, listener));
    let fetch = |path: String| {
        tokio::task::spawn_blocking(move || {
            let (head, body) = get(port, &path);
            assert!(head.starts_with("HTTP/1.1 200"), "{path}: {head}");
            body
        })
    };
    let shown_name = "evil\\u{202E}gnp.exe pi\\u{200B}d";
    for path in [
        "/".to_string(),
        format!("/submissions/{id}"),
        format!("/submissions/{id}?page=2"),
        format!("/submissions/{id}/episodes/w001-t0"),
        format!("/compare/{id}/{id}"),
    ] {
        let body = fetch(path.clone()).await?;
        assert_neutralised(&path, &body);
        assert!(body.contains(shown_name), "{path} names the submission");
    }
    let page = fetch(format!("/submissions/{id}")).await?;
    assert!(
        page.contains("al\\u{200B}ice\\u{0007}"),
        "the owner, escaped"
    );
    let episode = fetch(format!("/submissions/{id}/episodes/w001-t0")).await?;
    assert!(
        episode.contains("planner said \\u{2066}hi\\u{2069}\\u{E0041}\\u{000D}"),
        "the detail, escaped: {episode}"
    );
    // The API is data: the stored value, JSON-encoded, for programs to show as they choose.
    let api: serde_json::Value =
        serde_json::from_str(&fetch(format!("/api/submissions/{id}")).await?)?;
    assert_eq!(api["submission"]["name"], NAME, "{api}");
    // The static board and the SVG charts, rendered through the same pages.
    let mut summary = results::summary::summarise(&[]);
    summary.planner = NAME.into();
    let page = vb_leaderboard::pages::board::standalone(
        &[vb_leaderboard::pages::board::Evaluation {
            name: NAME.into(),
            summary,
        }],
        common::SIM_VERSION,
        None,
    );
    assert_neutralised("leaderboard.html", &page);
    assert!(page.contains(shown_name), "{page}");
    Ok(())
}
