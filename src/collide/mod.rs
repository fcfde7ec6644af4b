//! Collision evaluators: one trait, several backends that must agree.
//!
//! A backend takes a batch of [`Query`]s (head pose, cutoff stamp, safety
//! margin) and answers, per query, whether the platform or any part
//! triangle with `stamp < cutoff` crosses the head, lies inside it, or
//! comes closer to its surface than the query's margin (DESIGN.md).

pub mod brute;
pub mod choice;
pub mod cpu;
pub mod gpu;
pub mod moves;
pub mod order;
pub mod parry;
pub mod sample;

pub use crate::scene::Query;

/// What can go wrong evaluating queries.
#[derive(Debug, thiserror::Error)]
pub enum CollideError {
    /// A query's pose has a NaN or infinite component.
    #[error("query {0} has a non-finite pose")]
    NonFinite(usize),
    /// A query's safety margin or its slope is negative or not finite.
    #[error("query {0} has a negative or non-finite safety margin or slope")]
    BadMargin(usize),
    /// The chosen backend cannot run here.
    #[error("{0}")]
    Unavailable(String),
    /// The gpu backend was asked for and there is no adapter: the user
    /// can fix that (a driver, or another backend).
    #[error("--backend gpu: no GPU adapter found: install a Vulkan driver (on Debian/Ubuntu, mesa-vulkan-drivers gives the lavapipe software adapter) or use --backend cpu")]
    NoGpu,
}

/// A batch collision evaluator.
pub trait Backend: Sync {
    /// Short name as used on the command line (`cpu`, `parry`, `gpu`).
    fn name(&self) -> &'static str;
    /// One verdict per query: `true` = collides. May be called from
    /// several threads at once (the planner measures the input beside its
    /// own stages); each call's verdicts are its own.
    fn evaluate(&self, queries: &[Query]) -> Result<Vec<bool>, CollideError>;
    /// Queries per call that keep the backend busiest: callers that split
    /// their work (to show progress) hand it over in multiples of this.
    fn batch_hint(&self) -> usize {
        16_384
    }
    /// Queries that reach farther than this (mm: the margin at the
    /// head's farthest point) are better answered on the CPU beside this
    /// backend (`None`: none are). The gpu backend gathers every pair of
    /// head and part volumes within a query's margin before it tests one,
    /// and a travel's first, coarse samples ask tens of millimetres; the
    /// cpu backend stops at the first triangle within the margin.
    fn wide_above(&self) -> Option<f32> {
        None
    }
    /// One verdict per move: does any of its samples
    /// ([`moves::SampledMove`]) come within its margin? By default the
    /// samples are posed on the host and asked through [`Self::evaluate`];
    /// the gpu backend poses them and reduces their verdicts on the device.
    fn sampled_moves(
        &self,
        machine: &crate::kinematics::Machine,
        moves: &[moves::SampledMove],
    ) -> Result<Vec<bool>, CollideError> {
        moves::host_sampled_moves(self, machine, moves)
    }
    /// One line on the backend's own work so far, for `-v` (the gpu
    /// backend: batches, exact tests, candidate lists that filled).
    fn summary(&self) -> Option<String> {
        None
    }
}

/// Reject non-finite poses and negative or non-finite margins before any
/// backend sees them.
pub fn check_finite(queries: &[Query]) -> Result<(), CollideError> {
    for (i, q) in queries.iter().enumerate() {
        let p = &q.pose;
        let finite = p
            .tip
            .iter()
            .chain(p.cols.iter().flatten())
            .all(|c| c.is_finite());
        if !finite {
            return Err(CollideError::NonFinite(i));
        }
        if !(q.margin.is_finite() && q.margin >= 0.0 && q.slope.is_finite() && q.slope >= 0.0) {
            return Err(CollideError::BadMargin(i));
        }
    }
    Ok(())
}
