//! Thread pools that survive `fork()`. rayon's global pool does not: a forked child inherits the pool's state but
//! none of its threads, so its first parallel call waits forever (gymnasium's `AsyncVectorEnv` forks after making a
//! first environment in the parent). So this extension never uses the global pool: each vector environment owns a
//! pool, rebuilt in a process that is not the one that built it, and one-off work runs on a pool made for it.

use pyo3::exceptions::PyRuntimeError;
use pyo3::PyResult;

/// A rayon pool owned by one object, remade after a fork.
pub struct ForkSafePool {
    threads: usize,
    /// The pool and the process that made it.
    pool: Option<(u32, rayon::ThreadPool)>,
}

/// The number of threads to use when the caller does not say: every core, at most `work` items' worth.
pub fn default_threads(work: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    cores.min(work).max(1)
}

fn build(threads: usize) -> PyResult<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start {threads} threads: {e}")))
}

impl ForkSafePool {
    pub fn new(threads: usize) -> Self {
        ForkSafePool {
            threads: threads.max(1),
            pool: None,
        }
    }

    /// True when work should run on the calling thread (one thread: no pool at all).
    pub fn serial(&self) -> bool {
        self.threads == 1
    }

    /// The pool of this process, made on first use here. A pool inherited through `fork()` is forgotten, not
    /// dropped: its threads do not exist in this process and dropping would signal them.
    pub fn get(&mut self) -> PyResult<&rayon::ThreadPool> {
        let pid = std::process::id();
        if self.pool.as_ref().is_some_and(|(p, _)| *p != pid) {
            if let Some((_, stale)) = self.pool.take() {
                std::mem::forget(stale);
            }
        }
        if self.pool.is_none() {
            self.pool = Some((pid, build(self.threads)?));
        }
        match &self.pool {
            Some((_, p)) => Ok(p),
            None => Err(PyRuntimeError::new_err("thread pool missing")),
        }
    }
}

/// Runs `f` on a pool of `threads` made for it (any `par_iter` inside uses it), then lets the pool go.
pub fn on_local_pool<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> PyResult<R> {
    Ok(build(threads.max(1))?.install(f))
}
