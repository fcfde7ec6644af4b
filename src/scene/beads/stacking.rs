//! The layers of a toolpath given without them (a single file of
//! waypoints in print order), found from how its beads stack: beads of one
//! layer lie side by side, so a waypoint standing over a bead of its own
//! layer starts the next one.

use super::top_grid::Below;
use super::{
    group_of, height_of, segment_beads, v, Bead, BeadPath, BeadSettings, Deposit, LOOKBACK,
};
use crate::geometry::Mesh;

/// What [`stacked_layers`] finds.
#[derive(Clone, Debug)]
pub struct Stacking {
    /// Each waypoint's layer, counted from 0 in print order.
    pub layer_of: Vec<usize>,
    /// Does the waypoint's nozzle axis point into the material below it
    /// (more than [`AGAINST_DEG`] from the direction away from it)? A
    /// toolpath stored with some layers upside down, as the data set
    /// stores its support layers, has these.
    pub against: Vec<bool>,
    /// The beads laid along the path in those layers, as
    /// [`super::deposit`] lays them (a bead's orientation does not depend
    /// on which way its nozzle axes point).
    pub deposit: Deposit,
}

/// How far (degrees) a nozzle axis must point from the direction away
/// from the material below for [`Stacking::against`] to call it reversed.
pub const AGAINST_DEG: f64 = 120.0;

/// How far above a bead of its own layer (a share of the default layer
/// height) a waypoint must be for [`stacked_layers`] to start a new layer
/// there: beads of one layer that overlap their neighbours stay well
/// below it.
pub const STACKED_SHARE: f64 = 0.25;

/// The layers of a toolpath whose layers are not known: `path`'s own
/// layers, each split where its path starts to run over a bead it laid
/// itself — at least [`STACKED_SHARE`] of the default layer height above
/// it, no more than the largest layer height, its foot within half a bead
/// width of that bead's path — at the start of the run that brought it
/// there when that run began in the layer being left. Also which nozzle
/// axes point into the material below, and the beads.
///
/// Waypoints are taken one by one in print order: each bead's top must be
/// known before the next waypoint can be found over it.
pub fn stacked_layers(path: BeadPath, platform: &Mesh, s: &BeadSettings) -> Stacking {
    let n = path.pos.len();
    let [_, hi] = s.height;
    let over = [STACKED_SHARE * s.default_height, hi];
    let reversed = AGAINST_DEG.to_radians().cos();
    let mut tops = super::top_grid(s);
    tops.insert_platform(platform);
    let mut layer_of = vec![0usize; n];
    let mut against = vec![false; n];
    let mut heights = vec![(hi, true); n];
    let mut beads: Vec<(usize, Bead)> = Vec::new();
    // The current layer's first waypoint, the current run's (the first
    // after a travel), and the strips listed before each waypoint.
    let (mut layer, mut layer_start, mut run_start) = (0, 0, 0);
    let mut strips_before = vec![0usize; n];
    let mut last: Option<Below> = None;
    for g in 0..n {
        let p = v(path.pos[g]);
        strips_before[g] = tops.strip_count();
        let (mut below, stands) = tops.below_and_over(p, layer, hi, LOOKBACK, over, 0.5 * s.width);
        if g > 0 && path.layer[g] != path.layer[g - 1] {
            tops.fit_layer(strips_before[layer_start], layer);
            (layer, layer_start, run_start, last) = (layer + 1, g, g, None);
            below = tops.below(p, layer, hi, LOOKBACK);
        } else if g > 0 && stands {
            // The new layer began where the run over the old one did.
            let start = if run_start > layer_start {
                run_start
            } else {
                g
            };
            tops.relabel_from(strips_before[start], layer + 1);
            tops.fit_layer(strips_before[layer_start], layer);
            layer += 1;
            layer_of[start..g].fill(layer);
            if start == g {
                last = None;
            }
            layer_start = start;
            below = tops.below(p, layer, hi, LOOKBACK);
        }
        layer_of[g] = layer;
        heights[g] = height_of(&below, s.height);
        against[g] = below
            .up
            .is_some_and(|m| m.dot(v(path.dir[g]).normalize_or_zero()) < reversed);
        let joined = BeadPath {
            layer: &layer_of[..=g],
            ..path
        };
        let prints = joined.prints_into(g, s.gap);
        if !prints {
            run_start = g;
        }
        if let (Some(prev), true) = (&last, prints) {
            let made = segment_beads(
                &path,
                g,
                (prev, heights[g - 1].0),
                (&below, heights[g].0),
                s.width,
            );
            for b in made {
                if b.primary {
                    tops.insert_strip(b.path_strip(s.width), layer, b.path);
                }
                beads.push((g, b));
            }
        }
        last = Some(below);
    }
    let deposit = Deposit {
        groups: layer_groups(&beads, &layer_of),
        heights,
    };
    Stacking {
        layer_of,
        against,
        deposit,
    }
}

/// `beads` (each with the waypoint it ends at, in print order) as one
/// group per layer, each bead in the final layer of its waypoint.
fn layer_groups(beads: &[(usize, Bead)], layer_of: &[usize]) -> Vec<crate::scene::PartGroup> {
    let mut groups = Vec::new();
    let mut start = 0;
    while start < beads.len() {
        let layer = layer_of[beads[start].0];
        let end = start
            + beads[start..]
                .iter()
                .take_while(|(g, _)| layer_of[*g] == layer)
                .count();
        let layer_beads: Vec<Bead> = beads[start..end].iter().map(|(_, b)| *b).collect();
        groups.push(group_of(&layer_beads, layer));
        start = end;
    }
    groups
}
