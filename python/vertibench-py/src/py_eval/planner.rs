//! A Python planner in an evaluation: the episode runs on an evaluation thread, the planner's `reset` and `act` on
//! the thread that called `evaluate` (Python code runs where users expect it, and Ctrl-C raises `KeyboardInterrupt`
//! in it). The runner's side ([`Proxy`]) turns each call into Python arguments, sends it to the caller's thread
//! ([`Call`]) and waits for the answer, which [`Caller::call`] gives.
//!
//! The per-step deadline (`step_timeout=`) is wall-clock only and lives here: simulated time stays frozen while the
//! planner thinks. A call still running at its deadline is stopped by raising [`StepTimeout`] in the caller's thread
//! (`PyThreadState_SetAsyncExc`, again every second while it runs); a call blocked in native code cannot be stopped
//! and fails once it returns. Either way the episode fails with reason `planner_timeout`.

use crate::convert::vehicle_info;
use numpy::ndarray::Array2;
use numpy::IntoPyArray;
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use pyo3::PyTypeInfo;
use sim_core::observe::{self, CropSpec};
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};
use sim_core::world::World;
use std::os::raw::c_long;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError, Sender, SyncSender};
use std::sync::Arc;
use std::time::{Duration, Instant};

pyo3::create_exception!(
    vertibench,
    StepTimeout,
    pyo3::exceptions::PyBaseException,
    "Raised in a Python planner whose reset or act runs past evaluate's step_timeout (a BaseException, so that \
     `except Exception` does not catch it); the episode fails with reason planner_timeout."
);

/// The least time `reset` gets, whatever `step_timeout` says (as the benchmark service gives a planner to start).
const RESET_DEADLINE: Duration = Duration::from_secs(10);

/// How often a call that goes on past its deadline is stopped again (a planner may catch the first stop).
const STOP_AGAIN: Duration = Duration::from_secs(1);

/// What the runner asks of the planner.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    Reset,
    Act,
}

impl Method {
    fn glue(self) -> &'static str {
        match self {
            Method::Reset => "_core_reset",
            Method::Act => "_core_act",
        }
    }
}

/// One call of the planner, sent to the caller's thread; `reply` gets its answer.
pub struct Call {
    id: u64,
    method: Method,
    /// The glue function's arguments, the planner first.
    args: Py<PyTuple>,
    /// For messages: `act at t = 3.05 s`.
    what: String,
    deadline: Option<Duration>,
    reply: SyncSender<Result<Action, PlannerError>>,
}

/// State shared by the runner's side and the caller's thread.
pub struct Shared {
    /// The id of the call the caller's thread is in, 0 when none (read and written with the GIL held).
    in_call: AtomicU64,
    next_id: AtomicU64,
    /// A [`StepTimeout`] was raised in the caller's thread and may still be pending there.
    stopped: AtomicBool,
    /// The caller's thread (`threading.get_ident()`).
    thread: c_long,
    step_timeout: Option<Duration>,
}

impl Shared {
    pub fn new(py: Python<'_>, step_timeout: Option<Duration>) -> PyResult<Arc<Shared>> {
        let ident: u64 = py
            .import("threading")?
            .call_method0("get_ident")?
            .extract()?;
        Ok(Arc::new(Shared {
            in_call: AtomicU64::new(0),
            next_id: AtomicU64::new(1),
            stopped: AtomicBool::new(false),
            // `unsigned long` in C; pyo3 declares it `long`: the same bits.
            thread: ident as c_long,
            step_timeout,
        }))
    }

    /// Raises [`StepTimeout`] in the caller's thread if it is still in call `id`.
    fn stop(&self, id: u64) {
        Python::attach(|py| {
            if self.in_call.load(Ordering::SeqCst) != id {
                return;
            }
            let exc = StepTimeout::type_object(py);
            // SAFETY: the GIL is held (as the function requires) and `exc` is a live exception type; the function
            // takes its own reference.
            unsafe { pyo3::ffi::PyThreadState_SetAsyncExc(self.thread, exc.as_ptr()) };
            self.stopped.store(true, Ordering::SeqCst);
        })
    }

    /// Drops a [`StepTimeout`] still pending in the caller's thread (the call ended before raising it).
    fn clear_stop(&self, _py: Python<'_>) {
        if self.stopped.swap(false, Ordering::SeqCst) {
            // SAFETY: the GIL is held (`_py`); a null exception clears the thread's pending one.
            unsafe { pyo3::ffi::PyThreadState_SetAsyncExc(self.thread, std::ptr::null_mut()) };
        }
    }
}

