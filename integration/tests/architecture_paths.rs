//! ARCHITECTURE.md stays true and short: every repository path it names in backticks exists, and it is under 200
//! lines (issue 30).

use std::path::Path;

/// The backticked tokens of `text` that look like repository paths: a `/` or a `.rs`, `.md`, `.toml` or `.proto`
/// ending, no spaces, no `::`, not a flag or a URL; a trailing `:LINE` or `/` is dropped.
fn paths(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    // Odd-numbered pieces of a split on backticks are inside backticks; a fenced block becomes one piece with
    // whitespace in it (two fences are six backticks), so it is skipped.
    for token in text.split('`').skip(1).step_by(2) {
        if token.is_empty()
            || token.contains(char::is_whitespace)
            || token.contains("::")
            || token.starts_with('-')
            || token.starts_with("http")
        {
            continue;
        }
        let token = match token.rsplit_once(':') {
            Some((path, line)) if !line.is_empty() && line.bytes().all(|b| b.is_ascii_digit()) => {
                path
            }
            _ => token,
        };
        let is_path = token.contains('/')
            || [".rs", ".md", ".toml", ".proto"]
                .iter()
                .any(|ext| token.ends_with(ext));
        let token = token.trim_end_matches('/');
        if is_path && !token.is_empty() {
            out.push(token.to_string());
        }
    }
    out
}

#[test]
fn architecture_md_names_only_existing_paths_and_is_short() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let text = std::fs::read_to_string(root.join("ARCHITECTURE.md")).expect("read ARCHITECTURE.md");
    let named = paths(&text);
    assert!(
        named.len() > 20,
        "found only {} paths in ARCHITECTURE.md",
        named.len()
    );
    let missing: Vec<&String> = named.iter().filter(|p| !root.join(p).exists()).collect();
    assert!(
        missing.is_empty(),
        "ARCHITECTURE.md names paths that do not exist: {missing:?}"
    );
    let lines = text.lines().count();
    assert!(
        lines < 200,
        "ARCHITECTURE.md has {lines} lines; keep it under 200"
    );
    let chars = text.chars().count();
    assert!(
        chars <= 15_000,
        "ARCHITECTURE.md has {chars} characters; keep it at most 15,000"
    );
}

#[test]
fn path_tokens_are_recognised() {
    let text = "`sim-core/src/lib.rs:44` `a b/c` `sim_core::x/y` `--out/x` `https://x/y` `Cargo.toml` `web/` `VB_LOG`";
    assert_eq!(paths(text), ["sim-core/src/lib.rs", "Cargo.toml", "web"]);
}
