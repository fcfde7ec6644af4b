//! Work that needs nothing the planner finds (the input's own metrics),
//! run on the cores the planner leaves idle.
//!
//! The planner's stages alternate between parallel loops that fill every
//! core and serial steps (the graph's searches, the extrusion, the
//! verification) that leave all but one idle. Work joined beside it on
//! the same thread pool shares the cores equally from the start, so it
//! slows the parallel loops by its whole cost and is done before the
//! serial steps come. On threads of their own at the lowest priority it
//! runs where a core would idle, and the planner's loops keep every core
//! (dome_cut's 700 k-waypoint stand-in: the input's 1.5 s of queries
//! fit in the 2.4 core-seconds its plan leaves idle on two cores).

/// `main` on this thread, and `beside` on a pool of its own (as many
/// threads as rayon's) whose threads yield to every other thread of
/// normal priority; both answers once both are done. A panic in either
/// is raised here. Where the pool cannot be made, the two are joined on
/// rayon's pool.
pub(super) fn beside_idle<A, B>(
    main: impl FnOnce() -> A + Send,
    beside: impl FnOnce() -> B + Send,
) -> (A, B)
where
    A: Send,
    B: Send,
{
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(rayon::current_num_threads())
        .thread_name(|i| format!("maamplan-idle-{i}"))
        .start_handler(|_| yield_to_others())
        .build();
    let Ok(pool) = pool else {
        return rayon::join(main, beside);
    };
    std::thread::scope(|s| {
        let other = s.spawn(|| pool.install(beside));
        let a = main();
        let b = other
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (a, b)
    })
}

/// Lower the calling thread's priority to the least (nice 19): it runs
/// where no thread of normal priority wants the core. Linux keeps a nice
/// value per thread; elsewhere the thread keeps its priority (the work
/// then shares the cores as if joined).
fn yield_to_others() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: setpriority changes only the scheduling priority of the
    // calling thread (`who` 0 under PRIO_PROCESS names it on Linux); a
    // refusal leaves it as it was and is harmless.
    unsafe {
        libc::setpriority(libc::PRIO_PROCESS, 0, 19);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    /// The threads `beside` runs on are its pool's, at the lowest
    /// priority, and its parallel loops stay on them; `main` keeps this
    /// thread and rayon's pool at normal priority.
    #[test]
    fn the_work_beside_runs_on_its_own_threads_at_the_lowest_priority() {
        let name = || std::thread::current().name().unwrap_or("").to_string();
        let before = niceness();
        let (main, (beside, nice)) = beside_idle(
            || (0..64).into_par_iter().map(|_| niceness()).max(),
            || {
                let names: Vec<String> = (0..64).into_par_iter().map(|_| name()).collect();
                let nice = (0..64).into_par_iter().map(|_| niceness()).min();
                (names, nice)
            },
        );
        assert!(
            beside.iter().all(|n| n.starts_with("maamplan-idle-")),
            "{beside:?}"
        );
        if cfg!(all(target_os = "linux", target_env = "gnu")) {
            assert_eq!(nice, Some(19));
            assert_eq!(
                main,
                Some(before),
                "the planner's threads keep their priority"
            );
        }
    }

    /// A panic beside the planner is raised, not lost.
    #[test]
    #[should_panic(expected = "beside")]
    fn a_panic_beside_is_raised() {
        beside_idle(|| 1, || panic!("beside"));
    }

    /// The calling thread's nice value.
    fn niceness() -> i32 {
        #[cfg(all(target_os = "linux", target_env = "gnu"))]
        // SAFETY: getpriority only reads the calling thread's priority.
        unsafe {
            libc::getpriority(libc::PRIO_PROCESS, 0)
        }
        #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
        0
    }
}
