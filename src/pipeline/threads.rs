//! Worker pools: pipelines run on a rayon pool of a chosen size.
//!
//! Work installed in the pool runs on one of its threads: each parallel step
//! it takes then joins in and wakes only the others, where a step taken from
//! outside the pool puts the caller to sleep until the step is done. A local
//! update is hundreds of small parallel steps.

use super::error::{PipelineError, Result};

/// Most worker threads a pool may have.
pub const MAX_THREADS: usize = 1024;

/// A rayon pool of `threads` threads (all cores when `None`), to run work on.
pub fn worker_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut pool = rayon::ThreadPoolBuilder::new();
    match threads {
        None => {}
        Some(n) if !(1..=MAX_THREADS).contains(&n) => {
            return Err(PipelineError::setting("threads", format!("must be between 1 and {MAX_THREADS}, got {n}")));
        }
        Some(n) => pool = pool.num_threads(n),
    }
    pool.build().map_err(|e| PipelineError::Unsuitable(format!("starting the worker threads: {e}")))
}

/// Runs `f` on a pool of `threads` threads (all cores when `None`).
pub fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T> {
    Ok(worker_pool(threads)?.install(f))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_runs_on_a_pool_thread_of_the_size_asked() {
        // On the caller's thread, every parallel step would put it to sleep
        // and wake it: a local update's hundreds of steps paid for that.
        assert!(with_threads(None, || rayon::current_thread_index().is_some()).unwrap());
        assert_eq!(with_threads(Some(3), rayon::current_num_threads).unwrap(), 3);
        let refused = with_threads(Some(0), || ()).unwrap_err();
        assert_eq!(refused.bad_setting(), Some("threads"));
    }
}
