//! Which layer a point of the program reads as.
//!
//! A G-code file does not say which layer a line prints. A reader that
//! needs to know — to decide which material exists while the line runs —
//! takes the layer of the waypoint nearest to the nozzle tip (as the
//! data set's `gcode_audit.py` does, and as the original software's
//! stamps do for layer triangles). A waypoint reads as its own layer, but a
//! point that splits a bead (see [`tip_subdivision_where`]) can lie nearer
//! to a waypoint of the layer above than to either end of its bead, and
//! such a reader would then check the move against the rest of the
//! current layer, material not printed yet. [`NearestLayer`] answers the
//! question so that split points can be placed where they read right, and
//! where no split can (a bead that turns the head a long way bows enough
//! to need short pieces, and its middle may read as the layer above over
//! more than a piece's length), so that the pieces that read wrong are
//! proved against what such a reader assumes exists: every layer below
//! the one they read as.
//!

use crate::kinematics::{Axes, Machine};
use crate::prove::{tip_subdivision_where, MoveSpec};
use crate::toolpath::Toolpath;
use rstar::primitives::GeomWithData;
use rstar::RTree;

type Site = GeomWithData<[f64; 3], u32>;

/// All waypoints of a toolpath, indexed by position, with their layers.
pub struct NearestLayer {
    /// Sites carry the waypoint's global index.
    tree: RTree<Site>,
    layer_of: Vec<u32>,
}

impl NearestLayer {
    /// Index waypoints at `pos` (part frame) whose layers are `layer_of`.
    pub fn new(pos: &[[f64; 3]], layer_of: &[usize]) -> Self {
        let sites = pos
            .iter()
            .enumerate()
            .map(|(g, p)| Site::new(*p, g as u32))
            .collect();
        NearestLayer {
            tree: RTree::bulk_load(sites),
            layer_of: layer_of.iter().map(|&k| k as u32).collect(),
        }
    }

    /// Index the waypoints of `toolpath`.
    pub fn of(toolpath: &Toolpath) -> Self {
        let (pos, layer_of): (Vec<[f64; 3]>, Vec<usize>) = toolpath
            .iter()
            .map(|(k, w)| (w.pos.map(|x| x as f64), k))
            .unzip();
        Self::new(&pos, &layer_of)
    }

    /// The pieces of the extruding move `a → b` of `layer` as the program
    /// writes them, each with the material it is proved against:
    /// [`tip_subdivision_where`] with split tips that read as `layer`; a
    /// piece is proved against the material of stamps below `cutoff`, or
    /// when its end tip still reads as a later layer, against every layer
    /// below that one too ([`Self::reader_cutoff`]). The planner proves,
    /// the program writes and `check --plan` re-checks exactly these.
    pub fn bead_moves(
        &self,
        m: &Machine,
        a: &Axes,
        b: &Axes,
        tol: f64,
        layer: usize,
        cutoff: u32,
    ) -> Vec<MoveSpec> {
        let mut from = *a;
        let (pts, all_read_right) =
            tip_subdivision_where(m, a, b, tol, |p| self.reads_as(p, layer));
        let n = pts.len();
        pts.into_iter()
            .enumerate()
            .map(|(k, to)| {
                let reads_right = all_read_right || k + 1 == n || self.reads_as(m.tip(&to), layer);
                let cutoff = if reads_right {
                    cutoff
                } else {
                    self.reader_cutoff(m.tip(&to), cutoff)
                };
                let mv = MoveSpec { from, to, cutoff };
                from = to;
                mv
            })
            .collect()
    }

    /// The cutoff a move ending at `p` needs to satisfy a reader that takes
    /// the layer of the waypoint nearest to `p` and checks against every
    /// layer below it: `cutoff`, raised to the stamp past that layer's
    /// predecessors (waypoints are numbered layer by layer).
    pub fn reader_cutoff(&self, p: [f64; 3], cutoff: u32) -> u32 {
        let Some(g) = self.nearest(p) else {
            return cutoff;
        };
        let layer = self.layer_of[g];
        let first = self.layer_of.partition_point(|&k| k < layer);
        cutoff.max(crate::scene::cutoff(first))
    }

