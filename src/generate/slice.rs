//! Multi-directional planar slicing (paper 003): a closed mesh cut by
//! parallel planes normal to any direction `d`, each slice turned into grid
//! points of spacing S and ordered by a raster [`Fill`].
//!
//! Layer k's plane sits at `t_min + (k + ½)·H` along `d` (mid-layer, so the
//! part's own faces never lie in a plane), from the mesh's lowest point
//! along `d`. A slice is the set of closed section loops ([`section`]); a
//! grid point is inside by the even-odd rule along its row, so cavities
//! (holes) and islands inside them come out right without classifying
//! loops. The grid is anchored half a step inside the slice's bounding box,
//! on the in-plane axes `u`, `v` (`u × v = d`); rows run along `u`.
//! Waypoints are the grid points in fill order, on the slice plane, with the
//! nozzle along `d`; MZZ starts each layer, among its equally short
//! orders, nearest where the previous layer ended. Each layer's surface is the union of one strip of
//! width S per run (the printed region), facing `d`.

use super::curvature::tangent_axes;
use super::fill::{lengths, order_from, Fill, Lengths, Pass, Run};
use super::section::section;
use super::{validate, GenerateError};
use crate::geometry::Mesh;
use crate::toolpath::{Layer, Toolpath, Waypoint};
use glam::DVec3;
use serde::Serialize;

/// Slicing settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SliceOptions {
    /// Slicing direction (normalised here): layers are stacked along it and
    /// the nozzle points along it.
    pub dir: [f64; 3],
    /// Layer thickness H (mm).
    pub layer: f64,
    /// Grid spacing S (mm).
    pub spacing: f64,
    /// Raster.
    pub fill: Fill,
}

/// Per-layer figures.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LayerSummary {
    /// The layer's name in the toolpath.
    pub name: String,
    /// The plane's offset along the slicing direction (mm).
    pub offset: f64,
    /// Grid points printed.
    pub waypoints: usize,
    /// Runs (row pieces) in the slice.
    pub runs: usize,
    /// Printing length (mm).
    pub print_length: f64,
    /// Travel (non-printing) length within the layer (mm).
    pub travel_length: f64,
    /// Travel from the previous layer's last waypoint to this layer's
    /// first (mm; 0 for the first layer).
    pub entry_length: f64,
}

/// A sliced and filled mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct SliceResult {
    /// One layer per non-empty slice, named 0, 1, …, with its strip surface.
    pub toolpath: Toolpath,
    /// Figures per layer.
    pub layers: Vec<LayerSummary>,
    /// The unit slicing direction.
    pub dir: [f64; 3],
}

impl SliceResult {
    /// Total printing and travel length over all layers (mm).
    pub fn lengths(&self) -> Lengths {
        Lengths {
            print: self.layers.iter().map(|l| l.print_length).sum(),
            travel: self.layers.iter().map(|l| l.travel_length).sum(),
        }
    }
}

/// The in-plane axes `(u, v)` of the slices along the unit direction `d`,
/// `u × v = d`: grid rows run along `u`.
pub fn frame(d: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let (u, v) = tangent_axes(DVec3::from(d));
    (u.to_array(), v.to_array())
}