/// The planner as the runner sees it: each call goes to the caller's thread.
pub struct Proxy<T: From<Call> + Send> {
    pub obj: Py<PyAny>,
    pub to_caller: Sender<T>,
    pub shared: Arc<Shared>,
    pub rate: f64,
    pub crop: Option<CropSpec>,
    pub world: Option<World>,
    /// The planner's believed maps under a map-degrading perception profile (`None` under ground truth).
    pub sync: Option<perception::sync::MapSync>,
}

impl<T: From<Call> + Send> Proxy<T> {
    /// Sends a call and waits for its answer, stopping it at its deadline.
    fn ask(
        &self,
        method: Method,
        args: Py<PyTuple>,
        what: String,
        deadline: Option<Duration>,
    ) -> Result<Action, PlannerError> {
        let id = self.shared.next_id.fetch_add(1, Ordering::SeqCst);
        let (reply, answer) = mpsc::sync_channel(1);
        let call = Call {
            id,
            method,
            args,
            what,
            deadline,
            reply,
        };
        let gone = || PlannerError::Other("the evaluation stopped".into());
        self.to_caller.send(call.into()).map_err(|_| gone())?;
        let mut wait = deadline;
        loop {
            let r = match wait {
                Some(w) => answer.recv_timeout(w),
                None => answer.recv().map_err(|_| RecvTimeoutError::Disconnected),
            };
            match r {
                Ok(a) => return a,
                Err(RecvTimeoutError::Timeout) => {
                    self.shared.stop(id);
                    wait = Some(STOP_AGAIN);
                }
                Err(RecvTimeoutError::Disconnected) => return Err(gone()),
            }
        }
    }

    fn reset_args(&mut self, py: Python<'_>, ctx: &PlannerContext<'_>) -> PyResult<Py<PyTuple>> {
        let (t, w) = (ctx.task, ctx.world);
        let task = crate::convert::task(py, t, w)?;
        let maps = crate::convert::maps(py, w)?;
        maps.set_item("believed", ctx.believed)?;
        let vehicle = vehicle_info(py, ctx.vehicle)?;
        self.world = self.crop.map(|_| w.clone());
        self.sync = ctx.believed.then(|| perception::sync::MapSync::new(w));
        Ok((self.obj.clone_ref(py), task, vehicle, maps, ctx.sim_dt)
            .into_pyobject(py)?
            .unbind())
    }

    /// The step's arguments: the state, the crops (of the believed world under a map-degrading profile) and the
    /// patch of believed maps that changed since the last step (`None` when none did).
    fn act_args(&mut self, py: Python<'_>, obs: &Observation) -> PyResult<Py<PyTuple>> {
        let s = &obs.state;
        let state = vec![
            s.time,
            s.position[0],
            s.position[1],
            s.position[2],
            s.roll,
            s.pitch,
            s.yaw,
            s.velocity[0],
            s.velocity[1],
            s.velocity[2],
            s.angular_velocity[0],
            s.angular_velocity[1],
            s.angular_velocity[2],
            s.speed,
            s.steering,
        ];
        let world = obs.belief.as_deref().or(self.world.as_ref());
        let crops = match (&self.crop, world) {
            (Some(c), Some(w)) => {
                let n = c.size * c.size;
                let (mut e, mut m, mut o) = (vec![0f32; n], vec![0u8; n], vec![0u8; n]);
                observe::elevation_crop(w, s, c, &mut e);
                observe::semantics_crop(w, s, c, &mut m);
                observe::obstacle_crop(w, s, c, &mut o);
                let err = |e: numpy::ndarray::ShapeError| PyRuntimeError::new_err(e.to_string());
                let sq = (c.size, c.size);
                Some((
                    Array2::from_shape_vec(sq, e).map_err(err)?.into_pyarray(py),
                    Array2::from_shape_vec(sq, m).map_err(err)?.into_pyarray(py),
                    Array2::from_shape_vec(sq, o).map_err(err)?.into_pyarray(py),
                ))
            }
            _ => None,
        };
        let update = match (&mut self.sync, &obs.belief) {
            (Some(sync), Some(b)) => sync.update(b).map(|p| patch(py, p)).transpose()?,
            _ => None,
        };
        Ok((self.obj.clone_ref(py), state, crops, update)
            .into_pyobject(py)?
            .unbind())
    }
}

/// `Maps.update`'s arguments: `(x0, y0, elevation, obstacles)`.
type PatchArgs<'py> = (
    usize,
    usize,
    Bound<'py, numpy::PyArray2<f32>>,
    Bound<'py, numpy::PyArray2<u8>>,
);

