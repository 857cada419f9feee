//! Markup injected through every user-controlled field (submission name, owner, planner command, detail, planner
//! log, identity; a reason is one of `EndReason`'s names) comes out escaped on every HTML page, in every SVG and in the static leaderboard; the JSON
//! API serves it as JSON that browsers may not sniff; every response carries the Content-Security-Policy.

mod common;

use std::io::{Read, Write};
use vb_store::*;

/// In the planner's log only: a planner prints what it likes (a token it found), so no public page may show it.
const LOG_SECRET: &str = "found-token-4f1d9c";
const EVIL: &str = "<script>alert(1)</script><img src=x onerror=alert(2)>";

fn get(port: u16, path: &str) -> (String, String) {
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).unwrap();
    let text = String::from_utf8_lossy(&raw).into_owned();
    let (head, body) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
    (head.to_string(), body.to_string())
}

fn assert_clean(what: &str, text: &str) {
    for raw in ["<script", "<img"] {
        assert!(!text.contains(raw), "{what} contains raw `{raw}`");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn injected_markup_is_escaped_everywhere() -> anyhow::Result<()> {
    let dir = std::env::temp_dir().join(format!("vb-escape-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    let url = format!("sqlite://{}", dir.join("vb.db").display());
    let store = Store::open(&url).await?;
    let (set, served) = common::committed()?;
    let sub = NewSubmission {
        name: EVIL.into(),
        owner: EVIL.into(),
        owner_token: "t".into(),
        planner: vb_store::PlannerSpec::Exec(vec![EVIL.to_string()]),
        planner_identity: format!("exec:{EVIL}"),
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
        detail: EVIL.into(),
        metrics: Some(contracts::EpisodeMetrics::default()),
        trajectory_csv: format!("{}\n", contracts::trajectory::CSV_HEADER),
        trajectory_gz: None,
        planner_log: format!("{EVIL} {LOG_SECRET}"),
        sim_version: "s".into(),
        planner_identity: format!("exec:{EVIL}"),
        wall_time_s: 0.1,
    };
    assert_eq!(store.report(&w, &r, 2.0).await?, ReportOutcome::Accepted);
    let lb =
        vb_leaderboard::Leaderboard::new(store.reader(), common::SIM_VERSION, Some(served.clone()));
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let port = listener.local_addr()?.port();
    tokio::spawn(vb_leaderboard::serve(lb, listener));
    let pages = [
        "/".to_string(),
        format!("/submissions/{id}"),
        format!("/submissions/{id}?page=2"),
        format!("/submissions/{id}/episodes/w001-t0"),
        "/api/submissions".to_string(),
        format!("/api/submissions/{id}"),
        format!("/api/submissions/{id}/episodes"),
        format!("/api/submissions/{id}/episodes/w001-t0"),
        format!("/compare/{id}/{id}"),
        format!("/api/compare/{id}/{id}"),
        "/metrics".to_string(),
        "/no-such-page".to_string(),
    ];
    for path in &pages {
        let (head, body) = tokio::task::spawn_blocking({
            let path = path.clone();
            move || get(port, &path)
        })
        .await?;
        let head_lc = head.to_ascii_lowercase();
        if head_lc.contains("content-type: application/json") {
            // Data, not markup: the browser must not sniff it into HTML.
            assert!(
                head_lc.contains("x-content-type-options: nosniff"),
                "{path}: {head}"
            );
        } else {
            assert_clean(path, &body);
        }
        assert!(
            !body.contains(LOG_SECRET),
            "{path} shows the planner's log to the public"
        );
        assert!(
            head.to_ascii_lowercase().contains(
                &format!("content-security-policy: {}", vb_leaderboard::CSP).to_ascii_lowercase()
            ),
            "{path}: {head}"
        );
    }
    let (_, index) = tokio::task::spawn_blocking(move || get(port, "/")).await?;
    assert!(
        index.contains("&#60;script&#62;alert(1)&#60;/script&#62;"),
        "the name is shown, escaped"
    );
    // The static leaderboard and the charts of `vb eval` escape too: the same board template, standalone.
    let mut summary = results::summary::summarise(&[]);
    summary.planner = EVIL.into();
    summary.vehicle = EVIL.into();
    summary.task_set_version = EVIL.into();
    summary.sim_version = EVIL.into();
    let svg = results::charts::charts_svg(&summary).into_string();
    assert_clean("charts.svg", &svg);
    assert!(svg.contains("&#60;script&#62;"), "{svg}");
    let page = vb_leaderboard::pages::board::standalone(
        &[vb_leaderboard::pages::board::Evaluation {
            name: EVIL.into(),
            summary,
        }],
        common::SIM_VERSION,
        None,
    );
    assert_clean("leaderboard.html", &page);
    assert!(page.contains("&#60;script&#62;alert(1)"), "{page}");
    Ok(())
}

/// A standalone page allows exactly its inline style by hash (CSP level 2: base64 SHA-256 of the element's
/// text), and nothing else: no script source, no other style.
#[test]
fn standalone_page_allows_only_its_own_style() {
    use sha2::Digest;
    let page = vb_leaderboard::pages::board::standalone(&[], common::SIM_VERSION, None);
    let css = page
        .split_once("<style>")
        .and_then(|(_, rest)| rest.split_once("</style>"))
        .map(|(css, _)| css)
        .expect("an inline style");
    let hash = sha2::Sha256::digest(css.as_bytes());
    let b64 = base64(&hash);
    let csp = vb_leaderboard::pages::standalone_csp();
    assert!(csp.contains(&format!("style-src 'sha256-{b64}'")), "{csp}");
    assert!(csp.starts_with("default-src 'none'"), "{csp}");
    // The page's <meta> carries the policy (its quotes escaped as an attribute value is).
    let meta = page
        .split_once("http-equiv=\"Content-Security-Policy\" content=\"")
        .and_then(|(_, rest)| rest.split_once('"'))
        .map(|(v, _)| v.replace("&#39;", "'"))
        .expect("a CSP meta element");
    assert_eq!(meta, csp);
    assert!(!page.contains("<script"));
}

/// Base64 written out independently of the crate's encoder (RFC 4648, bit by bit).
fn base64(bytes: &[u8]) -> String {
    let alphabet: Vec<char> = ('A'..='Z')
        .chain('a'..='z')
        .chain('0'..='9')
        .chain(['+', '/'])
        .collect();
    let bits: Vec<u8> = bytes
        .iter()
        .flat_map(|b| (0..8).rev().map(move |i| (b >> i) & 1))
        .collect();
    let mut s: String = bits
        .chunks(6)
        .map(|c| {
            let v = c
                .iter()
                .chain(std::iter::repeat(&0))
                .take(6)
                .fold(0usize, |a, b| a * 2 + *b as usize);
            alphabet[v]
        })
        .collect();
    while !s.len().is_multiple_of(4) {
        s.push('=');
    }
    s
}
