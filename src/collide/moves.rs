//! Moves asked as moves: a backend poses their samples and answers one
//! verdict per move ([`super::Backend::sampled_moves`]). The cpu and parry
//! backends pose them on the host in `f64` ([`host_sampled_moves`]); the
//! gpu backend ships each move once (`collide::gpu::wire::GpuMove`), poses
//! its samples on the device (`collide_expand`) and reduces their verdicts
//! there (`collide_reduce`).

use super::{Backend, CollideError, Query};
use crate::kinematics::{Axes, Machine};
use rayon::prelude::*;

/// A machine move checked at `intervals − 1` evenly spaced poses between
/// its ends (its ends are not asked).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampledMove {
    /// Axes at the start.
    pub from: Axes,
    /// Axes at the end.
    pub to: Axes,
    /// Material with `stamp < cutoff` exists during the move.
    pub cutoff: u32,
    /// Safety margin of every sample (mm).
    pub margin: f32,
    /// Pieces the move is cut into; sample `k` (`0 < k < intervals`) is
    /// the machine's pose at `k / intervals` of the move.
    pub intervals: u32,
}

/// [`Backend::sampled_moves`] on the host: every sample posed in `f64`
/// ([`Machine::pose_along`]), all asked in one [`Backend::evaluate`].
pub fn host_sampled_moves(
    backend: &(impl Backend + ?Sized),
    machine: &Machine,
    moves: &[SampledMove],
) -> Result<Vec<bool>, CollideError> {
    let per: Vec<Vec<Query>> = moves
        .par_iter()
        .map(|mv| {
            let n = mv.intervals;
            (1..n)
                .map(|k| Query {
                    pose: machine.pose_along(&mv.from, &mv.to, k as f64 / n as f64),
                    cutoff: mv.cutoff,
                    margin: mv.margin,
                    slope: 0.0,
                })
                .collect()
        })
        .collect();
    let flat: Vec<Query> = per.iter().flatten().copied().collect();
    let hits = backend.evaluate(&flat)?;
    let mut out = Vec::with_capacity(moves.len());
    let mut k = 0;
    for q in &per {
        out.push(hits[k..k + q.len()].iter().any(|&h| h));
        k += q.len();
    }
    Ok(out)
}
