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
//! question so that split points can be placed where they read right.
//!

use super::motion::tip_subdivision_where;
use crate::kinematics::{Axes, Machine};
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
    /// writes them: [`tip_subdivision_where`] with split tips that read as
    /// `layer`. The planner proves, the program writes and `check --plan`
    /// re-checks exactly these.
    pub fn split_bead(&self, m: &Machine, a: &Axes, b: &Axes, tol: f64, layer: usize) -> Vec<Axes> {
        tip_subdivision_where(m, a, b, tol, |p| self.reads_as(p, layer))
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

    /// The layer of waypoint `g`.
    pub fn layer(&self, g: usize) -> usize {
        self.layer_of[g] as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
