//! Handing the memory a stage freed back to the system, so that the
//! plan's peak is the largest stage's, not the sum of what every stage
//! left mapped.

/// Hand memory freed by the planner's temporaries back to the OS when
/// the allocator holds more than [`RETAINED_AT_MOST`] of it. glibc's
/// malloc keeps freed memory mapped: each worker thread has its own
/// arena, and the holes freed among long-lived allocations (the columns'
/// vectors, the prover's caches) are never trimmed from the top, so on a
/// large colliding toolpath the columns' memory would stay mapped through
/// the program stage. `malloc_trim` returns every wholly free page of
/// every arena. Small amounts are left alone: a trimmed page costs a page
/// fault when it is used again, more than keeping it. Elsewhere than
/// glibc, nothing to do.
pub(super) fn release_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallinfo reads the allocator's statistics and malloc_trim
    // returns free pages to the kernel; both take the allocator's locks
    // like any malloc call and touch no memory in use.
    unsafe {
        // `mallinfo`, not `mallinfo2`: that needs glibc 2.33, and
        // distributions still in service ship older ones. Its `int` field
        // holds the low 32 bits of the count, exact below 4 GiB freed;
        // beyond, a wrapped count at worst skips one trim.
        let freed = libc::mallinfo().fordblks as u32 as usize;
        if freed > RETAINED_AT_MOST {
            libc::malloc_trim(0);
        }
    }
}

/// Hand every page the allocator holds free back to the OS, however few:
/// once, before the plan's outputs are made, whose buffers (the program's
/// scene, the pictures) would otherwise come on top of what the planner
/// left mapped (dome_cut `--tilt 50` with its report: a peak of 0.94
/// GiB, not 1.04).
pub(crate) fn release_all_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: as in `release_freed_memory`.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Freed memory (bytes) the allocator may keep mapped between stages
/// ([`release_freed_memory`]).
const RETAINED_AT_MOST: usize = 512 << 20;
