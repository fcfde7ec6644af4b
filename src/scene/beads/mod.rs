//! The part as deposited: when no layer surfaces say what has been
//! printed, the material is modelled from the program itself, one closed
//! bead solid per printing segment.
//!
//! A segment from waypoint `g − 1` to `g` lays a bead whose top runs along
//! the tip's path: a box `width` wide and as deep as the layer height there,
//! lengthened by `width / 2` at both ends so that consecutive beads overlap
//! at corners (no gap opens up to a right-angle turn), its top raised by
//! [`top_lift`] so that it still holds the bead if the bead lies turned by
//! up to [`AGREE_DEG`] about the path, stamped
//! [`stamp_of`]`(g)` so every query sees exactly the beads printed before
//! it ([`crate::scene::cutoff`]).
//!
//! Which way is "up" for a bead? The nozzle axis is the program's word for
//! it, but a five-axis program often tilts the nozzle away from the surface
//! it prints on. The material below says where the surface is: the bead
//! rests on the nearest earlier bead (or the platform), so the direction
//! from that nearest point to the tip is the local layer normal, and the
//! distance is the layer height (as the data set's original software
//! measures it from the surfaces below, [`LOOKBACK`] layers back). Where
//! the two directions disagree by more than [`AGREE_DEG`], the bead is
//! modelled both ways (two boxes): whichever is true, the model holds the
//! material, which is what makes a plan against it safe against the real
//! part. Where nothing lies within the largest layer height below, the
//! nozzle axis alone orients it, at that largest height.
//!
//! Layers are built in print order (each needs the beads of the layers
//! below it), the waypoints of one layer in parallel; the nearest earlier
//! top is found in a uniform grid of the beads' top faces and the
//! platform's triangles, cells as large as the search radius.

mod settle;
mod stacking;
mod top_grid;

pub use stacking::{stacked_layers, Stacking, AGAINST_DEG, STACKED_SHARE};
pub use top_grid::FIT_WIDTHS;

use super::{stamp_of, PartGroup};
use crate::geometry::Mesh;
use glam::DVec3;
use rayon::prelude::*;
use std::ops::Range;
use top_grid::{Below, TopGrid};

/// Layers looked back for the bead a waypoint rests on (as the layer
/// heights of surfaces, [`crate::plan::extrusion::LOOKBACK`]).
pub const LOOKBACK: usize = 25;

/// Largest angle (degrees) between the nozzle axis and the normal the
/// material below gives at which one box models a bead; beyond it, both.
pub const AGREE_DEG: f64 = 10.0;

/// How far above the path a bead's top is modelled (mm): a bead `width`
/// wide turned by [`AGREE_DEG`] about the path lifts its upper edge by
/// this much.
pub fn top_lift(width: f64) -> f64 {
    0.5 * width * AGREE_DEG.to_radians().sin()
}

/// Largest angle (degrees) between the nozzle axis and the direction from
/// the nearest material below at which that direction is taken for the
/// layer's normal: nearer to sideways, the nearest material is a
/// neighbouring bead beside the path (interleaved layers), not the one the
/// bead rests on, and the nozzle axis alone orients it.
pub const MATERIAL_MAX_DEG: f64 = 60.0;

/// Consecutive waypoints farther apart than this (mm) are not joined by a
/// bead by default: the planner starts a new section there
/// ([`crate::plan::PlanOptions::jump`]).
pub const DEFAULT_GAP: f64 = 5.0;

/// The layer heights a bead may have for a machine whose default layer
/// height is `default_height` (mm): a twentieth of it to four times it.
/// The same range bounds the heights extrusion measures.
pub fn height_range(default_height: f64) -> [f64; 2] {
    [0.05 * default_height, 4.0 * default_height]
}

/// How beads are made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeadSettings {
    /// Bead width (mm): the machine's extrusion width.
    pub width: f64,
    /// Smallest and largest layer height (mm): a bead is never shallower
    /// than the first, and the second is how far below the tip the
    /// material it rests on is looked for (and its depth where none is).
    pub height: [f64; 2],
    /// The machine's default layer height (mm).
    pub default_height: f64,
    /// Consecutive waypoints of a layer farther apart than this (mm) are
    /// not joined by a bead (the planner travels between them).
    pub gap: f64,
}

