//! `/metrics`: the store's counts and this leaderboard's request latencies in Prometheus' text exposition format
//! (version 0.0.4), for operators.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;
use vb_store::Counts;

/// Upper bounds of the request-latency histogram's buckets, s.
const BUCKETS: [f64; 10] = [0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 1.0, 5.0];

/// A latency histogram of the requests this leaderboard answered (cumulative counts, as Prometheus wants them).
#[derive(Default)]
pub struct Latency {
    /// Requests at most as long as each bucket's bound, then all requests.
    counts: [AtomicU64; BUCKETS.len() + 1],
    /// Sum of the durations, µs.
    sum_us: AtomicU64,
}

impl Latency {
    pub fn record(&self, d: Duration) {
        let s = d.as_secs_f64();
        for (i, b) in BUCKETS.iter().enumerate() {
            if s <= *b {
                self.counts[i].fetch_add(1, Ordering::Relaxed);
            }
        }
        self.counts[BUCKETS.len()].fetch_add(1, Ordering::Relaxed);
        self.sum_us
            .fetch_add(d.as_micros() as u64, Ordering::Relaxed);
    }

    fn exposition(&self) -> String {
        let name = "vb_http_request_duration_seconds";
        let mut out =
            format!("# HELP {name} Requests answered by this leaderboard, by duration.\n# TYPE {name} histogram\n");
        for (i, b) in BUCKETS.iter().enumerate() {
            out += &format!(
                "{name}_bucket{{le=\"{b}\"}} {}\n",
                self.counts[i].load(Ordering::Relaxed)
            );
        }
        let n = self.counts[BUCKETS.len()].load(Ordering::Relaxed);
        out += &format!("{name}_bucket{{le=\"+Inf\"}} {n}\n");
        out += &format!(
            "{name}_sum {}\n{name}_count {n}\n",
            self.sum_us.load(Ordering::Relaxed) as f64 / 1e6
        );
        out
    }
}

/// A label value with `\`, `"` and newlines escaped as the format requires.
fn label(v: &str) -> String {
    v.replace('\\', "\\\\")
        .replace('"', "\\\"")
        .replace('\n', "\\n")
}

/// The exposition text of `c` and of the request latencies.
pub fn exposition(c: &Counts, latency: &Latency) -> String {
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
    // Reasons are machine-readable names (`planner_crash`); anything else a worker reported counts as `other`, so
    // the label set stays small and plain.
    let mut failures = std::collections::BTreeMap::<String, u64>::new();
    for (reason, n) in &c.failures_by_reason {
        let plain = !reason.is_empty()
            && reason.len() <= 40
            && reason.bytes().all(|b| b.is_ascii_lowercase() || b == b'_');
        *failures
            .entry(if plain {
                reason.clone()
            } else {
                "other".into()
            })
            .or_default() += n;
    }
    family(
        "vb_episode_failures",
        "Finished episodes that did not succeed, by reason.",
        "reason",
        &failures.into_iter().collect::<Vec<_>>(),
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
    let name = "vb_lease_drops_total";
    out += &format!(
        "# HELP {name} Leases that ended without a result (expired in a worker's hands, or released).\n# TYPE {name} counter\n{name} {}\n",
        c.lease_drops
    );
    out + &latency.exposition()
}

#[cfg(test)]
mod tests {
    #[test]
    fn exposition_follows_the_text_format() {
        let c = vb_store::Counts {
            submissions_by_state: vec![("done".into(), 3), ("running".into(), 1)],
            episodes_by_state: vec![("done".into(), 3000)],
            outcomes: vec![("su\"cc\\ess\n".into(), 7)],
            failures_by_reason: vec![
                ("planner_crash".into(), 2),
                ("stuck".into(), 9),
                ("<b>odd</b>".into(), 1),
                ("Weird".into(), 1),
            ],
            finished_last_minute: 42,
            workers_live: 2,
            slots_live: 16,
            lease_drops: 5,
        };
        let latency = super::Latency::default();
        for ms in [0.5, 3.0, 30.0, 2000.0, 9000.0] {
            latency.record(std::time::Duration::from_secs_f64(ms / 1000.0));
        }
        let t = super::exposition(&c, &latency);
        assert!(t.contains("# TYPE vb_submissions gauge\nvb_submissions{state=\"done\"} 3\nvb_submissions{state=\"running\"} 1\n"));
        assert!(
            t.contains("vb_episode_outcomes{outcome=\"su\\\"cc\\\\ess\\n\"} 7\n"),
            "{t}"
        );
        assert!(t.contains("vb_episodes_finished_last_minute 42\n"));
        assert!(t.contains(
            "vb_episode_failures{reason=\"other\"} 2\nvb_episode_failures{reason=\"planner_crash\"} 2\n\
             vb_episode_failures{reason=\"stuck\"} 9\n"
        ));
        assert!(t.contains("vb_worker_slots_live 16\n"));
        assert!(t.contains("vb_lease_drops_total 5\n"));
        // Cumulative buckets: 0.5 ms is under every bound, 9 s under none.
        for (le, n) in [
            ("0.001", 1),
            ("0.005", 2),
            ("0.05", 3),
            ("5", 4),
            ("+Inf", 5),
        ] {
            let line = format!("vb_http_request_duration_seconds_bucket{{le=\"{le}\"}} {n}\n");
            assert!(t.contains(&line), "{line} in {t}");
        }
        assert!(t.contains("vb_http_request_duration_seconds_count 5\n"));
        // Every sample line is `name{labels} value` or `name value`.
        for line in t.lines().filter(|l| !l.starts_with('#')) {
            let (_, value) = line.rsplit_once(' ').expect(line);
            value.parse::<f64>().expect(line);
        }
    }
}
