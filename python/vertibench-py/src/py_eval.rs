//! In-process evaluation: `vertibench.evaluate` runs a Python planner (or a built-in one) on the benchmark with
//! `vb eval`'s own runner and writes `vb eval`'s files. A Python planner is called back at its control rate, one
//! episode at a time; simulated time is frozen while it thinks, as in every benchmark episode.
//!
//! The episodes run on an evaluation thread in a rayon pool of this call's own (never the global pool, which does
//! not survive `os.fork()`). The calling thread stays in Python: it runs a Python planner's calls
//! ([`planner`]), prints progress through `sys.stderr` and checks for signals every 50 ms, so Ctrl-C stops the
//! evaluation within a second and what finished is kept, written and returned.

mod planner;

use planner::{Answered, Call, Caller, Proxy, Shared};
use pyo3::exceptions::{PyKeyboardInterrupt, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sim_core::episode::EpisodeConfig;
use sim_core::observe::CropSpec;
use sim_core::planner::Planner;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::thread::ScopedJoinHandle;
use std::time::Duration;

/// How often the calling thread checks for signals while it waits.
const SIGNAL_CHECK: Duration = Duration::from_millis(50);

/// What the evaluation thread tells the calling thread.
enum ToCaller {
    /// The evaluation is prepared: `kept` of its `total` episodes were already in `out`.
    Started {
        kept: usize,
        total: usize,
    },
    Progress {
        done: usize,
        total: usize,
        secs: f64,
    },
    Call(Call),
    Done(Result<Vec<eval::EpisodeRow>, eval::EvalError>),
}

impl From<Call> for ToCaller {
    fn from(c: Call) -> Self {
        ToCaller::Call(c)
    }
}

/// The episode table of rows: `episodes.csv`'s columns at full precision, then `detail`.
fn table<'py>(py: Python<'py>, rows: &[eval::EpisodeRow]) -> PyResult<Bound<'py, PyDict>> {
    use eval::report::ColumnValues as V;
    let d = PyDict::new(py);
    for c in eval::report::episode_columns(rows) {
        match c.values {
            V::Text(v) => d.set_item(c.name, v)?,
            V::Int(v) => d.set_item(c.name, v)?,
            V::Float(v, _) => d.set_item(c.name, v)?,
            V::OptFloat(v, _) => d.set_item(c.name, v)?,
            V::OptInt(v) => d.set_item(c.name, v)?,
        }
    }
    // `scale` is text in the CSV only to print it at full precision.
    d.set_item("scale", rows.iter().map(|r| r.scale).collect::<Vec<_>>())?;
    d.set_item(
        "detail",
        rows.iter().map(|r| r.detail.as_str()).collect::<Vec<_>>(),
    )?;
    Ok(d)
}

/// An evaluation error as the Python exception users expect.
fn py_error(e: eval::EvalError) -> PyErr {
    match e {
        eval::EvalError::Io { .. } | eval::EvalError::Results(_) => {
            PyOSError::new_err(e.to_string())
        }
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// Writes `text` to Python's `sys.stderr` (a notebook shows it), when there is one.
fn say(py: Python<'_>, text: &str) -> PyResult<()> {
    let err = py.import("sys")?.getattr("stderr")?;
    if err.is_none() {
        return Ok(());
    }
    err.call_method1("write", (text,))?;
    err.call_method0("flush")?;
    Ok(())
}

/// The calling thread while the evaluation runs: it answers a Python planner's calls, prints, and stops the
/// evaluation on a signal, keeping a signal handler's error other than `KeyboardInterrupt` to raise once the
/// finished episodes are written.
struct Watch<'a> {
    cancel: &'a AtomicBool,
    caller: Option<&'a Caller>,
    out: &'a Path,
    progress: bool,
    raised: Option<PyErr>,
    /// Episodes of the evaluation (known once it started).
    total: usize,
    /// Whether a progress line is on the screen.
    shown: bool,
}

impl Watch<'_> {
    /// An exception raised in the calling thread by a signal handler: the evaluation stops.
    fn signal(&mut self, py: Python<'_>, e: PyErr) {
        self.cancel.store(true, Ordering::SeqCst);
        if !e.is_instance_of::<PyKeyboardInterrupt>(py) && self.raised.is_none() {
            self.raised = Some(e);
        }
    }

    /// Serves the evaluation thread until it is done; its result.
    fn serve(
        &mut self,
        py: Python<'_>,
        mut rx: Receiver<ToCaller>,
        worker: &ScopedJoinHandle<'_, ()>,
    ) -> PyResult<Vec<eval::EpisodeRow>> {
        loop {
            let (msg, back) = py.detach(move || (rx.recv_timeout(SIGNAL_CHECK), rx));
            rx = back;
            let msg = match msg {
                Ok(m) => Some(m),
                // The thread sends `Done` before it ends; if it ended without, it panicked.
                Err(_) if worker.is_finished() => match rx.try_recv() {
                    Ok(m) => Some(m),
                    Err(_) => return Err(PyRuntimeError::new_err(THREAD_FAILED)),
                },
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => None,
            };
            let handled = match msg {
                Some(ToCaller::Done(r)) => return r.map_err(py_error),
                Some(m) => self.handle(py, m),
                None => Ok(()),
            };
            // Printing runs Python code, where Ctrl-C may land too.
            if let Err(e) = handled.and_then(|_| py.check_signals()) {
                self.signal(py, e);
            }
        }
    }

    fn handle(&mut self, py: Python<'_>, msg: ToCaller) -> PyResult<()> {
        match msg {
            ToCaller::Call(c) => match self.caller {
                Some(caller) if !self.cancel.load(Ordering::SeqCst) => {
                    if let Answered::Interrupted = caller.call(py, c) {
                        self.signal(py, PyKeyboardInterrupt::new_err(()));
                    }
                }
                _ => planner::refuse(c),
            },
            ToCaller::Started { kept, total } => {
                self.total = total;
                if kept > 0 {
                    let out = self.out.display();
                    say(py, &format!("vertibench.evaluate: resuming in {out}: keeping the {kept} of {total} episodes it holds\n"))?;
                }
            }
            ToCaller::Progress { done, total, secs } => {
                if self.progress && (done.is_multiple_of(10) || done == total) {
                    self.shown = true;
                    say(py, &format!("\r{done}/{total} episodes, {secs:.0} s "))?;
                }
            }
            ToCaller::Done(_) => {}
        }
        Ok(())
    }
}

