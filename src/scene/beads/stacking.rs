//! The layers of a toolpath given without them (a single file of
//! waypoints in print order), found from how its beads stack: beads of one
//! layer lie side by side, so a waypoint standing over a bead of its own
//! layer starts the next one.

use super::top_grid::{stands_over_strip, Below, TopGrid};
use super::{
    group_of, height_of, segment_beads, v, Bead, BeadPath, BeadSettings, Deposit, LOOKBACK,
};
use crate::geometry::Mesh;
use glam::DVec3;
use rayon::prelude::*;
use std::ops::Range;

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
/// Each bead's top must be known before the next waypoint can be found
/// over it, so waypoints are placed one by one in print order; what lies
/// below them (the layers before the current one, unchanged while it
/// lasts) is searched for a batch of them at once, the batch growing
/// while no layer begins and starting small again where one does.
pub fn stacked_layers(path: BeadPath, platform: &Mesh, s: &BeadSettings) -> Stacking {
    let mut tops = super::top_grid(s);
    tops.insert_platform(platform);
    let n = path.pos.len();
    let mut stacker = Stacker {
        path,
        s,
        over: [STACKED_SHARE * s.default_height, s.height[1]],
        tops,
        layer_of: vec![0; n],
        against: vec![false; n],
        heights: vec![(s.height[1], true); n],
        beads: Vec::new(),
        layer: 0,
        layer_start: 0,
        run_start: 0,
        strips_before: vec![0; n],
        last: None,
    };
    let mut g = 0;
    let mut batch = FIRST_BATCH;
    while g < n {
        let placed = stacker.place_batch(g..(g + batch).min(n));
        batch = if g + placed < n && placed < batch {
            FIRST_BATCH
        } else {
            (2 * batch).min(LARGEST_BATCH)
        };
        g += placed;
    }
    let deposit = Deposit {
        groups: layer_groups(&stacker.beads, &stacker.layer_of, s.width),
        heights: stacker.heights,
    };
    Stacking {
        layer_of: stacker.layer_of,
        against: stacker.against,
        deposit,
    }
}

/// The first batch of [`stacked_layers`]' searches, and after each new
/// layer; and the largest it grows to.
const FIRST_BATCH: usize = 64;
const LARGEST_BATCH: usize = 256;

/// [`stacked_layers`]' state as it places the waypoints in print order.
struct Stacker<'a> {
    path: BeadPath<'a>,
    s: &'a BeadSettings,
    /// Heights over a bead of the own layer that start a new one.
    over: [f64; 2],
    tops: TopGrid,
    layer_of: Vec<usize>,
    against: Vec<bool>,
    heights: Vec<(f64, bool)>,
    /// The beads laid, with the waypoint each ends at.
    beads: Vec<(usize, Bead)>,
    /// The current layer, its first waypoint and the current run's (the
    /// first after a travel).
    layer: usize,
    layer_start: usize,
    run_start: usize,
    /// The strips listed before each waypoint was placed.
    strips_before: Vec<usize>,
    /// What lies below the waypoint placed last, in the current layer.
    last: Option<Below>,
}

impl Stacker<'_> {
    /// Place the waypoints of `batch` in turn, from what lies below each
    /// (searched for all of them at once); stop after one that begins a
    /// layer, whose successors' searches are out of date. Returns how many
    /// were placed.
    fn place_batch(&mut self, batch: Range<usize>) -> usize {
        let (path, s, layer) = (self.path, self.s, self.layer);
        let across = 0.5 * s.width;
        let found: Vec<(Below, bool)> = batch
            .clone()
            .into_par_iter()
            .map(|k| {
                let p = v(path.pos[k]);
                self.tops
                    .below_and_over(p, layer, s.height[1], LOOKBACK, self.over, across)
            })
            .collect();
        // The strips this batch lists: the searches above could not see them.
        let mut fresh: Vec<([DVec3; 4], [DVec3; 2])> = Vec::new();
        for (k, (below, stands)) in batch.clone().zip(found) {
            let p = v(path.pos[k]);
            self.strips_before[k] = self.tops.strip_count();
            let stands = stands
                || fresh
                    .iter()
                    .any(|(c, seg)| stands_over_strip(p, c, *seg, self.over, across));
            let given = k > 0 && path.layer[k] != path.layer[k - 1];
            if given || (k > 0 && stands) {
                self.begin_layer(k, given);
                let below = self.tops.below(p, self.layer, s.height[1], LOOKBACK);
                self.place(k, below, &mut fresh);
                return k + 1 - batch.start;
            }
            self.place(k, below, &mut fresh);
        }
        batch.len()
    }

    /// A new layer begins at waypoint `k` (`given`: the toolpath says so),
    /// or at the start of the run that brought `k` over the current layer
    /// when that run began in it: its strips move to the new layer, and
    /// the layer it leaves is complete.
    fn begin_layer(&mut self, k: usize, given: bool) {
        let start = if !given && self.run_start > self.layer_start {
            self.run_start
        } else {
            k
        };
        self.tops
            .relabel_from(self.strips_before[start], self.layer + 1);
        self.tops
            .fit_layer(self.strips_before[self.layer_start], self.layer);
        self.layer += 1;
        self.layer_of[start..k].fill(self.layer);
        if start == k {
            self.last = None;
        }
        self.layer_start = start;
        if given {
            self.run_start = k;
        }
    }

    /// Place waypoint `k`, `below` it what [`TopGrid::below`] found in its
    /// layer: its layer, height and whether its axis points into the
    /// material; the bead into it, whose top is listed (and kept in
    /// `fresh`).
    fn place(&mut self, k: usize, below: Below, fresh: &mut Vec<([DVec3; 4], [DVec3; 2])>) {
        let (path, s) = (self.path, self.s);
        self.layer_of[k] = self.layer;
        self.heights[k] = height_of(&below, s.height);
        self.against[k] = below.up.is_some_and(|m| {
            m.dot(v(path.dir[k]).normalize_or_zero()) < AGAINST_DEG.to_radians().cos()
        });
        let joined = BeadPath {
            layer: &self.layer_of[..=k],
            ..path
        };
        let prints = joined.prints_into(k, s.gap);
        if !prints {
            self.run_start = k;
        }
        if let (Some(prev), true) = (&self.last, prints) {
            let ends = ((prev, self.heights[k - 1].0), (&below, self.heights[k].0));
            for b in segment_beads(&path, k, ends.0, ends.1, s.width) {
                if b.primary {
                    let strip = b.path_strip(s.width);
                    self.tops.insert_strip(strip, self.layer, b.path);
                    fresh.push((strip, b.path));
                }
                self.beads.push((k, b));
            }
        }
        self.last = Some(below);
    }
}

/// `beads` (each with the waypoint it ends at, in print order) as one
/// group per layer, each bead in the final layer of its waypoint.
fn layer_groups(
    beads: &[(usize, Bead)],
    layer_of: &[usize],
    width: f64,
) -> Vec<crate::scene::PartGroup> {
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
        groups.push(group_of(&layer_beads, layer, width));
        start = end;
    }
    groups
}
