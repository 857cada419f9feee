//! Checks of user-given text before it is stored or reaches a command line: names shown on pages
//! ([`check_display_text`]) and container image references ([`check_image_ref`], Docker's reference grammar);
//! and the one way user-given text is shown ([`shown`], [`shown_lines`]): what a check would refuse, made visible.
//! Pure functions, shared by the coordinator (at submission), the worker (before `docker`), the leaderboard and
//! `vb-submit` (when showing).

use std::borrow::Cow;
use std::fmt::Write as _;

/// Why a piece of user input was refused; the message names the field.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct InputError {
    pub field: String,
    pub message: String,
}

fn refuse(field: &str, message: String) -> InputError {
    InputError {
        field: field.to_string(),
        message,
    }
}

/// What kind of character `c` is if it must not appear in text shown to people: control characters, bidirectional
/// overrides, embeddings, isolates and marks (which reorder what follows them: `evil\u{202E}gnp.exe`), and
/// zero-width or otherwise invisible characters (which make two different names look the same).
pub fn hidden_char_kind(c: char) -> Option<&'static str> {
    match c {
        c if c.is_control() => Some("a control character"),
        '\u{202A}'..='\u{202E}' | '\u{2066}'..='\u{2069}' => {
            Some("a bidirectional override or isolate")
        }
        '\u{200E}' | '\u{200F}' | '\u{061C}' => Some("a bidirectional mark"),
        '\u{200B}'..='\u{200D}' | '\u{2060}'..='\u{2064}' | '\u{FEFF}' => {
            Some("a zero-width character")
        }
        '\u{00AD}'
        | '\u{034F}'
        | '\u{115F}'
        | '\u{1160}'
        | '\u{17B4}'
        | '\u{17B5}'
        | '\u{180E}'
        | '\u{3164}'
        | '\u{FFA0}'
        | '\u{206A}'..='\u{206F}'
        | '\u{FFF9}'..='\u{FFFB}' => Some("an invisible character"),
        '\u{2028}' | '\u{2029}' => Some("a line or paragraph separator"),
        '\u{E0000}'..='\u{E007F}' => Some("an invisible tag character"),
        _ => None,
    }
}

/// Refuses text shown on pages (a submission's name, a worker's name, ...) that carries control, bidirectional or
/// invisible characters; the message names `field` and the character's code point.
pub fn check_display_text(field: &str, text: &str) -> Result<(), InputError> {
    for (i, c) in text.chars().enumerate() {
        if let Some(kind) = hidden_char_kind(c) {
            return Err(refuse(
                field,
                format!(
                    "character {} is U+{:04X}, {kind}: control, bidirectional and invisible characters are not \
                     allowed",
                    i + 1,
                    c as u32
                ),
            ));
        }
    }
    Ok(())
}

/// User-given text as it may be shown to people: every character [`hidden_char_kind`] flags (control, bidirectional,
/// zero-width and other invisible characters) is replaced by a visible escape of its code point, `\u{202E}`;
/// everything else is kept. Names stored before [`check_display_text`] refused such characters, and text no check
/// reaches (a worker's reason or detail), are shown through this. Borrowed when there is nothing to escape.
pub fn shown(text: &str) -> Cow<'_, str> {
    neutralise(text, |_| false)
}

/// [`shown`] for text of several lines (a page, a log): line feeds and tabs are kept, everything else
/// [`hidden_char_kind`] flags (carriage returns, escape sequences, bidirectional and invisible characters) is escaped.
pub fn shown_lines(text: &str) -> Cow<'_, str> {
    neutralise(text, |c| c == '\n' || c == '\t')
}