    /// Does `p` read as `layer`: is a waypoint of `layer` at least as near
    /// to `p` as every waypoint of the other layers?
    pub fn reads_as(&self, p: [f64; 3], layer: usize) -> bool {
        let mut nearest = None;
        for (site, d2) in self.tree.nearest_neighbor_iter_with_distance_2(p) {
            match nearest {
                Some(d) if d2 > d => return false,
                _ => nearest = Some(d2),
            }
            if self.layer_of[site.data as usize] as usize == layer {
                return true;
            }
        }
        false
    }

    /// The waypoint nearest to `p` (global index; the earliest of equals).
    pub fn nearest(&self, p: [f64; 3]) -> Option<usize> {
        let mut best: Option<(f64, u32)> = None;
        for (site, d2) in self.tree.nearest_neighbor_iter_with_distance_2(p) {
            match best {
                Some((bd, _)) if d2 > bd => break,
                Some((_, bj)) if site.data >= bj => {}
                _ => best = Some((d2, site.data)),
            }
        }
        best.map(|(_, g)| g as usize)
    }

    /// The waypoint of `layer` nearest to `p` (global index; the earliest
    /// of equals). It walks out from `p`: meant for a layer that has a
    /// waypoint near.
    pub fn nearest_in(&self, p: [f64; 3], layer: usize) -> Option<usize> {
        let mut best: Option<(f64, u32)> = None;
        for (site, d2) in self.tree.nearest_neighbor_iter_with_distance_2(p) {
            match best {
                Some((bd, _)) if d2 > bd => break,
                Some((_, bj)) if site.data >= bj => {}
                _ if self.layer_of[site.data as usize] as usize == layer => {
                    best = Some((d2, site.data))
                }
                _ => {}
            }
        }
        best.map(|(_, g)| g as usize)
    }

    /// The waypoints within `r` of `p` (global indices, in no particular
    /// order) and the waypoint nearest to `p` ([`Self::nearest`]), in one
    /// search where one lies within `r`: the nearest of all is then the
    /// nearest of those (the smallest squared distance, as the tree
    /// measures it, then the earliest).
    pub fn within_and_nearest(&self, p: [f64; 3], r: f64) -> (Vec<usize>, Option<usize>) {
        use rstar::PointDistance;
        let mut best: Option<(f64, u32)> = None;
        let near: Vec<usize> = self
            .tree
            .locate_within_distance(p, r * r)
            .map(|site| {
                let key = (site.distance_2(&p), site.data);
                if best.is_none_or(|b| key < b) {
                    best = Some(key);
                }
                site.data as usize
            })
            .collect();
        let nearest = match best {
            Some((_, g)) => Some(g as usize),
            None => self.nearest(p),
        };
        (near, nearest)
    }

    /// The waypoints within `r` of `p` (global indices, in no particular
    /// order).
    pub fn within(&self, p: [f64; 3], r: f64) -> impl Iterator<Item = usize> + '_ {
        self.tree
            .locate_within_distance(p, r * r)
            .map(|site| site.data as usize)
    }

    /// The layer of waypoint `g`.
    pub fn layer(&self, g: usize) -> usize {
        self.layer_of[g] as usize
    }
}

