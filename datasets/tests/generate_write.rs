//! Generated episodes through the LeRobot v3 writer: the same files at one and two threads, and after an
//! interruption and a resume ([`Resume::from_writers`]), for the main and the failures dataset; both validate.

use anyhow::Result;
use datasets::generate::*;
use datasets::{DatasetKind, DatasetWriter, RecordedEpisode, WriterOptions};
use std::path::Path;

mod common;
mod gen_support;

const COMMAND: &str = "vb dataset generate --test";

/// A sink that fails after `left` appends: an interrupted run.
struct Crash<'a> {
    w: &'a mut DatasetWriter,
    left: u32,
}

impl EpisodeSink for Crash<'_> {
    fn append(&mut self, rec: &RecordedEpisode) -> Result<(), SinkError> {
        if self.left == 0 {
            return Err("interrupted".into());
        }
        self.left -= 1;
        EpisodeSink::append(self.w, rec)
    }
}

fn open(dir: &Path, spec: &datasets::DatasetSpec, o: &WriterOptions) -> Result<DatasetWriter> {
    Ok(DatasetWriter::open_with(dir, spec, COMMAND, o.clone())?)
}

/// Runs `cfg` into fresh or resumed datasets at `main` and `fail`; with `crash_after`, the main sink fails after
/// that many appends and neither writer finishes.
fn generate(
    cfg: &GenerateConfig,
    main: &Path,
    fail: &Path,
    crash_after: Option<u32>,
) -> Result<Resume> {
    // Files of a few episodes (and more windows), so each writer has pending episodes when interrupted.
    let o = WriterOptions {
        data_files_size_in_mb: 0.25,
        ..common::tiny()
    };
    let (mut m, mut f) = (
        open(main, &spec(cfg)?, &o)?,
        open(fail, &failures_spec(cfg)?, &o)?,
    );
    let resume = Resume::from_writers(cfg, &m, Some(&f))?;
    match crash_after {
        Some(left) => {
            let mut crash = Crash { w: &mut m, left };
            let r = run(cfg, &resume, &mut crash, Some(&mut f), &|_| {});
            assert!(matches!(r, Err(GenerateError::Sink { .. })), "{r:?}");
        }
        None => {
            run(cfg, &resume, &mut m, Some(&mut f), &|_| {})?;
            m.finish()?;
            f.finish()?;
        }
    }
    Ok(resume)
}

#[test]
fn written_datasets_are_the_same_at_any_thread_count_and_after_a_resume() -> Result<()> {
    let mut cfg = gen_support::config(DatasetKind::Random, 400.0 / 3600.0);
    cfg.max_time = 60.0;
    let (a, af) = (common::tmpdir("gen-a"), common::tmpdir("gen-a-failures"));
    let (b, bf) = (common::tmpdir("gen-b"), common::tmpdir("gen-b-failures"));
    cfg.threads = 1;
    generate(&cfg, &a, &af, None)?;
    cfg.threads = 2;
    generate(&cfg, &b, &bf, Some(9))?;
    let resumed = generate(&cfg, &b, &bf, None)?;
    // The writers had completed different amounts: each continues after its own last episode.
    let (m, f) = (resumed.main_next, resumed.failures_next);
    assert!(m > 0 && m < 9 && f != m, "{resumed:?}");
    common::assert_same(&a, &b);
    common::assert_same(&af, &bf);
    for d in [&a, &af] {
        let r = datasets::validate(d)?;
        assert!(r.is_ok() && r.episodes > 0, "{r:?}");
    }
    for d in [a, af, b, bf] {
        let _ = std::fs::remove_dir_all(d);
    }
    Ok(())
}
