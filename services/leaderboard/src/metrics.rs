//! `/metrics`: the store's counts in Prometheus' text exposition format (version 0.0.4), for operators.

use vb_store::Counts;

/// A label value with `\`, `"` and newlines escaped as the format requires.
fn label(v: &str) -> String {
    v.replace('\\', "\\\\")
        .replace('"', "\\\"")
        .replace('\n', "\\n")
}

/// The exposition text of `c`.
pub fn exposition(c: &Counts) -> String {
    let mut out = String::new();
    let mut family = |name: &str, help: &str, key: &str, rows: &[(String, u64)]| {
        out += &format!("# HELP {name} {help}\n# TYPE {name} gauge\n");
        for (k, n) in rows {
            out += &format!("{name}{{{key}=\"{}\"}} {n}\n", label(k));
        }
    };
    family(
        "vb_submissions",
        "Submissions by state.",
        "state",
        &c.submissions_by_state,
    );
    family(
        "vb_episodes",
        "Episodes by state (queued, leased, done, not_run).",
        "state",
        &c.episodes_by_state,
    );
    family(
        "vb_episode_outcomes",
        "Finished episodes by outcome.",
        "outcome",
        &c.outcomes,
    );
    for (name, help, v) in [
        (
            "vb_episodes_finished_last_minute",
            "Episodes finished in the last 60 s (the service's throughput).",
            c.finished_last_minute,
        ),
        (
            "vb_workers_live",
            "Workers heard from in the last 60 s.",
            c.workers_live,
        ),
        (
            "vb_worker_slots_live",
            "Episode slots of the workers heard from in the last 60 s.",
            c.slots_live,
        ),
    ] {
        out += &format!("# HELP {name} {help}\n# TYPE {name} gauge\n{name} {v}\n");
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn exposition_follows_the_text_format() {
        let c = vb_store::Counts {
            submissions_by_state: vec![("done".into(), 3), ("running".into(), 1)],
            episodes_by_state: vec![("done".into(), 3000)],
            outcomes: vec![("su\"cc\\ess\n".into(), 7)],
            finished_last_minute: 42,
            workers_live: 2,
            slots_live: 16,
        };
        let t = super::exposition(&c);
        assert!(t.contains("# TYPE vb_submissions gauge\nvb_submissions{state=\"done\"} 3\nvb_submissions{state=\"running\"} 1\n"));
        assert!(
            t.contains("vb_episode_outcomes{outcome=\"su\\\"cc\\\\ess\\n\"} 7\n"),
            "{t}"
        );
        assert!(t.contains("vb_episodes_finished_last_minute 42\n"));
        assert!(t.contains("vb_worker_slots_live 16\n"));
        // Every sample line is `name{labels} value` or `name value`.
        for line in t.lines().filter(|l| !l.starts_with('#')) {
            let (_, value) = line.rsplit_once(' ').expect(line);
            value.parse::<u64>().expect(line);
        }
    }
}