fn neutralise(text: &str, keep: impl Fn(char) -> bool) -> Cow<'_, str> {
    let hidden = |c: char| !keep(c) && hidden_char_kind(c).is_some();
    let Some(first) = text.find(hidden) else {
        return Cow::Borrowed(text);
    };
    let mut out = String::with_capacity(text.len() + 16);
    out.push_str(&text[..first]);
    for c in text[first..].chars() {
        if hidden(c) {
            let _ = write!(out, "\\u{{{:04X}}}", c as u32);
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

/// Longest image reference accepted (Docker's limit on the name is 255).
pub const MAX_IMAGE_REF: usize = 512;

/// Checks a container image reference against Docker's reference grammar (`distribution/reference`):
/// `[HOST[:PORT]/]NAME[:TAG][@sha256:HEX]`, where `NAME` is lowercase path components (`[a-z0-9]+` joined by `.`,
/// `_`, `__` or dashes) separated by `/`, `HOST` a domain (or `[IPv6]`) with an optional port, `TAG`
/// `[A-Za-z0-9_][A-Za-z0-9_.-]{0,127}` and the digest 64 lowercase hex digits. Nothing that could read as a flag
/// (`--privileged`) or carry spaces passes.
pub fn check_image_ref(image: &str) -> Result<(), InputError> {
    const FIELD: &str = "image";
    let bad = |why: String| {
        Err(refuse(
            FIELD,
            format!("`{image}` is not a valid image reference: {why}"),
        ))
    };
    if image.is_empty() {
        return bad("it is empty".into());
    }
    if image.len() > MAX_IMAGE_REF {
        return bad(format!("longer than {MAX_IMAGE_REF} bytes"));
    }
    if image.starts_with('-') {
        return bad("it starts with `-` (it would read as an option)".into());
    }
    if let Some(c) = image.chars().find(|c| !c.is_ascii_graphic()) {
        return bad(format!("it contains U+{:04X}", c as u32));
    }
    let (rest, digest) = match image.split_once('@') {
        Some((r, d)) => (r, Some(d)),
        None => (image, None),
    };
    if let Some(d) = digest {
        let ok = d.strip_prefix("sha256:").is_some_and(|hex| {
            hex.len() == 64
                && hex
                    .bytes()
                    .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
        });
        if !ok {
            return bad(format!(
                "digest `{d}` is not `sha256:` and 64 lowercase hex digits"
            ));
        }
    }
    // A tag is after the last `:` that follows the last `/` (a registry's port comes before a `/`).
    let last_slash = rest.rfind('/').map_or(0, |i| i + 1);
    let (name, tag) = match rest[last_slash..].rfind(':') {
        Some(i) => (&rest[..last_slash + i], Some(&rest[last_slash + i + 1..])),
        None => (rest, None),
    };
    if let Some(t) = tag {
        let b = t.as_bytes();
        let word = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
        if b.is_empty()
            || b.len() > 128
            || !word(b[0])
            || !b.iter().all(|&c| word(c) || c == b'.' || c == b'-')
        {
            return bad(format!(
                "tag `{t}` must be 1 to 128 letters, digits, `_`, `.` or `-`, not starting with `.` or `-`"
            ));
        }
    }
    if name.len() > 255 {
        return bad("the name is longer than 255 characters".into());
    }
    let mut parts: Vec<&str> = name.split('/').collect();
    // The first of several components is a registry host when it looks like one (Docker's rule).
    if parts.len() > 1
        && (parts[0].contains(['.', ':', '['])
            || parts[0] == "localhost"
            || parts[0].bytes().any(|b| b.is_ascii_uppercase()))
    {
        check_registry(parts[0]).or_else(&bad)?;
        parts.remove(0);
    }
    for p in parts {
        if !is_path_component(p) {
            return bad(format!(
                "name component `{p}` must be lowercase letters and digits, joined by `.`, `_`, `__` or `-`"
            ));
        }
    }
    Ok(())
}

/// `[a-z0-9]+` joined by the separators `.`, `_`, `__` or one or more `-`.
fn is_path_component(p: &str) -> bool {
    let b = p.as_bytes();
    let alnum = |c: u8| c.is_ascii_lowercase() || c.is_ascii_digit();
    if b.is_empty() || !alnum(b[0]) || !alnum(b[b.len() - 1]) {
        return false;
    }
    let mut i = 0;
    while i < b.len() {
        if alnum(b[i]) {
            i += 1;
            continue;
        }
        let start = i;
        while i < b.len() && !alnum(b[i]) {
            i += 1;
        }
        let sep = &p[start..i];
        if !(sep == "." || sep == "_" || sep == "__" || sep.bytes().all(|c| c == b'-')) {
            return false;
        }
    }
    true
}

/// `HOST[:PORT]`: domain components (`[A-Za-z0-9]` with inner dashes) joined by `.`, or `[IPv6]`.
fn check_registry(host_port: &str) -> Result<(), String> {
    let (host, port) = if let Some(v6) = host_port.strip_prefix('[') {
        let (addr, after) = v6
            .split_once(']')
            .ok_or_else(|| format!("registry `{host_port}` has an unclosed `[`"))?;
        if addr.is_empty()
            || !addr
                .bytes()
                .all(|b| b.is_ascii_hexdigit() || b == b':' || b == b'.')
        {
            return Err(format!(
                "registry `{host_port}` is not an IPv6 address in brackets"
            ));
        }
        match after {
            "" => (addr, None),
            a => (
                addr,
                Some(a.strip_prefix(':').ok_or_else(|| {
                    format!("registry `{host_port}`: expected `:PORT` after `]`")
                })?),
            ),
        }
    } else {
        match host_port.split_once(':') {
            Some((h, p)) => (h, Some(p)),
            None => (host_port, None),
        }
    };
    if !host_port.starts_with('[') {
        let component_ok = |c: &str| {
            let b = c.as_bytes();
            !b.is_empty()
                && b[0].is_ascii_alphanumeric()
                && b[b.len() - 1].is_ascii_alphanumeric()
                && b.iter().all(|&x| x.is_ascii_alphanumeric() || x == b'-')
        };
        if !host.split('.').all(component_ok) {
            return Err(format!("registry host `{host}` is not a domain name"));
        }
    }
    if let Some(p) = port {
        if p.is_empty()
            || p.len() > 5
            || !p.bytes().all(|b| b.is_ascii_digit())
            || !matches!(p.parse::<u32>(), Ok(n) if n <= 65535)
        {
            return Err(format!("registry port `{p}` is not a port number"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_references_follow_dockers_grammar() {
        let digest = format!("sha256:{}", "ab12".repeat(16));
        for ok in [
            "alpine".to_string(),
            "alpine:3.20".into(),
            "library/alpine:latest".into(),
            "my-org/my_planner__v2:1.0-rc.1".into(),
            "ghcr.io/org/planner:v1".into(),
            "localhost:5000/planner".into(),
            "localhost/planner".into(),
            "registry.example.com:443/a/b/c:TAG_1".into(),
            "[::1]:5000/planner:x".into(),
            format!("planner@{digest}"),
            format!("ghcr.io/org/planner:v1@{digest}"),
            "a.b-c---d".into(),
        ] {
            assert_eq!(check_image_ref(&ok), Ok(()), "{ok}");
        }
        for (bad, why) in [
            ("--privileged", "starts with `-`"),
            ("-v", "starts with `-`"),
            ("", "empty"),
            ("alpine latest", "U+0020"),
            ("alpine\n", "U+000A"),
            ("Alpine", "name component `Alpine`"),
            ("alpine:", "tag ``"),
            ("alpine:-x", "tag `-x`"),
            ("alpine:.x", "tag `.x`"),
            ("a..b", "name component `a..b`"),
            ("a___b", "name component `a___b`"),
            ("a-", "name component `a-`"),
            ("/alpine", "name component ``"),
            ("alpine/", "name component ``"),
            ("org//alpine", "name component ``"),
            ("alpine@sha256:abc", "digest"),
            ("alpine@md5:0123456789abcdef0123456789abcdef", "digest"),
            ("-.io/x", "starts with `-`"),
            ("exa_mple.com/x", "registry host"),
            ("host.io:99999/x", "registry port"),
            ("host.io:/x", "registry port"),
            ("[bad/x", "unclosed"),
            ("ä", "U+00E4"),
        ] {
            let e = check_image_ref(bad).expect_err(bad).to_string();
            assert!(e.starts_with("image: ") && e.contains(why), "{bad}: {e}");
        }
        assert!(check_image_ref(&format!("{}:x", "a".repeat(300))).is_err());
        assert!(check_image_ref(&format!("a:{}", "x".repeat(129))).is_err());
    }

    #[test]
    fn display_text_refuses_control_bidi_and_invisible_characters() {
        for ok in [
            "PID baseline",
            "MPPI-6 (v2, ünïcödé)",
            "规划器 🚙",
            "a<b>&c",
        ] {
            assert_eq!(check_display_text("name", ok), Ok(()), "{ok}");
        }
        for (bad, code) in [
            ("evil\u{202E}gnp.exe", "U+202E"),
            ("a\u{2066}b", "U+2066"),
            ("a\u{2069}", "U+2069"),
            ("\u{200E}a", "U+200E"),
            ("a\u{200F}", "U+200F"),
            ("a\u{061C}", "U+061C"),
            ("pi\u{200B}d", "U+200B"),
            ("pi\u{200D}d", "U+200D"),
            ("pid\u{2060}", "U+2060"),
            ("\u{FEFF}pid", "U+FEFF"),
            ("pi\u{00AD}d", "U+00AD"),
            ("tab\there", "U+0009"),
            ("bell\u{7}", "U+0007"),
            ("c1\u{85}", "U+0085"),
            ("line\u{2028}sep", "U+2028"),
            ("tag\u{E0041}", "U+E0041"),
        ] {
            let e = check_display_text("name", bad).expect_err(bad).to_string();
            assert!(e.starts_with("name: ") && e.contains(code), "{bad:?}: {e}");
        }
        let e = check_display_text("worker_name", "ab\u{202E}").unwrap_err();
        assert_eq!(e.field, "worker_name");
        assert!(e.message.contains("character 3 is U+202E"), "{e}");
    }

    #[test]
    fn shown_text_escapes_what_the_check_refuses_and_keeps_the_rest() {
        for ok in ["PID baseline", "规划器 🚙 <b>&", ""] {
            assert!(matches!(shown(ok), Cow::Borrowed(t) if t == ok), "{ok}");
        }
        assert_eq!(shown("evil\u{202E}gnp.exe"), "evil\\u{202E}gnp.exe");
        assert_eq!(shown("pi\u{200B}d\u{E0041}"), "pi\\u{200B}d\\u{E0041}");
        assert_eq!(
            shown("a\nb\tc\rd\u{1b}[2J"),
            "a\\u{000A}b\\u{0009}c\\u{000D}d\\u{001B}[2J"
        );
        assert_eq!(
            shown_lines("a\nb\tc\rd\u{1b}[2J\u{2066}"),
            "a\nb\tc\\u{000D}d\\u{001B}[2J\\u{2066}"
        );
        // Whatever is shown passes the check, except the line feeds and tabs `shown_lines` keeps.
        for bad in [
            "evil\u{202E}gnp",
            "\u{FEFF}x\u{200D}",
            "c1\u{85}",
            "\u{2028}",
            "\u{E007F}",
        ] {
            assert_eq!(check_display_text("name", &shown(bad)), Ok(()), "{bad:?}");
            assert_eq!(
                check_display_text("name", &shown_lines(bad)),
                Ok(()),
                "{bad:?}"
            );
        }
    }
}
