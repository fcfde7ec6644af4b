//! What a bead rests on: the tops of the beads laid so far, in a uniform
//! grid, and the platform, in parry's BVH, searched for the nearest top below a
//! waypoint, for the surface those tops lie on, and for whether a waypoint
//! stands over a bead of its own layer.
//!
//! A triangle is listed in every cell its bounding box touches; a search
//! reads the cells in rings of growing Chebyshev distance around the
//! point's cell and stops once the ring is farther than what it still
//! looks for, so the usual search (the layer below, half a millimetre
//! away) reads the 27 cells around the point.

use super::v;
use crate::geometry::point_triangle_distance::closest_point;
use crate::geometry::Mesh;
use glam::DVec3;
use parry3d::shape::{CompositeShapeRef, TriMesh};
use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;

/// How far (in bead widths) around the material below a waypoint the
/// paths that laid it are taken to fit the surface they lie on: far
/// enough to reach the passes beside it.
pub const FIT_WIDTHS: f64 = 2.2;

/// A triangle a search may find: half of a bead's top.
#[derive(Clone, Copy, Debug)]
struct Top {
    corners: [DVec3; 3],
    /// The centre and radius of a sphere holding the corners.
    centre: DVec3,
    radius: f64,
    /// The bead's strip.
    strip: u32,
}

/// A bead's top as laid: the segment along its middle, its layer, and
/// the normal of the surface its layer lies on there once the layer is
/// complete ([`TopGrid::fit_layer`]).
#[derive(Clone, Copy, Debug)]
struct Strip {
    path: [DVec3; 2],
    layer: usize,
    normal: Option<DVec3>,
}

/// What lies below a waypoint: the distance to the nearest earlier top
/// (or the platform) within the search radius, and the unit normal of the
/// surface there, turned towards the waypoint.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Below {
    pub distance: Option<f64>,
    pub up: Option<DVec3>,
    /// Is `up` the normal of the surface there (the platform's, or one
    /// fitted through the paths below), not only the direction to it?
    pub fitted: bool,
}

/// The tops in cubes `cell` mm wide, and the platform in parry's BVH (a
/// platform is far larger than a bead: listed cell by cell, its triangles
/// would fill as many cells as its area holds, whatever the toolpath).
pub(super) struct TopGrid {
    cell: f64,
    platform: Option<(TriMesh, Mesh)>,
    /// The radius of the fit of [`TopGrid::path_normal`] (mm).
    fit_radius: f64,
    tops: Vec<Top>,
    strips: Vec<Strip>,
    cells: HashMap<[i32; 3], Vec<u32>>,
}

impl TopGrid {
    /// An empty grid of cubes `cell` mm wide, fitting surfaces over
    /// `fit_radius` mm.
    pub fn new(cell: f64, fit_radius: f64) -> Self {
        TopGrid {
            cell: cell.max(1e-3),
            platform: None,
            fit_radius,
            tops: Vec::new(),
            strips: Vec::new(),
            cells: HashMap::default(),
        }
    }

    fn cell_of(&self, p: DVec3) -> [i32; 3] {
        (p / self.cell).floor().as_ivec3().to_array()
    }

