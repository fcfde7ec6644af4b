//! Collision queries for the motion between two machine configurations: the
//! axes move linearly (X, Y, Z, tilt, C all together), so the head sweeps a
//! curve in the part frame. Intermediate configurations are sampled so that
//! no point of the head moves more than `step` mm between two checks,
//! estimated as the tip's chord in the part frame, plus the head's reach
//! times the rotation, plus the second-order bow of the tip's path (the
//! distance from the rotation centre times the rotation squared).

use crate::kinematics::{head_pose, tip_position, Axes, Machine};
use crate::scene::Query;

/// Intermediate queries (endpoints excluded) for the move `a → b` with the
/// material of `cutoff`; `reach` is the head's largest distance from its
/// tip; at most `max_samples` of them.
#[allow(clippy::too_many_arguments)]
pub fn between(
    m: &Machine,
    a: &Axes,
    b: &Axes,
    cutoff: u32,
    reach: f64,
    step: f64,
    max_samples: usize,
    out: &mut Vec<Query>,
) {
    let d = [
        b.xyz[0] - a.xyz[0],
        b.xyz[1] - a.xyz[1],
        b.xyz[2] - a.xyz[2],
    ];
    let (cfg, rot_pair, off) = (m.configuration, m.rotary, m.offsets());
    let pa = tip_position(cfg, rot_pair, off, a.xyz, a.tilt, a.c);
    let pb = tip_position(cfg, rot_pair, off, b.xyz, b.tilt, b.c);
    // The linear axes compensate the rotation, so the tip follows the
    // part-frame chord up to a second-order bow; head points add the reach
    // times the rotation.
    let chord = (pb[0] - pa[0]).hypot(pb[1] - pa[1]).hypot(pb[2] - pa[2]);
    let rot = (b.tilt - a.tilt).abs() + (b.c - a.c).abs();
    let radius = a.xyz.iter().map(|x| x * x).sum::<f64>().sqrt();
    let travel = chord + reach * rot + radius * rot * rot;
    let n = ((travel / step).ceil().max(1.0) as usize).min(max_samples.saturating_add(1));
    for k in 1..n {
        let t = k as f64 / n as f64;
        let x = std::array::from_fn(|i| a.xyz[i] + t * d[i]);
        let tilt = a.tilt + t * (b.tilt - a.tilt);
        let c = a.c + t * (b.c - a.c);
        let p = tip_position(m.configuration, m.rotary, m.offsets(), x, tilt, c);
        out.push(Query {
            pose: head_pose(m.rotary, p, tilt, c),
            cutoff,
            margin: 0.0,
        });
    }
}