impl BeadSettings {
    /// Beads of the extrusion `width` (mm), layer heights in the
    /// [`height_range`] of `default_height`, joining waypoints up to `gap`
    /// apart.
    pub fn new(width: f64, default_height: f64, gap: f64) -> Self {
        BeadSettings {
            width,
            height: height_range(default_height),
            default_height,
            gap,
        }
    }

    /// The beads `machine` lays: its extrusion width and default layer
    /// height, waypoints up to [`DEFAULT_GAP`] apart joined.
    pub fn of_machine(machine: &crate::kinematics::Machine) -> Self {
        let e = &machine.extrusion;
        BeadSettings::new(e.width, e.default_height, DEFAULT_GAP)
    }
}

impl Default for BeadSettings {
    /// The default machine's beads ([`BeadSettings::of_machine`]).
    fn default() -> Self {
        BeadSettings::of_machine(&crate::kinematics::Machine::default())
    }
}

/// The toolpath a part is deposited along, in print order.
#[derive(Clone, Copy, Debug)]
pub struct BeadPath<'a> {
    /// Tip positions (part frame, mm).
    pub pos: &'a [[f64; 3]],
    /// Unit nozzle axes (from the tip up into the head).
    pub dir: &'a [[f64; 3]],
    /// Layer of each waypoint (non-decreasing).
    pub layer: &'a [usize],
}

/// A toolpath's tips, axes and layers in print order, held for the
/// [`BeadPath`] over them.
#[derive(Clone, Debug)]
pub struct HeldPath {
    pos: Vec<[f64; 3]>,
    dir: Vec<[f64; 3]>,
    layer: Vec<usize>,
}

impl HeldPath {
    /// Every waypoint of `toolpath`, in print order.
    pub fn of(toolpath: &crate::toolpath::Toolpath) -> HeldPath {
        HeldPath {
            pos: toolpath.positions(),
            dir: toolpath.directions(),
            layer: toolpath.iter().map(|(k, _)| k).collect(),
        }
    }

    /// The path to deposit along.
    pub fn path(&self) -> BeadPath<'_> {
        BeadPath {
            pos: &self.pos,
            dir: &self.dir,
            layer: &self.layer,
        }
    }
}

impl BeadPath<'_> {
    /// Does the segment into waypoint `g` lay a bead: same layer as the
    /// waypoint before, a positive length no longer than `gap`?
    pub fn prints_into(&self, g: usize, gap: f64) -> bool {
        if g == 0 || self.layer[g] != self.layer[g - 1] {
            return false;
        }
        let d = (v(self.pos[g]) - v(self.pos[g - 1])).length();
        d > 1e-9 && d <= gap
    }

    /// The waypoint ranges of each layer, in print order.
    fn layers(&self) -> Vec<Range<usize>> {
        let mut out: Vec<Range<usize>> = Vec::new();
        for (g, &k) in self.layer.iter().enumerate() {
            match out.last_mut() {
                Some(r) if self.layer[r.start] == k => r.end = g + 1,
                _ => out.push(g..g + 1),
            }
        }
        out
    }
}

/// What a deposit is made of: per layer the bead solids with their
/// stamps, and per waypoint the layer height found below it.
#[derive(Clone, Debug)]
pub struct Deposit {
    /// One group per layer that lays a bead, in layer order.
    pub groups: Vec<PartGroup>,
    /// Per waypoint: the distance to the material below (mm, clamped to
    /// the settings' heights), and whether the clamp decided it.
    pub heights: Vec<(f64, bool)>,
}

