//! Issue 60 item 3: no function of the libraries and binaries is longer than 100 lines unless its documentation
//! says why it is one piece ("One piece on purpose: ..."). Tests (`tests/` and `#[cfg(test)]` modules) are
//! scenarios read top to bottom and are not counted.

use std::path::{Path, PathBuf};

const MAX_LINES: usize = 100;
const WHY: &str = "One piece on purpose";

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if path.is_dir() {
            if !matches!(name, "target" | "tests" | "node_modules" | "fuzz")
                && !name.starts_with('.')
            {
                sources(&path, out);
            }
        } else if name.ends_with(".rs") {
            out.push(path);
        }
    }
}

/// Whether `line` starts a function item (`fn`, with any of `pub`, `pub(crate)`, `async`, `const`, `unsafe`).
fn starts_fn(line: &str) -> bool {
    let mut rest = line.trim_start();
    loop {
        if let Some(r) = rest.strip_prefix("pub(") {
            match r.find(')') {
                Some(i) => rest = r[i + 1..].trim_start(),
                None => return false,
            }
            continue;
        }
        let mut stripped = false;
        for word in ["pub ", "async ", "const ", "unsafe ", "extern \"C\" "] {
            if let Some(r) = rest.strip_prefix(word) {
                rest = r.trim_start();
                stripped = true;
            }
        }
        if !stripped {
            break;
        }
    }
    rest.starts_with("fn ")
}

/// The functions over [`MAX_LINES`] in `text` whose documentation does not say why: `(line, name, length)`.
fn long_functions(text: &str) -> Vec<(usize, String, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let end = lines
        .iter()
        .position(|l| l.trim() == "#[cfg(test)]")
        .unwrap_or(lines.len());
    let mut out = Vec::new();
    for i in 0..end {
        let line = lines[i];
        if !starts_fn(line) {
            continue;
        }
        let indent = line.len() - line.trim_start().len();
        // A declaration without a body (a trait's) ends with `;` before any `{`.
        let Some(open) =
            (i..end).find(|&j| lines[j].contains('{') || lines[j].trim_end().ends_with(';'))
        else {
            continue;
        };
        if !lines[open].contains('{') {
            continue;
        }
        let Some(close) = (open + 1..end).find(|&j| {
            let l = lines[j];
            l.len() > indent && l[..indent].trim().is_empty() && l[indent..].starts_with('}')
        }) else {
            continue;
        };
        let n = close - i + 1;
        if n <= MAX_LINES {
            continue;
        }
        // Its documentation and attributes: the lines above it back to the previous item's end or a blank line.
        let docs = lines[..i]
            .iter()
            .rev()
            .take_while(|l| {
                let t = l.trim();
                !t.is_empty() && !t.ends_with('}') && !t.ends_with(';') && !t.ends_with('{')
            })
            .any(|l| l.contains(WHY));
        if !docs {
            let name = line.trim_start().split("fn ").nth(1).unwrap_or("");
            let name = name.split(['(', '<']).next().unwrap_or(name).to_string();
            out.push((i + 1, name, n));
        }
    }
    out
}

#[test]
fn the_rule_finds_a_long_function_and_accepts_a_reason() {
    let body = "    let x = 1;\n".repeat(MAX_LINES);
    let long = format!("/// Does it.\npub(crate) async fn long() {{\n{body}}}\n");
    assert_eq!(
        long_functions(&long),
        vec![(2, "long".to_string(), MAX_LINES + 2)]
    );
    let why = format!("/// Does it.\n///\n/// {WHY}: it is.\nfn long() {{\n{body}}}\n");
    assert!(long_functions(&why).is_empty());
    let short = "fn short() {\n    let x = 1;\n}\n";
    assert!(long_functions(short).is_empty());
    let in_tests = format!("#[cfg(test)]\nmod tests {{\n    fn long() {{\n{body}    }}\n}}\n");
    assert!(long_functions(&in_tests).is_empty());
}

#[test]
fn no_function_is_over_100_lines_without_saying_why() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = Vec::new();
    sources(&root, &mut files);
    assert!(files.len() > 100, "the workspace's sources were not found");
    let mut found = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        for (line, name, n) in long_functions(&text) {
            let rel = f.strip_prefix(&root).unwrap_or(f).display().to_string();
            found.push(format!("{rel}:{line}: `{name}` has {n} lines"));
        }
    }
    assert!(
        found.is_empty(),
        "functions over {MAX_LINES} lines: split them along what they do, or say why each is one piece \
         (`{WHY}: ...` in its documentation):\n{}",
        found.join("\n")
    );
}
