//! Episodes computed in parallel, consumed in index order: a window of consecutive indices is in flight on the
//! pool; the calling thread (which holds the sinks) takes the results as they come, consumes them strictly in
//! index order, and starts the next index as each one is consumed. What is consumed therefore depends only on the
//! episodes, never on the thread count or on which episode finished first; the window only bounds memory and the
//! work wasted past the end (episodes in flight when the consumer stops are computed and dropped).

use super::GenerateError;
use rayon::ThreadPool;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;

/// Runs `job(i)` for `i = start, start + 1, ...` (below `end` when given) on `pool`, at most `window` at a time,
/// and hands each result to `consume` in index order until it returns `Ok(false)` or an error (the first error in
/// index order is returned, a job's or the consumer's).
pub fn ordered<T: Send>(
    pool: &ThreadPool,
    start: u64,
    end: Option<u64>,
    window: usize,
    job: &(dyn Fn(u64) -> Result<T, GenerateError> + Sync),
    consume: &mut dyn FnMut(u64, T) -> Result<bool, GenerateError>,
) -> Result<(), GenerateError> {
    let end = end.unwrap_or(u64::MAX);
    let window = window.max(1) as u64;
    let stop = AtomicBool::new(false);
    let (tx, rx) = mpsc::channel::<(u64, Option<Result<T, GenerateError>>)>();
    let mut outcome = Ok(());
    pool.in_place_scope(|scope| {
        let spawn = |i: u64| {
            let (tx, stop) = (tx.clone(), &stop);
            scope.spawn(move |_| {
                let r = (!stop.load(Ordering::Relaxed)).then(|| job(i));
                // The receiver lives until every job has reported.
                let _ = tx.send((i, r));
            });
        };
        let (mut next_spawn, mut next_take) = (start, start);
        let mut done: BTreeMap<u64, Option<Result<T, GenerateError>>> = BTreeMap::new();
        let mut running = true;
        while next_spawn < end && next_spawn < next_take + window {
            spawn(next_spawn);
            next_spawn += 1;
        }
        while next_take < next_spawn {
            let Ok((i, r)) = rx.recv() else {
                outcome = Err(GenerateError::Pool(
                    "a worker stopped without reporting".into(),
                ));
                break;
            };
            done.insert(i, r);
            while let Some(r) = done.remove(&next_take) {
                let i = next_take;
                next_take += 1;
                if !running {
                    continue;
                }
                let step = match r {
                    Some(r) => r.and_then(|t| consume(i, t)),
                    None => Ok(false),
                };
                match step {
                    Ok(true) => {
                        while next_spawn < end && next_spawn < next_take + window {
                            spawn(next_spawn);
                            next_spawn += 1;
                        }
                    }
                    Ok(false) => running = false,
                    Err(e) => {
                        outcome = Err(e);
                        running = false;
                    }
                }
                if !running {
                    stop.store(true, Ordering::Relaxed);
                }
            }
        }
    });
    outcome
}