const THREAD_FAILED: &str = "the evaluation thread failed (a bug: please report it)";

/// Runs an evaluation and writes `vb eval`'s files to `out`; returns its episode table (`episodes.csv`'s columns
/// at full precision, then `detail`) and whether every selected episode finished (false after Ctrl-C). `planner`
/// is the name of a built-in planner (run in parallel on `num_threads` threads) or a
/// `vertibench.planner.Planner` (run one episode at a time in the calling thread, `identity` its
/// `eval::PlannerIdentity` as JSON, each call failed with reason `planner_timeout` past `step_timeout` seconds).
///
/// One piece on purpose: the evaluation thread, the channel to the calling thread, the proxies' factory and the
/// watch loop that serves the Python planner's calls borrow one another inside one `std::thread::scope`; split,
/// each part would take the others' borrows, and the handshake (started, progress, done; Ctrl-C; the note on an
/// interrupted run) reads in order here.
#[pyfunction]
#[pyo3(signature = (planner, out, task_dir, tasks="all", vehicle="hmmwv", scale=None, rules="paper",
    progress=true, identity=None, step_timeout=None, num_threads=None, perception="ideal"))]
#[allow(clippy::too_many_arguments)]
pub fn evaluate<'py>(
    py: Python<'py>,
    planner: Bound<'py, PyAny>,
    out: PathBuf,
    task_dir: PathBuf,
    tasks: &str,
    vehicle: &str,
    scale: Option<f64>,
    rules: &str,
    progress: bool,
    identity: Option<&str>,
    step_timeout: Option<f64>,
    num_threads: Option<usize>,
    perception: &str,
) -> PyResult<(Bound<'py, PyDict>, bool)> {
    let episode = rules_named(rules)?;
    let perception = eval::perception_profile(perception).map_err(py_error)?;
    let step_timeout = step_timeout_of(step_timeout)?;
    if num_threads == Some(0) {
        return Err(PyValueError::new_err("num_threads must be at least 1"));
    }
    let builtin: Option<eval::Builtin> = match planner.extract::<String>() {
        Ok(n) => Some(eval::Builtin::resolve(&n, None).map_err(|e| py_error(e.into()))?),
        Err(_) => None,
    };
    let (name, identity) = match &builtin {
        Some(b) => (b.name().to_string(), eval::PlannerIdentity::of_builtin(b)),
        None => {
            let id: eval::PlannerIdentity = serde_json::from_str(identity.unwrap_or("null"))
                .map_err(|e| PyValueError::new_err(format!("invalid planner identity: {e}")))?;
            (planner.getattr("name")?.extract::<String>()?, id)
        }
    };
    let cfg = eval::EvalConfig {
        planner: name.into(),
        identity: Some(identity),
        task_dir,
        tasks: tasks.to_string(),
        vehicle: vehicle.into(),
        scale,
        out: out.clone(),
        out_param: "out=".into(),
        episode,
        perception,
    };
    let threads = match &builtin {
        Some(_) => num_threads.unwrap_or(0),
        None => 1,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("vb-evaluate-{i}"))
        .build()
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    let (to_caller, from_worker) = mpsc::channel::<ToCaller>();
    let caller = match &builtin {
        Some(_) => None,
        None => Some(Caller {
            glue: py.import("vertibench.planner")?.into_any().unbind(),
            shared: Shared::new(py, step_timeout)?,
        }),
    };
    let rate: f64 = match &builtin {
        Some(_) => 0.0,
        None => planner.getattr("control_rate_hz")?.extract()?,
    };
    let crop = match &builtin {
        Some(_) => None,
        None => crop_of(&planner)?,
    };
    let obj = planner.clone().unbind();
    let make = || -> Box<dyn Planner> {
        match &caller {
            None => builtin.as_ref().expect("a builtin without a caller").make(),
            Some(c) => Box::new(Proxy {
                obj: Python::attach(|py| obj.clone_ref(py)),
                to_caller: to_caller.clone(),
                shared: c.shared.clone(),
                rate,
                crop,
                world: None,
                sync: None,
            }),
        }
    };
    let cancel = AtomicBool::new(false);
    let mut watch = Watch {
        cancel: &cancel,
        caller: caller.as_ref(),
        out: &out,
        progress,
        raised: None,
        total: 0,
        shown: false,
    };
    let result = std::thread::scope(|s| {
        let tx = to_caller.clone();
        let worker = s.spawn(|| {
            let tx = tx;
            let r = pool.install(|| {
                let prepared = eval::prepare(&cfg)?;
                let _ = tx.send(ToCaller::Started {
                    kept: prepared.kept(),
                    total: prepared.total(),
                });
                let report = |done, total, secs| {
                    let _ = tx.send(ToCaller::Progress { done, total, secs });
                };
                prepared.run(&make, &cancel, &report)
            });
            let _ = tx.send(ToCaller::Done(r));
        });
        let r = watch.serve(py, from_worker, &worker);
        match py.detach(|| worker.join()) {
            Ok(()) => r,
            Err(_) => Err(PyRuntimeError::new_err(THREAD_FAILED)),
        }
    });
    let rows = result?;
    let total = watch.total;
    let complete = rows.len() == total;
    let summary = eval::summary::summarise(&rows);
    py.detach(|| eval::report::write(&out, &rows, &summary))
        .map_err(|e| PyOSError::new_err(e.to_string()))?;
    let note = closing_note(watch.shown, complete, rows.len(), total, &out);
    if !note.is_empty() {
        if let Err(e) = say(py, &note) {
            watch.signal(py, e);
        }
    }
    // Another Ctrl-C while stopping changes nothing (the finished episodes are returned); handled here, it is not
    // raised at the caller's next line instead.
    if cancel.load(Ordering::SeqCst) {
        if let Err(e) = py.check_signals() {
            watch.signal(py, e);
        }
    }
    if let Some(e) = watch.raised {
        return Err(e);
    }
    Ok((table(py, &rows)?, complete))
}

