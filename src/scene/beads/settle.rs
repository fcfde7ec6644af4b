//! How high above its path a bead's top is modelled.
//!
//! A box whose "up" is off the bead's true orientation by `δ` about the
//! path holds the bead's top edge only if its top is `width / 2 · sin δ`
//! above the path. Where nothing says how far off it may be, the box
//! allows [`AGREE_DEG`]; where the layer's own paths spread over a surface
//! around the bead, the surface fitted through them is the bead's own, and
//! the box allows its angle to that surface and [`SETTLED_SLACK_DEG`] more.
//! A top modelled higher than the material is clearance a tilted nozzle
//! never gets back: on the tilted simple_curve, 0.06 mm of it cost a third
//! of the run.

use super::top_grid::PathEnds;
use super::{across, Bead, AGREE_DEG, FIT_WIDTHS};
use rayon::prelude::*;

/// The turn (degrees) a top allows beyond its angle to the surface fitted
/// through its layer's paths: the fit's own error.
pub const SETTLED_SLACK_DEG: f64 = 2.0;

/// The lift of a top turned `deg` degrees off its bead: `width / 2 · sin`.
pub(super) fn lift_for(width: f64, deg: f64) -> f64 {
    0.5 * width * deg.to_radians().sin()
}

/// Lower the tops of one layer's `beads` (laid with [`AGREE_DEG`]'s lift)
/// to what their angle to the surface through the layer's own paths
/// needs. Only a layer's first box of a segment (the one the material
/// orients) is settled; bottoms stay where they are.
pub(super) fn settle_tops(beads: &mut [Bead], width: f64) {
    let primary = beads.iter().filter(|b| b.primary).map(|b| b.path);
    let ends = PathEnds::new(primary, FIT_WIDTHS * width);
    let full = lift_for(width, AGREE_DEG);
    beads.par_iter_mut().filter(|b| b.primary).for_each(|b| {
        let [a, e] = b.path;
        let t = (e - a).normalize_or_zero();
        let Some(own) = ends.normal_at(0.5 * (a + e)).and_then(|n| across(n, t)) else {
            return;
        };
        let off = own.dot(b.up).abs().min(1.0).acos().to_degrees();
        let deg = (off + SETTLED_SLACK_DEG).min(AGREE_DEG);
        let drop = full - lift_for(width, deg);
        for c in &mut b.corners[..4] {
            *c -= b.up * drop;
        }
    });
}