    fn insert(&mut self, corners: [DVec3; 3], strip: u32) {
        let i = self.tops.len() as u32;
        let centre = (corners[0] + corners[1] + corners[2]) / 3.0;
        let radius = corners
            .iter()
            .map(|c| (*c - centre).length())
            .fold(0.0, f64::max);
        self.tops.push(Top {
            corners,
            centre,
            radius,
            strip,
        });
        let lo = self.cell_of(corners[0].min(corners[1]).min(corners[2]));
        let hi = self.cell_of(corners[0].max(corners[1]).max(corners[2]));
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    self.cells.entry([x, y, z]).or_default().push(i);
                }
            }
        }
    }

    /// Add the platform (replacing any before it).
    pub fn insert_platform(&mut self, platform: &Mesh) {
        let vertices = platform
            .vertices
            .iter()
            .map(|p| parry3d::math::Vector::new(p[0], p[1], p[2]))
            .collect();
        self.platform = TriMesh::new(vertices, platform.triangles.clone())
            .ok()
            .map(|t| (t, platform.clone()));
    }

    /// The nearest point of the platform within `radius` of `p`, its
    /// distance and the normal of the triangle it lies on. parry finds the
    /// triangle (in f32); the point is measured again in f64, as the tops
    /// are.
    fn platform_below(&self, p: DVec3, radius: f64) -> Option<(f64, DVec3, DVec3)> {
        let (tree, mesh) = self.platform.as_ref()?;
        let at = p.as_vec3();
        let point = parry3d::math::Vector::new(at.x, at.y, at.z);
        let slack = (radius * 1e-4).max(1e-3) as f32;
        let (i, _) =
            CompositeShapeRef(tree).project_local_point(point, radius as f32 + slack, false)?;
        let [a, b, c] = mesh.corners(i as usize).map(|x| v(x.map(f64::from)));
        let q = v(closest_point(
            p.to_array(),
            a.to_array(),
            b.to_array(),
            c.to_array(),
        ));
        let d = (p - q).length();
        (d <= radius).then_some((d, q, (b - a).cross(c - a)))
    }

    /// List a bead's top `c` (its four corners counter-clockwise seen from
    /// above), laid along `path` in `layer`.
    pub fn insert_strip(&mut self, c: [DVec3; 4], layer: usize, path: [DVec3; 2]) {
        let s = self.strips.len() as u32;
        self.strips.push(Strip {
            path,
            layer,
            normal: None,
        });
        self.insert([c[0], c[1], c[2]], s);
        self.insert([c[0], c[2], c[3]], s);
    }

    /// Fit the surface under every strip of `layer` (listed from `first`
    /// on): [`PathEnds::normal_at`] the middle of its path, through the
    /// layer's path ends, kept for the waypoints above it to read.
    pub fn fit_layer(&mut self, first: usize, layer: usize) {
        // The paths alone, not the beads' guessed orientations.
        let of_layer = self.strips[first..].iter().filter(|s| s.layer == layer);
        let ends = PathEnds::new(of_layer.map(|s| s.path), self.fit_radius);
        let normals: Vec<Option<DVec3>> = self.strips[first..]
            .par_iter()
            .map(|s| {
                (s.layer == layer)
                    .then(|| ends.normal_at(0.5 * (s.path[0] + s.path[1])))
                    .flatten()
            })
            .collect();
        for (s, n) in self.strips[first..].iter_mut().zip(normals) {
            if s.layer == layer {
                s.normal = n;
            }
        }
    }

    /// Move every strip listed from `first` on to `layer`.
    pub fn relabel_from(&mut self, first: usize, layer: usize) {
        for s in &mut self.strips[first..] {
            s.layer = layer;
        }
    }

    /// The number of strips listed.
    pub fn strip_count(&self) -> usize {
        self.strips.len()
    }

    /// The layer of a top.
    fn layer(&self, top: &Top) -> usize {
        self.strips[top.strip as usize].layer
    }

    /// Visit the tops listed in the cells around `p`, ring by ring out to
    /// `reach`, until `visit` (given a top's index) returns `false` or the
    /// next ring lies farther than `needed()`.
    fn rings(
        &self,
        p: DVec3,
        reach: f64,
        needed: impl Fn() -> f64,
        mut visit: impl FnMut(u32) -> bool,
    ) {
        let c = self.cell_of(p);
        let last = (reach / self.cell).ceil() as i32;
        for r in 0..=last {
            // Cells of ring r are at least (r - 1) cells from p.
            if r > 0 && (r - 1) as f64 * self.cell > needed() {
                return;
            }
            for x in -r..=r {
                for y in -r..=r {
                    for z in -r..=r {
                        if x.abs().max(y.abs()).max(z.abs()) != r {
                            continue;
                        }
                        let Some(list) = self.cells.get(&[c[0] + x, c[1] + y, c[2] + z]) else {
                            continue;
                        };
                        for &i in list {
                            if !visit(i) {
                                return;
                            }
                        }
                    }
                }
            }
        }
    }

    /// The nearest top below `p` (a waypoint of `layer`) within `radius`:
    /// the platform, or a bead of the `lookback` layers before `layer`;
    /// the normal there is the platform triangle's, or the one fitted
    /// under that bead ([`TopGrid::fit_layer`]), else the direction from
    /// it to `p`.
    pub fn below(&self, p: DVec3, layer: usize, radius: f64, lookback: usize) -> Below {
        self.search(p, layer, radius, lookback, None).0
    }

    /// [`TopGrid::below`], and whether `p` stands over a bead of `layer`
    /// itself: its height above the bead's top within `over`, its foot
    /// within `across` of the path the bead was laid along. Only beads as
    /// near as the material below are asked (a bead of `layer` under `p`
    /// lies between it and that material).
    pub fn below_and_over(
        &self,
        p: DVec3,
        layer: usize,
        radius: f64,
        lookback: usize,
        over: [f64; 2],
        across: f64,
    ) -> (Below, bool) {
        self.search(p, layer, radius, lookback, Some((over, across)))
    }

    fn search(
        &self,
        p: DVec3,
        layer: usize,
        radius: f64,
        lookback: usize,
        over: Option<([f64; 2], f64)>,
    ) -> (Below, bool) {
        let oldest = layer.saturating_sub(lookback);
        // The nearest so far: its distance, point and top (`None`: the
        // platform, whose normal is kept beside).
        let platform = self.platform_below(p, radius);
        let best: std::cell::Cell<Option<(f64, DVec3, Option<u32>)>> =
            std::cell::Cell::new(platform.map(|(d, q, _)| (d, q, None)));
        let bound = || best.get().map_or(radius, |b| b.0);
        let mut stands = false;
        self.rings(p, radius, bound, |i| {
            let top = &self.tops[i as usize];
            match self.layer(top) {
                l if l == layer => {
                    if let Some((heights, across)) = over {
                        let path = self.strips[top.strip as usize].path;
                        stands |= stands_over(p, &top.corners, path, heights, across);
                    }
                    return !stands;
                }
                l if l < oldest || l > layer => return true,
                _ => {}
            }
            if (p - top.centre).length() - top.radius >= bound() {
                return true;
            }
            let [a, b, c] = top.corners.map(|q| q.to_array());
            let q = v(closest_point(p.to_array(), a, b, c));
            let d = (p - q).length();
            let better = match best.get() {
                Some((bd, _, bi)) => d < bd || (d == bd && Some(i) < bi),
                None => d <= radius,
            };
            if better {
                best.set(Some((d, q, Some(i))));
            }
            true
        });
        let Some((d, q, i)) = best.get() else {
            return (Below::default(), stands);
        };
        let away = p - q;
        let normal = match i {
            None => platform.map(|(_, _, n)| n),
            Some(i) => self.strips[self.tops[i as usize].strip as usize].normal,
        };
        let fitted = normal.and_then(|n| n.try_normalize());
        let up = match fitted {
            Some(n) if n.dot(away) < 0.0 => Some(-n),
            Some(n) => Some(n),
            None => (d > 1e-9).then(|| away / d),
        };
        let below = Below {
            distance: Some(d),
            up,
            fitted: fitted.is_some(),
        };
        (below, stands)
    }
}