/// The rules `vertibench.evaluate` takes by name.
fn rules_named(rules: &str) -> PyResult<EpisodeConfig> {
    match rules {
        "paper" => Ok(EpisodeConfig::default()),
        "release" => Ok(EpisodeConfig::release()),
        o => Err(PyValueError::new_err(format!(
            "rules `{o}` is not `paper` or `release`"
        ))),
    }
}

fn step_timeout_of(step_timeout: Option<f64>) -> PyResult<Option<Duration>> {
    match step_timeout {
        None => Ok(None),
        Some(s) if s.is_finite() && s > 0.0 => Ok(Some(Duration::from_secs_f64(s))),
        Some(s) => Err(PyValueError::new_err(format!(
            "step_timeout must be a positive number of seconds or None, not {s}"
        ))),
    }
}

/// The local map crop a Python planner asks for (`crop_size` 0: none).
fn crop_of(planner: &Bound<'_, PyAny>) -> PyResult<Option<CropSpec>> {
    let size: usize = planner.getattr("crop_size")?.extract()?;
    let resolution: f64 = planner.getattr("crop_resolution")?.extract()?;
    Ok((size > 0).then_some(CropSpec { size, resolution }))
}

/// What `evaluate` says as it returns: a line break after its progress line, and how to resume an interrupted run.
fn closing_note(
    shown: bool,
    complete: bool,
    kept: usize,
    total: usize,
    out: &std::path::Path,
) -> String {
    let mut note = String::new();
    if shown {
        note.push('\n');
    }
    if !complete {
        note += &format!("vertibench.evaluate: interrupted; {kept} of {total} episodes are kept in {}: call evaluate again with the same out= to resume\n", out.display());
    }
    note
}