/// Slice `mesh` (closed, outward-facing) and fill every slice.
pub fn slice(mesh: &Mesh, opts: &SliceOptions) -> Result<SliceResult, GenerateError> {
    let d = unit_direction(opts)?;
    let mesh = validate::solid(mesh)?;
    let (u, v) = tangent_axes(d);
    let ts: Vec<f64> = mesh
        .vertices
        .iter()
        .map(|p| d.dot(DVec3::from(p.map(f64::from))))
        .collect();
    let t_min = ts.iter().copied().fold(f64::INFINITY, f64::min);
    let t_max = ts.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let n_layers = ((t_max - t_min) / opts.layer).ceil().max(1.0) as usize;
    if n_layers > 100_000 {
        return Err(GenerateError::Parameter(format!(
            "{n_layers} layers: use a thicker layer (the part is {:.1} mm along the direction)",
            t_max - t_min
        )));
    }
    let mut result = SliceResult {
        toolpath: Toolpath::default(),
        layers: Vec::new(),
        dir: d.to_array(),
    };
    let mut total_points = 0usize;
    let mut prev_end: Option<DVec3> = None;
    for k in 0..n_layers {
        let t = t_min + (k as f64 + 0.5) * opts.layer;
        if t >= t_max {
            break;
        }
        let plane = Plane { u, v, d, t };
        let Some(grid) = Grid::of(&mesh, &plane, opts.spacing)? else {
            continue;
        };
        let from = prev_end.map(|p| grid.cell(plane.coords(p)));
        let ord = order_from(&grid.runs, opts.fill, from);
        let len = lengths(&grid.runs, &ord, opts.spacing);
        let waypoints = grid.waypoints(&plane, &ord);
        total_points += waypoints.len();
        let first = DVec3::from(waypoints[0].pos.map(f64::from));
        let entry_length = prev_end.map_or(0.0, |p| p.distance(first));
        prev_end = Some(DVec3::from(
            waypoints[waypoints.len() - 1].pos.map(f64::from),
        ));
        if total_points > 50_000_000 {
            return Err(GenerateError::Parameter(
                "more than 50 million waypoints: use a coarser spacing or thicker layers".into(),
            ));
        }
        let name = result.toolpath.layers.len().to_string();
        result.layers.push(LayerSummary {
            name: name.clone(),
            offset: t,
            waypoints: waypoints.len(),
            runs: grid.runs.len(),
            print_length: len.print,
            travel_length: len.travel,
            entry_length,
        });
        result.toolpath.layers.push(Layer {
            name,
            waypoints,
            surface: Some(grid.strips(&plane)),
        });
    }
    if result.toolpath.layers.is_empty() {
        return Err(GenerateError::Parameter(format!(
            "no slice holds a grid point: the part is {:.3} mm thick along the direction; use thinner layers or a finer spacing",
            t_max - t_min
        )));
    }
    Ok(result)
}

/// The unit slicing direction, once the settings are checked.
fn unit_direction(opts: &SliceOptions) -> Result<DVec3, GenerateError> {
    let dir = DVec3::from(opts.dir);
    let len = dir.length();
    if !(len.is_finite() && len > 1e-9) {
        return Err(GenerateError::Parameter(
            "the slicing direction must be a non-zero vector X,Y,Z".into(),
        ));
    }
    if !(opts.layer.is_finite() && opts.layer > 0.0) {
        return Err(GenerateError::Parameter(
            "the layer thickness must be a positive number (mm)".into(),
        ));
    }
    if !(opts.spacing.is_finite() && opts.spacing > 0.0) {
        return Err(GenerateError::Parameter(
            "the grid spacing must be a positive number (mm)".into(),
        ));
    }
    Ok(dir / len)
}

/// A slicing plane: `d · x = t`, with in-plane axes `u`, `v` (`u × v = d`).
struct Plane {
    u: DVec3,
    v: DVec3,
    d: DVec3,
    t: f64,
}

impl Plane {
    /// The in-plane coordinates of `p`.
    fn coords(&self, p: DVec3) -> [f64; 2] {
        [p.dot(self.u), p.dot(self.v)]
    }

    /// The point of the plane at in-plane coordinates `(a, b)`.
    fn point(&self, a: f64, b: f64) -> [f32; 3] {
        (self.u * a + self.v * b + self.d * self.t)
            .as_vec3()
            .to_array()
    }
}

/// One slice's grid points inside the part, as runs along its rows.
struct Grid {
    /// The grid point of row 0, column 0 (in-plane coordinates): half a
    /// step inside the slice's bounding box.
    base: [f64; 2],
    /// Spacing (mm).
    spacing: f64,
    runs: Vec<Run>,
}

