//! What the gpu backend has done since it was built ([`GpuStats`]), for
//! `-v` and the benches.

/// What the backend has done since it was built: how often a batch's
/// candidate list filled and what that cost, and where the wall time of
/// its calls went (the host's own work, or waiting for the device).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GpuStats {
    /// Batches submitted (each: one walk per query, one exact test per
    /// candidate).
    pub batches: u64,
    /// Queries evaluated.
    pub queries: u64,
    /// (query, triangle) pairs handed to the exact tests.
    pub candidates: u64,
    /// Passes whose candidate list filled.
    pub full_lists: u64,
    /// Resumed passes (walks of the incomplete, undecided queries only:
    /// their share of pairs handed over, or the list full).
    pub resumed_passes: u64,
    /// Query walks those passes made.
    pub resumed_queries: u64,
    /// Host time spent preparing work: ordering queries, packing and
    /// uploading them, encoding and submitting passes, scattering verdicts.
    pub host: std::time::Duration,
    /// Host time spent blocked on the device (its results not yet there):
    /// the device's work that the host's did not hide.
    pub waiting: std::time::Duration,
}

impl GpuStats {
    /// Count `more` in.
    pub(super) fn add(&mut self, more: &GpuStats) {
        self.batches += more.batches;
        self.queries += more.queries;
        self.candidates += more.candidates;
        self.full_lists += more.full_lists;
        self.resumed_passes += more.resumed_passes;
        self.resumed_queries += more.resumed_queries;
        self.host += more.host;
        self.waiting += more.waiting;
    }
}

impl std::fmt::Display for GpuStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "gpu: {} queries in {} batches, {} exact tests; {} query walk(s) resumed in {} pass(es) (the candidate list full in {}), no batch redone; host {:.1} ms preparing, {:.1} ms waiting on the device",
            self.queries,
            self.batches,
            self.candidates,
            self.resumed_queries,
            self.resumed_passes,
            self.full_lists,
            self.host.as_secs_f64() * 1e3,
            self.waiting.as_secs_f64() * 1e3,
        )
    }
}