/// A patch of believed maps as `Maps.update` takes it.
fn patch(py: Python<'_>, p: perception::sync::MapPatch) -> PyResult<PatchArgs<'_>> {
    let err = |e: numpy::ndarray::ShapeError| PyRuntimeError::new_err(e.to_string());
    let shape = (p.ny, p.nx);
    Ok((
        p.x0,
        p.y0,
        Array2::from_shape_vec(shape, p.heights)
            .map_err(err)?
            .into_pyarray(py),
        Array2::from_shape_vec(shape, p.obstacles)
            .map_err(err)?
            .into_pyarray(py),
    ))
}

/// The arguments could not be made: a bug of ours or an exhausted machine, not the planner's doing.
fn args_failed(e: PyErr) -> PlannerError {
    PlannerError::Other(format!("cannot pass the episode to the planner: {e}"))
}

impl<T: From<Call> + Send> Planner for Proxy<T> {
    fn name(&self) -> &str {
        "python"
    }
    fn control_rate_hz(&self) -> f64 {
        self.rate
    }
    /// A Python planner's `Maps` are the believed ones under a map-degrading profile, updated in place.
    fn reads_belief(&self) -> bool {
        true
    }
    fn reset(&mut self, ctx: &PlannerContext<'_>) -> Result<(), PlannerError> {
        let args = Python::attach(|py| self.reset_args(py, ctx)).map_err(args_failed)?;
        let deadline = self.shared.step_timeout.map(|d| d.max(RESET_DEADLINE));
        self.ask(Method::Reset, args, "reset".into(), deadline)
            .map(|_| ())
    }
    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError> {
        let args = Python::attach(|py| self.act_args(py, obs)).map_err(args_failed)?;
        let what = format!("act at t = {:.2} s", obs.state.time);
        self.ask(Method::Act, args, what, self.shared.step_timeout)
    }
}

/// The caller's side: runs the calls of the planner in the thread that called `evaluate`.
pub struct Caller {
    pub glue: Py<PyAny>,
    pub shared: Arc<Shared>,
}

/// How a call ended, for the caller's loop.
pub enum Answered {
    /// Answered (an action, or the planner's failure).
    Done,
    /// Ctrl-C in the planner: the evaluation stops.
    Interrupted,
}

impl Caller {
    /// Runs `call` and sends its answer.
    pub fn call(&self, py: Python<'_>, call: Call) -> Answered {
        let Call {
            id,
            method,
            args,
            what,
            deadline,
            reply,
        } = call;
        self.shared.in_call.store(id, Ordering::SeqCst);
        let t0 = Instant::now();
        let r = self.glue.call_method1(py, method.glue(), args.bind(py));
        let took = t0.elapsed();
        self.shared.in_call.store(0, Ordering::SeqCst);
        self.shared.clear_stop(py);
        let limit = |d: Duration| {
            let d = d.as_secs_f64();
            match (method, self.shared.step_timeout) {
                (Method::Reset, Some(s)) => format!(
                    "{d:.1} s (step_timeout={} s; reset gets at least {} s)",
                    s.as_secs_f64(),
                    RESET_DEADLINE.as_secs()
                ),
                _ => format!("step_timeout={d} s"),
            }
        };
        let (answer, interrupted) = match r {
            Err(e) if e.is_instance_of::<StepTimeout>(py) => (
                Err(PlannerError::Timeout(format!(
                    "{what} was stopped after {:.2} s, past its deadline {}",
                    took.as_secs_f64(),
                    limit(deadline.unwrap_or_default())
                ))),
                false,
            ),
            Err(e) if e.is_instance_of::<PyKeyboardInterrupt>(py) => (
                Err(PlannerError::Other("interrupted (Ctrl-C)".into())),
                true,
            ),
            Err(e) => (Err(crashed(py, e)), false),
            Ok(v) => match deadline {
                Some(d) if took > d => (
                    Err(PlannerError::Timeout(format!(
                        "{what} took {:.2} s, past its deadline {}",
                        took.as_secs_f64(),
                        limit(d)
                    ))),
                    false,
                ),
                _ => match method {
                    Method::Reset => (Ok(Action::default()), false),
                    Method::Act => match v.extract::<(f64, f64, f64)>(py) {
                        Ok((steering, throttle, brake)) => (
                            Ok(Action {
                                steering,
                                throttle,
                                brake,
                            }),
                            false,
                        ),
                        Err(e) => (Err(crashed(py, e)), false),
                    },
                },
            },
        };
        // The runner may have given up waiting (the evaluation failed): nothing to answer then.
        let _ = reply.send(answer);
        if interrupted {
            Answered::Interrupted
        } else {
            Answered::Done
        }
    }
}

/// Answers a call without running it: the evaluation is stopping.
pub fn refuse(call: Call) {
    let _ = call
        .reply
        .send(Err(PlannerError::Other("interrupted (Ctrl-C)".into())));
}

/// A Python exception as the planner's crash: its traceback, then the exception.
fn crashed(py: Python<'_>, e: PyErr) -> PlannerError {
    let tb = e
        .traceback(py)
        .and_then(|t| t.format().ok())
        .unwrap_or_default();
    PlannerError::Crashed(format!("{tb}{e}"))
}
