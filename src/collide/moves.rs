//! Moves asked as moves: a backend poses their samples and answers one
//! verdict per move ([`super::Backend::sampled_moves`]). The cpu and parry
//! backends pose them on the host in `f64` ([`host_sampled_moves`]); the
//! gpu backend ships each move once ([`GpuMove`]), poses its samples on the
//! device (`collide_expand`) and reduces their verdicts there
//! (`collide_reduce`).

use super::{Backend, CollideError, Query};
use crate::kinematics::{Axes, Configuration, Interpolation, Machine, Rotary};
use crate::scene::{GpuMotion, GpuMove};
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

/// The machine as the motion kernels read it.
pub fn gpu_motion(m: &Machine, move_count: usize) -> GpuMotion {
    let [d, h, r] = m.offsets();
    GpuMotion {
        configuration: match m.configuration {
            Configuration::I => 1,
            Configuration::II => 2,
            Configuration::III => 3,
        },
        rotary: match m.rotary {
            Rotary::BC => 0,
            Rotary::AC => 1,
        },
        interpolation: match m.post.interpolation() {
            Interpolation::Joint => 0,
            Interpolation::TipLinear => 1,
        },
        move_count: move_count as u32,
        offsets: [d as f32, h as f32, r as f32],
        _pad: 0,
    }
}

/// `mv` as the motion kernels read it, its samples in the query slots
/// from `first` on. C starts reduced to one turn (the same pose, and `f32`
/// keeps its digits for the angle, not for whole turns).
pub fn gpu_move(mv: &SampledMove, first: u32) -> GpuMove {
    let at = |a: &Axes| {
        [
            a.xyz[0] as f32,
            a.xyz[1] as f32,
            a.xyz[2] as f32,
            a.tilt as f32,
        ]
    };
    GpuMove {
        from: at(&mv.from),
        to: at(&mv.to),
        c_from: mv.from.c.rem_euclid(std::f64::consts::TAU) as f32,
        c_delta: (mv.to.c - mv.from.c) as f32,
        inv_n: (1.0 / mv.intervals.max(1) as f64) as f32,
        cutoff: mv.cutoff,
        margin: mv.margin,
        first,
        count: mv.intervals.saturating_sub(1),
        _pad: 0,
    }
}