/// The ends of one layer's bead paths by the cells (`radius` mm cubes)
/// they lie in: every end within `radius` of a point lies in the 27
/// cells around the point's.
pub(super) struct PathEnds {
    radius: f64,
    cells: HashMap<[i32; 3], Vec<DVec3>>,
}

impl PathEnds {
    /// The ends of `paths`, to fit surfaces over `radius` mm.
    pub fn new(paths: impl Iterator<Item = [DVec3; 2]>, radius: f64) -> PathEnds {
        let radius = radius.max(1e-3);
        let mut cells: HashMap<[i32; 3], Vec<DVec3>> = HashMap::default();
        for e in paths.flatten() {
            let c = (e / radius).floor().as_ivec3().to_array();
            cells.entry(c).or_default().push(e);
        }
        PathEnds { radius, cells }
    }

    /// The normal of the plane through the ends within the radius of `q`
    /// (each once), where they spread over a surface ([`plane_normal`]):
    /// the surface the paths were laid on there.
    pub fn normal_at(&self, q: DVec3) -> Option<DVec3> {
        let c = (q / self.radius).floor().as_ivec3().to_array();
        let mut points: Vec<DVec3> = Vec::new();
        for x in -1..=1 {
            for y in -1..=1 {
                for z in -1..=1 {
                    if let Some(list) = self.cells.get(&[c[0] + x, c[1] + y, c[2] + z]) {
                        points.extend(list.iter().filter(|e| (**e - q).length() <= self.radius));
                    }
                }
            }
        }
        points.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).expect("finite"));
        points.dedup();
        plane_normal(&points)
    }
}

/// Is `p` over the bead whose top is `c` (four corners counter-clockwise
/// seen from above), laid along `path`, as [`TopGrid::below_and_over`]
/// asks it?
pub(super) fn stands_over_strip(
    p: DVec3,
    c: &[DVec3; 4],
    path: [DVec3; 2],
    heights: [f64; 2],
    across: f64,
) -> bool {
    let reach = heights[1] + across + (path[1] - path[0]).length();
    (p - path[0]).length() <= reach && stands_over(p, &[c[0], c[1], c[2]], path, heights, across)
}