impl Grid {
    /// The grid of the slice of `mesh` in `plane`; `None` when the plane
    /// misses the part or no grid point lies inside.
    fn of(mesh: &Mesh, plane: &Plane, s: f64) -> Result<Option<Grid>, GenerateError> {
        // Section loops in plane coordinates.
        let loops: Vec<Vec<[f64; 2]>> = section(mesh, plane.d, plane.t)
            .into_iter()
            .map(|p| p.points.iter().map(|q| plane.coords(q.pos)).collect())
            .collect();
        let Some((lo, hi)) = bounds(&loops) else {
            return Ok(None);
        };
        let cols = ((hi[0] - lo[0]) / s).floor() as i64 + 1;
        let n_rows = ((hi[1] - lo[1]) / s).floor() as i64 + 1;
        if (cols as f64) * (n_rows as f64) > 5e7 {
            return Err(GenerateError::Parameter(format!(
                "a slice of {:.1} × {:.1} mm holds too many grid points at spacing {s} mm: use a coarser spacing",
                hi[0] - lo[0],
                hi[1] - lo[1]
            )));
        }
        let base = [lo[0] + 0.5 * s, lo[1] + 0.5 * s];
        let mut runs = Vec::new();
        for row in 0..n_rows {
            let y = base[1] + row as f64 * s;
            for (x0, x1) in row_intervals(&loops, y) {
                let i0 = ((x0 - base[0]) / s).ceil() as i64;
                let i1 = ((x1 - base[0]) / s).floor() as i64;
                if i0 <= i1 {
                    runs.push(Run { row, i0, i1 });
                }
            }
        }
        Ok((!runs.is_empty()).then_some(Grid {
            base,
            spacing: s,
            runs,
        }))
    }

    /// In-plane coordinates `p` in grid steps from the base.
    fn cell(&self, p: [f64; 2]) -> [f64; 2] {
        [
            (p[0] - self.base[0]) / self.spacing,
            (p[1] - self.base[1]) / self.spacing,
        ]
    }

    /// The point of column `i`, row `row` (fractional for cell corners).
    fn point(&self, plane: &Plane, i: f64, row: f64) -> [f32; 3] {
        plane.point(
            self.base[0] + i * self.spacing,
            self.base[1] + row * self.spacing,
        )
    }

    /// The grid points in the order of `passes`, nozzle along the plane's normal.
    fn waypoints(&self, plane: &Plane, passes: &[Pass]) -> Vec<Waypoint> {
        let dir = plane.d.as_vec3().to_array();
        let mut waypoints = Vec::new();
        for p in passes {
            let r = self.runs[p.run];
            let cols: Box<dyn Iterator<Item = i64>> = if p.forward {
                Box::new(r.i0..=r.i1)
            } else {
                Box::new((r.i0..=r.i1).rev())
            };
            waypoints.extend(cols.map(|i| Waypoint {
                pos: self.point(plane, i as f64, r.row as f64),
                dir,
            }));
        }
        waypoints
    }

    /// The printed region: one strip of width S per run, facing the
    /// plane's normal.
    fn strips(&self, plane: &Plane) -> Mesh {
        let mut surface = Mesh::default();
        for r in &self.runs {
            let (a0, a1) = (r.i0 as f64 - 0.5, r.i1 as f64 + 0.5);
            let (b0, b1) = (r.row as f64 - 0.5, r.row as f64 + 0.5);
            let n = surface.vertices.len() as u32;
            for (a, b) in [(a0, b0), (a1, b0), (a1, b1), (a0, b1)] {
                surface.vertices.push(self.point(plane, a, b));
            }
            surface.triangles.push([n, n + 1, n + 2]);
            surface.triangles.push([n, n + 2, n + 3]);
        }
        surface
    }
}