#[cfg(test)]
impl NearestLayer {
    /// Waypoints given layer by layer, in print order (global indices run
    /// on from one layer to the next): their positions and their index.
    pub(crate) fn of_layers(layers: &[&[[f64; 3]]]) -> (Vec<[f64; 3]>, Self) {
        let pos = layers.concat();
        let layer_of: Vec<usize> = layers
            .iter()
            .enumerate()
            .flat_map(|(k, l)| std::iter::repeat_n(k, l.len()))
            .collect();
        let index = Self::new(&pos, &layer_of);
        (pos, index)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One search for the waypoints within reach and the nearest gives
    /// what the two searches give apart, ties to the earliest included:
    /// waypoints on a coarse grid, each position held by a dozen or more,
    /// asked at points on them, beside them and far from all.
    #[test]
    fn within_and_nearest_agree_with_the_searches_apart() {
        let mut u = crate::geometry::xorshift(0x7ea5_0bed_0000_0007);
        let pos: Vec<[f64; 3]> = (0..3000)
            .map(|_| {
                [
                    (8.0 * u()).floor() * 0.004,
                    (8.0 * u()).floor() * 0.004,
                    (3.0 * u()).floor(),
                ]
            })
            .collect();
        let layer_of: Vec<usize> = (0..pos.len()).map(|g| g / 1000).collect();
        let index = NearestLayer::new(&pos, &layer_of);
        let (mut on, mut off) = (0, 0);
        for k in 0..4000 {
            let p = match k % 3 {
                0 => pos[k % pos.len()],
                1 => pos[k % pos.len()].map(|x| x + 0.004 * (u() - 0.5)),
                _ => [0.2 * u() - 0.1, 0.2 * u() - 0.1, 4.0 * u() - 0.5],
            };
            let r = 0.002;
            let (mut near, nearest) = index.within_and_nearest(p, r);
            let mut apart: Vec<usize> = index.within(p, r).collect();
            near.sort_unstable();
            apart.sort_unstable();
            assert_eq!(near, apart, "point {p:?}");
            assert_eq!(nearest, index.nearest(p), "point {p:?}");
            if near.is_empty() {
                off += 1
            } else {
                on += 1
            }
        }
        assert!(
            on > 1000 && off > 1000,
            "{on} points near waypoints, {off} not"
        );
    }

    #[test]
    fn a_point_reads_as_the_layer_of_its_nearest_waypoint() {
        // Layer 0 along x at z = 0, 1 mm apart; layer 1 at z = 0.3 over
        // x = 0.5 only.
        let pos = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.0, 0.3]];
        let near = NearestLayer::new(&pos, &[0, 0, 1]);
        assert!(near.reads_as([0.1, 0.0, 0.0], 0));
        assert!(!near.reads_as([0.5, 0.0, 0.0], 0));
        assert!(near.reads_as([0.5, 0.0, 0.0], 1));
        // A tie counts for the asked layer.
        let tie = NearestLayer::new(&[[0.0; 3], [2.0, 0.0, 0.0]], &[0, 1]);
        assert!(tie.reads_as([1.0, 0.0, 0.0], 0) && tie.reads_as([1.0, 0.0, 0.0], 1));
    }

    #[test]
    fn a_point_read_as_a_later_layer_needs_every_layer_below_it() {
        let (_, near) = NearestLayer::of_layers(&[
            &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
            &[[0.0, 0.0, 0.3], [1.0, 0.0, 0.3]],
            &[[0.5, 0.0, 0.6]],
        ]);
        // Reads as layer 1: material of waypoints 0..=1 (stamps 1, 2).
        assert_eq!(near.reader_cutoff([0.9, 0.0, 0.3], 1), 3);
        // Reads as layer 2: layers 0 and 1 (stamps up to 4).
        assert_eq!(near.reader_cutoff([0.5, 0.0, 0.55], 2), 5);
        assert_eq!(near.nearest_in([0.5, 0.0, 0.55], 1), Some(2));
        assert_eq!(near.nearest_in([0.5, 0.0, 0.55], 2), Some(4));
        // An earlier layer asks for nothing more.
        assert_eq!(near.reader_cutoff([0.0, 0.0, 0.0], 4), 4);
    }

    /// A bead through a middle that reads as the layer above, over more
    /// than a piece's length: the pieces that end there are proved against
    /// the whole of the bead's own layer, the rest at the given cutoff.
    #[test]
    fn bead_pieces_that_read_as_the_layer_above_take_its_cutoff() {
        let m = Machine::default();
        let tc = (-30f64.to_radians(), 0.0);
        let at = |p: [f64; 3], c: f64| m.axes_at(p, (tc.0, c.to_radians()));
        let (pa, pb) = ([20.0, 0.0, 10.0], [21.2, 0.0, 10.0]);
        let (a, b) = (at(pa, 0.0), at(pb, 40.0));
        // Layer 0: the bead's two ends and one more far away; layer 1: one
        // waypoint 0.3 above the bead's middle.
        let (_, near) =
            NearestLayer::of_layers(&[&[pa, pb, [40.0, 0.0, 10.0]], &[[20.6, 0.0, 10.3]]]);
        let moves = near.bead_moves(&m, &a, &b, 0.05, 0, 1);
        assert!(moves.len() > 2, "the bead is split");
        assert_eq!(moves.last().unwrap().to, b);
        let mut raised = 0;
        for mv in &moves {
            let reads_up = !near.reads_as(m.tip(&mv.to), 0);
            assert_eq!(mv.cutoff, if reads_up { 4 } else { 1 });
            raised += reads_up as usize;
        }
        assert!(raised > 0, "some split tip reads as layer 1");
    }
}