/// The beads laid along `path` on `platform`, layer by layer.
pub fn deposit(path: BeadPath, platform: &Mesh, s: &BeadSettings) -> Deposit {
    let mut tops = top_grid(s);
    tops.insert_platform(platform);
    let mut groups = Vec::new();
    let mut heights = vec![(s.height[1], true); path.pos.len()];
    for range in path.layers() {
        let layer = path.layer[range.start];
        let below: Vec<Below> = range
            .clone()
            .into_par_iter()
            .map(|g| tops.below(v(path.pos[g]), layer, s.height[1], LOOKBACK))
            .collect();
        for (g, b) in range.clone().zip(&below) {
            heights[g] = height_of(b, s.height);
        }
        let beads: Vec<Vec<Bead>> = range
            .clone()
            .into_par_iter()
            .filter(|&g| path.prints_into(g, s.gap))
            .map(|g| {
                let at = |k: usize| (&below[k - range.start], heights[k].0);
                segment_beads(&path, g, at(g - 1), at(g), s.width)
            })
            .collect();
        let beads: Vec<Bead> = beads.into_iter().flatten().collect();
        if beads.is_empty() {
            continue;
        }
        let first = tops.strip_count();
        for b in beads.iter().filter(|b| b.primary) {
            tops.insert_strip(b.path_strip(s.width), layer, b.path);
        }
        tops.fit_layer(first, layer);
        groups.push(group_of(&beads, layer, s.width));
    }
    Deposit { groups, heights }
}

/// The grid the tops are listed in: cubes one and a half bead widths
/// wide, so that the layer below a waypoint is found in the cells next to
/// its own; surfaces fitted over [`FIT_WIDTHS`] bead widths.
fn top_grid(s: &BeadSettings) -> TopGrid {
    TopGrid::new(1.5 * s.width, FIT_WIDTHS * s.width)
}

/// A waypoint's layer height from what lies below it, clamped to
/// `[lo, hi]`, and whether the clamp decided it.
fn height_of(below: &Below, [lo, hi]: [f64; 2]) -> (f64, bool) {
    match below.distance {
        Some(d) if d >= lo => (d, false),
        Some(_) => (lo, true),
        None => (hi, true),
    }
}