/// Bounding box of the loops' points.
fn bounds(loops: &[Vec<[f64; 2]>]) -> Option<([f64; 2], [f64; 2])> {
    let mut it = loops.iter().flatten();
    let first = *it.next()?;
    Some(it.fold((first, first), |(lo, hi), p| {
        (
            [lo[0].min(p[0]), lo[1].min(p[1])],
            [hi[0].max(p[0]), hi[1].max(p[1])],
        )
    }))
}

/// Inside intervals of the horizontal line at `y` by the even-odd rule
/// (edges are half-open in y, so a line through a vertex counts it once).
pub fn row_intervals(loops: &[Vec<[f64; 2]>], y: f64) -> Vec<(f64, f64)> {
    let mut xs = Vec::new();
    for lp in loops {
        for k in 0..lp.len() {
            let (a, b) = (lp[k], lp[(k + 1) % lp.len()]);
            if (a[1] <= y) != (b[1] <= y) {
                xs.push(a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1]));
            }
        }
    }
    xs.sort_by(f64::total_cmp);
    xs.chunks_exact(2).map(|c| (c[0], c[1])).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::default_job::box_mesh;
    use glam::Vec3;

    #[test]
    fn frame_is_right_handed_and_orthonormal() {
        for d in [DVec3::Z, DVec3::X, DVec3::new(0.3, -0.5, 0.8).normalize()] {
            let (u, v) = frame(d.to_array());
            let (u, v) = (DVec3::from(u), DVec3::from(v));
            assert!((u.cross(v) - d).abs().max_element() < 1e-12, "{d:?}");
            assert!(u.dot(d).abs() < 1e-12 && (u.dot(u) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn a_box_sliced_upwards_gives_full_grids_on_the_planes() {
        let b = box_mesh([0.0; 3], [3.0, 2.0, 1.0]);
        let r = slice(
            &b,
            &SliceOptions {
                dir: [0.0, 0.0, 2.0],
                layer: 0.25,
                spacing: 0.5,
                fill: Fill::Zigzag,
            },
        )
        .unwrap();
        assert_eq!(r.toolpath.layers.len(), 4);
        for (k, l) in r.toolpath.layers.iter().enumerate() {
            assert_eq!(l.waypoints.len(), 6 * 4);
            let z = 0.125 + 0.25 * k as f32;
            assert!(l.waypoints.iter().all(|w| (w.pos[2] - z).abs() < 1e-6));
            assert!(l.waypoints.iter().all(|w| w.dir == [0.0, 0.0, 1.0]));
            // grid half a step inside the box
            assert!(l
                .waypoints
                .iter()
                .all(|w| w.pos[0] >= 0.25 - 1e-6 && w.pos[0] <= 2.75 + 1e-6));
            let area: f64 = l
                .surface
                .as_ref()
                .unwrap()
                .triangles
                .iter()
                .enumerate()
                .map(|(i, _)| {
                    let [a, b, c] = l.surface.as_ref().unwrap().corners(i).map(Vec3::from);
                    (b - a).cross(c - a).length() as f64 / 2.0
                })
                .sum();
            assert!((area - 6.0).abs() < 1e-4, "{area}");
        }
        assert_eq!(r.layers[0].travel_length, 0.0);
        assert!((r.layers[0].print_length - (4.0 * 2.5 + 3.0 * 0.5)).abs() < 1e-9);
    }

    #[test]
    fn bad_parameters_and_open_meshes_are_refused() {
        let b = box_mesh([0.0; 3], [1.0; 3]);
        let o = SliceOptions {
            dir: [0.0, 0.0, 0.0],
            layer: 0.2,
            spacing: 0.3,
            fill: Fill::Mzz,
        };
        assert!(matches!(slice(&b, &o), Err(GenerateError::Parameter(_))));
        let mut open = b.clone();
        open.triangles.pop();
        let o = SliceOptions {
            dir: [0.0, 0.0, 1.0],
            ..o
        };
        assert!(matches!(slice(&open, &o), Err(GenerateError::Open { .. })));
    }
}