/// Is `p` between `low` and `high` above the plane of the top `[a, b, c]`
/// (counter-clockwise seen from above) of a bead laid along `[s, e]`, its
/// foot within `across` of that segment and not beyond its ends?
fn stands_over(
    p: DVec3,
    [a, b, c]: &[DVec3; 3],
    [s, e]: [DVec3; 2],
    [low, high]: [f64; 2],
    across: f64,
) -> bool {
    let n = (*b - *a).cross(*c - *a);
    let len = n.length();
    let along = e - s;
    let l = along.length();
    if len <= 0.0 || l <= 0.0 {
        return false;
    }
    let (n, t) = (n / len, along / l);
    let height = (p - s).dot(n);
    if height < low || height > high {
        return false;
    }
    let foot = p - n * height - s;
    let x = foot.dot(t);
    (0.0..=l).contains(&x) && (foot - t * x).length() <= across
}

/// The normal of the plane through `points` (least squares), when they
/// spread over a surface: the second-largest spread at least a quarter of
/// the largest (in standard deviation) and five points or more.
pub(super) fn plane_normal(points: &[DVec3]) -> Option<DVec3> {
    use glamx::{glam, DSymmetricEigen3};
    if points.len() < 5 {
        return None;
    }
    let mean = points.iter().copied().sum::<DVec3>() / points.len() as f64;
    let mut cov = [[0.0f64; 3]; 3];
    for p in points {
        let d = (*p - mean).to_array();
        for (i, row) in cov.iter_mut().enumerate() {
            for (j, c) in row.iter_mut().enumerate() {
                *c += d[i] * d[j];
            }
        }
    }
    // (Eigenvalues in ascending order, eigenvectors as columns.)
    let eigen = DSymmetricEigen3::new(glam::DMat3::from_cols_array_2d(&cov));
    let [_, middle, most] = eigen.eigenvalues.to_array().map(|e| e.max(0.0));
    if middle < 0.0625 * most {
        return None;
    }
    Some(DVec3::from_array(eigen.eigenvectors.x_axis.to_array()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The nearest top the rings find is the nearest of a plain loop over
    /// every top, at every distance the search may reach.
    #[test]
    fn the_rings_find_what_a_plain_loop_finds() {
        let mut grid = TopGrid::new(0.7, 1.0);
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut next = || rng.random::<f64>();
        for k in 0..400 {
            let a = DVec3::new(next() * 8.0, next() * 8.0, next() * 3.0);
            let t = DVec3::new(next() - 0.5, next() - 0.5, 0.0).normalize() * 0.6;
            let side = DVec3::new(-t.y, t.x, 0.0) * 0.5;
            let c = [a - side, a + t - side, a + t + side, a + side];
            grid.insert_strip(c, k / 100, [a, a + t]);
        }
        for _ in 0..300 {
            let p = DVec3::new(next() * 8.0, next() * 8.0, next() * 4.0);
            let below = grid.below(p, 4, 2.0, 25);
            let plain = grid
                .tops
                .iter()
                .map(|t| {
                    let [a, b, c] = t.corners.map(|q| q.to_array());
                    (p - v(closest_point(p.to_array(), a, b, c))).length()
                })
                .filter(|&d| d <= 2.0)
                .fold(None, |m: Option<f64>, d| Some(m.map_or(d, |m| m.min(d))));
            assert_eq!(below.distance, plain, "at {p}");
        }
    }

    #[test]
    fn a_plane_through_two_passes_has_their_normal() {
        let n = DVec3::new(0.2, -0.1, 1.0).normalize();
        let (u, w) = (n.any_orthonormal_pair().0, n.any_orthonormal_pair().1);
        let points: Vec<DVec3> = (0..10)
            .flat_map(|i| [0.0, 0.7].map(|s| u * (0.3 * i as f64) + w * s))
            .collect();
        let got = plane_normal(&points).expect("a surface");
        assert!(got.dot(n).abs() > 1.0 - 1e-9, "{got} vs {n}");
        // One pass alone is a line: no plane.
        assert_eq!(
            plane_normal(&points.iter().step_by(2).copied().collect::<Vec<_>>()),
            None
        );
    }
}