pub(super) fn v(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

/// One bead box: the segment's stamp, its corners (top four, then the
/// bottom four below them), the unit direction it is deep along, and
/// whether it is the segment's best guess of the bead (the first of its
/// boxes: the one the material below orients, when there is one), whose
/// top the next layers rest on.
#[derive(Clone, Copy, Debug)]
struct Bead {
    stamp: u32,
    corners: [DVec3; 8],
    up: DVec3,
    primary: bool,
    /// The segment it is laid along.
    path: [DVec3; 2],
}

impl Bead {
    /// The strip the bead's top models, at the path's level: what the
    /// next layer rests on.
    fn path_strip(&self, width: f64) -> [DVec3; 4] {
        let lift = self.up * top_lift(width);
        std::array::from_fn(|i| self.corners[i] - lift)
    }
}

/// The beads of the segment into waypoint `g`: one box, or two where the
/// nozzle axis and the material below disagree on "up".
fn segment_beads(
    path: &BeadPath,
    g: usize,
    (below_a, h_a): (&Below, f64),
    (below_b, h_b): (&Below, f64),
    width: f64,
) -> Vec<Bead> {
    let (a, b) = (v(path.pos[g - 1]), v(path.pos[g]));
    let t = (b - a).normalize();
    let depth = h_a.max(h_b);
    let mut ups = Vec::with_capacity(2);
    let material = match (below_a.up, below_b.up) {
        (Some(x), Some(y)) => across(x + y, t).or(Some(y)),
        (x, y) => x.or(y),
    };
    let nozzle = nozzle_axis(path.dir[g - 1], path.dir[g], material);
    // A surface fitted below orients the bead alone; a mere direction to
    // the nearest material only when it is plausible, the nozzle too.
    let fitted = [below_a, below_b]
        .iter()
        .all(|b| b.up.is_none() || b.fitted)
        && material.is_some();
    let plausible = |m: &DVec3| fitted || m.dot(nozzle) >= MATERIAL_MAX_DEG.to_radians().cos();
    if let Some(up) = material.filter(plausible).and_then(|m| across(m, t)) {
        ups.push(up);
    }
    if let (false, Some(up)) = (fitted && !ups.is_empty(), across(nozzle, t)) {
        let agree = AGREE_DEG.to_radians().cos();
        if ups.first().is_none_or(|m| m.dot(up) < agree) {
            ups.push(up);
        }
    }
    if ups.is_empty() {
        ups.push(t.any_orthonormal_vector());
    }
    ups.into_iter()
        .enumerate()
        .map(|(i, up)| Bead {
            stamp: stamp_of(g),
            corners: box_corners(a, b, t, up, width, depth),
            up,
            primary: i == 0,
            path: [a, b],
        })
        .collect()
}

/// The unit nozzle axis over a segment whose ends have the axes `a` and
/// `b`: their mean, or `b` alone where they point opposite ways (a single
/// waypoint stored upside down), turned to the side of `material` (the
/// unit direction from the material below) when that is known, so that a
/// bead never hangs above the path it is laid along.
fn nozzle_axis(a: [f64; 3], b: [f64; 3], material: Option<DVec3>) -> DVec3 {
    let (a, b) = (v(a).normalize_or_zero(), v(b).normalize_or_zero());
    let axis = if a.dot(b) >= 0.0 {
        (a + b).normalize_or_zero()
    } else {
        b
    };
    match material {
        Some(m) if axis.dot(m) < 0.0 => -axis,
        _ => axis,
    }
}

/// `u` made perpendicular to the unit `t` and unit, if it is not along `t`
/// (nor nearly zero).
fn across(u: DVec3, t: DVec3) -> Option<DVec3> {
    let p = u - t * u.dot(t);
    let l = p.length();
    (l > 1e-6).then(|| p / l)
}

/// The eight corners of the box over the segment `a → b` (unit direction
/// `t`): top face [`top_lift`] above the path, `width` across, lengthened
/// by `width / 2` at both ends; the bottom face `depth` below the path
/// along `-up`. Top corners go counter-clockwise seen from above.
fn box_corners(a: DVec3, b: DVec3, t: DVec3, up: DVec3, width: f64, depth: f64) -> [DVec3; 8] {
    let side = up.cross(t) * (0.5 * width);
    let lift = up * top_lift(width);
    let (a0, a1) = (a - t * (0.5 * width) + lift, b + t * (0.5 * width) + lift);
    let top = [a0 - side, a1 - side, a1 + side, a0 + side];
    let drop = up * (depth + top_lift(width));
    [
        top[0],
        top[1],
        top[2],
        top[3],
        top[0] - drop,
        top[1] - drop,
        top[2] - drop,
        top[3] - drop,
    ]
}

/// The twelve triangles of a box from [`box_corners`], counter-clockwise
/// seen from outside.
const BOX_TRIANGLES: [[u32; 3]; 12] = [
    // top, bottom
    [0, 1, 2],
    [0, 2, 3],
    [4, 6, 5],
    [4, 7, 6],
    // the four sides
    [0, 4, 5],
    [0, 5, 1],
    [1, 5, 6],
    [1, 6, 2],
    [2, 6, 7],
    [2, 7, 3],
    [3, 7, 4],
    [3, 4, 0],
];

/// Is triangle `i` of a group of beads one of a bead's walls (sides and
/// ends: the eight triangles of a box after its top and bottom)?
pub fn is_wall(i: usize) -> bool {
    i % BOX_TRIANGLES.len() >= 4
}

/// A layer's beads as one stamped group.
fn group_of(beads: &[Bead], layer: usize, width: f64) -> PartGroup {
    let mut beads = beads.to_vec();
    settle::settle_tops(&mut beads, width);
    let mut mesh = Mesh {
        vertices: Vec::with_capacity(8 * beads.len()),
        triangles: Vec::with_capacity(12 * beads.len()),
    };
    let mut stamps = Vec::with_capacity(12 * beads.len());
    for b in &beads {
        let base = mesh.vertices.len() as u32;
        mesh.vertices
            .extend(b.corners.iter().map(|c| c.as_vec3().to_array()));
        mesh.triangles
            .extend(BOX_TRIANGLES.iter().map(|t| t.map(|i| base + i)));
        stamps.extend(std::iter::repeat_n(b.stamp, 12));
    }
    PartGroup {
        mesh,
        stamps,
        layer: Some(layer),
        kind: super::GroupKind::Beads,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rustc_hash::FxHashMap as HashMap;

    const SETTINGS: BeadSettings = BeadSettings {
        width: 0.7,
        height: [0.025, 2.0],
        default_height: 0.5,
        gap: 5.0,
    };

    /// A flat platform: a 100 mm square plate with its top at z = 40.
    fn platform() -> Mesh {
        crate::default_job::box_mesh([-50.0, -50.0, 39.0], [50.0, 50.0, 40.0])
    }

    /// A toolpath with its true surface normals: `layers` layers 0.4 mm
    /// apart on cylinders about an axis parallel to x 70.4 mm up (radius
    /// 30 mm less 0.4 mm a layer: the first 0.4 mm above the platform's
    /// top at its lowest),
    /// each of `passes` lines along x, 0.7 mm apart around the cylinder,
    /// a waypoint every 0.5 mm, alternating direction.
    struct Part {
        pos: Vec<[f64; 3]>,
        normal: Vec<[f64; 3]>,
        layer: Vec<usize>,
    }

    fn cylinder_part(layers: usize, passes: usize) -> Part {
        let mut part = Part {
            pos: Vec::new(),
            normal: Vec::new(),
            layer: Vec::new(),
        };
        for k in 0..layers {
            let r = 30.0 - 0.4 * k as f64;
            for j in 0..passes {
                let angle = (j as f64 - passes as f64 / 2.0) * 0.7 / r;
                let n = [0.0, -angle.sin(), angle.cos()];
                for i in 0..=20 {
                    let x = if j % 2 == 0 { i } else { 20 - i } as f64 * 0.5;
                    let p = [x, r * angle.sin(), 70.4 - r * angle.cos()];
                    part.pos.push(p);
                    part.normal.push(n);
                    part.layer.push(k);
                }
            }
        }
        part
    }

    /// The nozzle axes of `part` rotated `deg` degrees about x.
    fn tilted(part: &Part, deg: f64) -> Vec<[f64; 3]> {
        let (s, c) = deg.to_radians().sin_cos();
        part.normal
            .iter()
            .map(|n| [n[0], c * n[1] - s * n[2], s * n[1] + c * n[2]])
            .collect()
    }

    fn deposit_of(part: &Part, dir: &[[f64; 3]]) -> Deposit {
        let path = BeadPath {
            pos: &part.pos,
            dir,
            layer: &part.layer,
        };
        deposit(path, &platform(), &SETTINGS)
    }

    /// Each bead of a group: its stamp and its twelve triangles.
    fn boxes(group: &PartGroup) -> impl Iterator<Item = (u32, Mesh)> + '_ {
        (0..group.stamps.len() / 12).map(|b| {
            let vertices = group.mesh.vertices[8 * b..8 * b + 8].to_vec();
            let triangles = group.mesh.triangles[12 * b..12 * b + 12]
                .iter()
                .map(|t| t.map(|i| i - 8 * b as u32))
                .collect();
            (
                group.stamps[12 * b],
                Mesh {
                    vertices,
                    triangles,
                },
            )
        })
    }

    /// Is `p` inside the convex closed mesh `m` (behind every face, with
    /// a little slack for the f32 corners)?
    fn inside_convex(m: &Mesh, p: DVec3) -> bool {
        (0..m.triangles.len()).all(|i| {
            let [a, b, c] = m.corners(i).map(|q| v(q.map(f64::from)));
            let n = (b - a).cross(c - a).normalize();
            (p - a).dot(n) <= 1e-4
        })
    }

    #[test]
    fn every_bead_is_a_closed_box_facing_out() {
        let part = cylinder_part(3, 4);
        let d = deposit_of(&part, &part.normal);
        let mut beads = 0;
        for group in &d.groups {
            for (_, b) in boxes(group) {
                assert_eq!(b.open_edges(), 0);
                let vol = b.signed_volume();
                // Segments of 0.5 or 0.7 mm lengthened by 0.7, 0.7 wide, as
                // deep as the 0.33 to 0.45 mm down to the material below
                // and the bottom's allowance for a turned bead, the top
                // settled on its layer's parallel surface (2° of lift).
                let (full, settled) = (top_lift(0.7), settle::lift_for(0.7, 2.0));
                assert!(
                    vol > 1.2 * 0.7 * (0.33 + full + settled)
                        && vol < 1.4 * 0.7 * (0.45 + full + 1.01 * settled),
                    "{vol}"
                );
                beads += 1;
            }
        }
        // 20 segments a pass and 3 between passes a layer, one box each
        // (the nozzle along the normal).
        assert_eq!(beads, 3 * (4 * 21 - 1));
    }

    #[test]
    fn heights_are_the_distance_to_the_material_below() {
        let part = cylinder_part(4, 6);
        let d = deposit_of(&part, &part.normal);
        for (g, &(h, clamped)) in d.heights.iter().enumerate() {
            if part.layer[g] == 0 {
                // Over the flat platform: the cylinder's height there.
                let want = part.pos[g][2] - 40.0;
                assert!(!clamped && (h - want).abs() < 1e-4, "{h} {want}");
            } else {
                assert!(!clamped && (h - 0.4).abs() < 0.02, "waypoint {g}: {h}");
            }
        }
    }

    #[test]
    fn beads_are_stamped_by_their_segment_and_skip_gaps_and_layer_changes() {
        let mut part = cylinder_part(2, 2);
        // A jump longer than the gap inside layer 0's first pass.
        for p in &mut part.pos[11..21] {
            p[0] += 10.0;
        }
        let d = deposit_of(&part, &part.normal);
        // (Beads over the gap's missing material below are modelled both
        // ways: one stamp each.)
        let mut stamps: Vec<u32> = d
            .groups
            .iter()
            .flat_map(|g| boxes(g).map(|(s, _)| s))
            .collect();
        stamps.dedup();
        let want: Vec<u32> = (1..part.pos.len())
            .filter(|&g| g != 11 && g != 21 && part.layer[g] == part.layer[g - 1])
            .map(stamp_of)
            .collect();
        assert_eq!(stamps, want);
        assert_eq!(
            d.groups.iter().map(|g| g.layer).collect::<Vec<_>>(),
            [Some(0), Some(1)]
        );
    }

    /// The material really laid (a bead 0.6 wide and 0.3 deep below the
    /// path along the surface normal, lengthened 0.3 at each end, as the
    /// independent audit models it) lies inside the solids made for its
    /// segment — also when the nozzle is tilted far from the normal, so
    /// that only the material below tells which way the bead lies.
    #[test]
    fn the_deposited_material_lies_inside_its_solids_whatever_the_nozzle_tilt() {
        let part = cylinder_part(3, 5);
        for tilt in [0.0, 20.0, 50.0] {
            let dir = tilted(&part, tilt);
            let d = deposit_of(&part, &dir);
            let mut by_stamp: HashMap<u32, Vec<Mesh>> = HashMap::default();
            for g in &d.groups {
                for (s, b) in boxes(g) {
                    by_stamp.entry(s).or_default().push(b);
                }
            }
            for g in 1..part.pos.len() {
                if part.layer[g] != part.layer[g - 1] || (g % 21) == 0 {
                    continue;
                }
                let solids = &by_stamp[&stamp_of(g)];
                let (a, b) = (v(part.pos[g - 1]), v(part.pos[g]));
                let t = (b - a).normalize();
                let up = v(part.normal[g - 1]) + v(part.normal[g]);
                let up = (up - t * up.dot(t)).normalize();
                let side = up.cross(t);
                for i in 0..=6 {
                    for j in 0..=4 {
                        for k in 0..=3 {
                            let along = -0.3 + i as f64 / 6.0 * (0.6 + (b - a).length());
                            let p = a + t * along + side * (-0.3 + 0.6 * j as f64 / 4.0)
                                - up * (0.3 * k as f64 / 3.0);
                            assert!(
                                solids.iter().any(|m| inside_convex(m, p)),
                                "tilt {tilt}: the point {p} of the bead into waypoint {g} is outside its solids"
                            );
                        }
                    }
                }
            }
        }
    }
}
