//! Deposition-rate-optimal iso-planar paths on one curved layer surface
//! (paper 001).
//!
//! **Effective width (Sec. 2.1).** Beads are ellipses of width `s` (major
//! axis, the nozzle diameter) and height `h` (the layer thickness) laid side
//! by side; the cusp-area equilibrium — overlap between neighbours equal to
//! the gaps they leave against the previous layer and the layer surface —
//! is conservation of cross-section: one ellipse (`π s h / 4`) fills one
//! cell of the layer. On a flat layer the cell is `w × h`, so
//! `w_eff = s·cos ρ* = π s / 4`. Across a layer bent with normal curvature
//! `κ` along the side direction `k` (positive when convex), the cell is an
//! annular sector between the surface and the previous layer `h` below it,
//! of area `w h (1 − κ h / 2)` for a width `w` measured on the surface, so
//! `w_eff = (π s / 4) / (1 − κ h / 2)`: wider on convex layers, narrower on
//! concave ones.
//!
//! **Feed rate (Sec. 2.2)** with our machine instead of a robot arm: at each
//! vertex and feed direction `f`, the axes (both IK solutions, the nearer
//! one at the other end) at `p ± l·f` with the fitted surface's normals
//! give each axis' travel per mm of tip motion (a central difference, so
//! the sign of `f` does not matter); `f*` is the smallest of the axis
//! speed limits divided by those rates, the commanded feed and the
//! extruder's largest tip speed. Only velocity limits exist in the machine
//! file, so Eq. 8's acceleration and jerk rows are not used.
//!
//! **Deposition rate (Eq. 10, 11).** `v_e(θ) = π h w_eff(θ) f*(θ)` for the
//! drive-plane normal `q = (sin θ, cos θ, 0)`; the feed direction at a
//! vertex is the tangent `n × q`, the side direction `k = n × f`. θ* is the
//! θ (sampled over [0°, 180°]) with the largest mean over the vertices (the
//! first one on ties, values within 10⁻⁶ counting as tied, so a symmetric
//! curve picks the smaller of its mirror-image maxima).
//!
//! **Paths (Sec. 3).** Drive planes `q·x = c` from the extreme of the
//! surface: the first half a side step in, then each next one a side step
//! `w_s*` further (Eq. 14: the smallest `w_eff(θ*)` along the current
//! curve), converted to a plane offset by the length of `q`'s tangential
//! part, so the curves are `w_s*` apart *on the surface*. Each plane's
//! section is sampled by the chord-error forward step (Eq. 12,
//! `l_f = √(8 δ r_f − 4 δ²)` with `r_f` the radius of curvature along the
//! feed direction), shortened further where the section bends more than
//! the local estimate says, so no section point is farther than `δ` from a
//! chord. Curves alternate direction (zig-zag); the nozzle follows the
//! surface normal (vertex normals interpolated along the section).

use super::curvature::{local_frames, unit, LocalFrame};
use super::section::{section, SectionPoint};
use super::{validate, GenerateError};
use crate::geometry::point_segment_distance::point_segment_distance;
use crate::geometry::Mesh;
use crate::kinematics::{inverse, wrap, Axes, Machine};
use crate::toolpath::{Layer, Toolpath, Waypoint};
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;
use std::f64::consts::PI;

/// A sampled section piece: positions and nozzle directions.
type Piece = (Vec<DVec3>, Vec<DVec3>);

/// Iso-planar settings.
#[derive(Clone, Debug, PartialEq)]
pub struct IsoplanarOptions {
    /// The machine whose axis limits bound the feed rate.
    pub machine: Machine,
    /// Bead width `s`, the ellipse's major axis (mm).
    pub nozzle: f64,
    /// Layer thickness `h`, the ellipse's minor axis (mm).
    pub height: f64,
    /// Largest chord error δ_c (mm).
    pub chord_error: f64,
    /// Longest forward step (mm), for flat stretches.
    pub max_step: f64,
    /// Sampling of θ over [0°, 180°] (degrees).
    pub theta_step_deg: f64,
    /// Half the finite-difference step along the feed direction (mm).
    pub feed_probe: f64,
}

impl Default for IsoplanarOptions {
    fn default() -> Self {
        IsoplanarOptions {
            machine: Machine::default(),
            nozzle: 0.7,
            height: 0.5,
            chord_error: 0.05,
            max_step: 2.0,
            theta_step_deg: 2.0,
            feed_probe: 0.25,
        }
    }
}

/// One sample of the mean deposition-rate curve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CurvePoint {
    /// Feed angle θ (degrees).
    pub theta_deg: f64,
    /// Mean deposition rate over the vertices, Eq. 11 (mm³/s).
    pub v_e: f64,
    /// Mean effective width (mm).
    pub w_eff: f64,
    /// Mean kinematics-limited feed rate (mm/s).
    pub feed: f64,
}

/// Iso-planar paths on one surface.
#[derive(Clone, Debug, PartialEq)]
pub struct IsoplanarResult {
    /// One layer, named `0`, whose surface is the (welded) input.
    pub toolpath: Toolpath,
    /// The mean v_e(θ) curve.
    pub curve: Vec<CurvePoint>,
    /// θ* (degrees).
    pub theta_star_deg: f64,
    /// Side step of each drive plane after the first, on the surface (mm).
    pub side_steps: Vec<f64>,
    /// Printing length: along the curves and the short joins between them (mm).
    pub print_length: f64,
    /// Travel: joins longer than two side steps (mm).
    pub travel_length: f64,
}

impl IsoplanarResult {
    /// The drive planes' normal at θ* ([`drive_normal`]).
    pub fn drive_plane_normal(&self) -> [f64; 3] {
        drive_normal(self.theta_star_deg.to_radians()).to_array()
    }
}

/// Effective width on a layer bent with convex normal curvature `kappa`
/// (1/mm) across the bead (see the module comment).
pub fn effective_width(nozzle: f64, height: f64, kappa: f64) -> f64 {
    let bend = (kappa * height / 2.0).clamp(-1.0, 0.5);
    PI * nozzle / 4.0 / (1.0 - bend)
}

/// The feed direction at a frame for drive-plane normal `q`.
fn feed_dir(fr: &LocalFrame, q: DVec3) -> DVec3 {
    let f = fr.normal.cross(q);
    if f.dot(f) < 1e-12 {
        fr.e1
    } else {
        unit(f)
    }
}

/// Kinematics-limited feed rate at `fr` along the unit tangent `f`.
pub fn feed_rate(m: &Machine, fr: &LocalFrame, f: DVec3, probe: f64) -> f64 {
    let at = |sgn: f64| {
        let t = f * (sgn * probe);
        let p = (fr.origin + t).as_vec3().to_array();
        let n = fr.normal_at(t).as_vec3().to_array();
        inverse(m, p, n)
    };
    let (a, b) = (at(-1.0), at(1.0));
    let gap = |x: &Axes, y: &Axes| (x.tilt - y.tilt).abs() + wrap(x.c - y.c).abs();
    let mut best = 0.0f64;
    for x in &a {
        let y = if gap(x, &b[0]) <= gap(x, &b[1]) {
            &b[0]
        } else {
            &b[1]
        };
        let per_mm = |d: f64| d.abs() / (2.0 * probe);
        let mut v = m.feed.min(m.tip_speed[1]);
        for (d, speed) in [
            (x.xyz[0] - y.xyz[0], m.x.speed),
            (x.xyz[1] - y.xyz[1], m.y.speed),
            (x.xyz[2] - y.xyz[2], m.z.speed),
            ((x.tilt - y.tilt).to_degrees(), m.tilt.speed),
            (wrap(x.c - y.c).to_degrees(), m.c.speed),
        ] {
            let r = per_mm(d);
            if r > 0.0 {
                v = v.min(speed / r);
            }
        }
        best = best.max(v);
    }
    best
}

/// The drive-plane normal of angle θ (radians).
pub fn drive_normal(theta: f64) -> DVec3 {
    DVec3::new(theta.sin(), theta.cos(), 0.0)
}

/// Per-vertex effective width, feed rate and deposition rate at θ.
fn vertex_rates(frames: &[LocalFrame], opts: &IsoplanarOptions, theta: f64) -> Vec<[f64; 3]> {
    let q = drive_normal(theta);
    frames
        .par_iter()
        .map(|fr| {
            let f = feed_dir(fr, q);
            let k = fr.normal.cross(f);
            let w = effective_width(opts.nozzle, opts.height, fr.convex_curvature(k));
            let feed = feed_rate(&opts.machine, fr, f, opts.feed_probe);
            [w, feed, PI * opts.height * w * feed]
        })
        .collect()
}

/// The mean v_e(θ) curve over the vertices of `mesh` (validated surface).
pub fn deposition_curve(frames: &[LocalFrame], opts: &IsoplanarOptions) -> Vec<CurvePoint> {
    let n = (180.0 / opts.theta_step_deg).round().max(1.0) as usize;
    (0..=n)
        .map(|i| {
            let theta_deg = 180.0 * i as f64 / n as f64;
            let r = vertex_rates(frames, opts, theta_deg.to_radians());
            let mean = |k: usize| r.iter().map(|x| x[k]).sum::<f64>() / r.len() as f64;
            CurvePoint {
                theta_deg,
                v_e: mean(2),
                w_eff: mean(0),
                feed: mean(1),
            }
        })
        .collect()
}

/// The point a fraction `t` of the way from `a` to `b`.
fn lerp(a: DVec3, b: DVec3, t: f64) -> DVec3 {
    a + (b - a) * t
}

/// Generate the iso-planar path on `mesh` (a manifold surface, open or
/// closed, whose winding makes its normals point to the nozzle side).
pub fn isoplanar(mesh: &Mesh, opts: &IsoplanarOptions) -> Result<IsoplanarResult, GenerateError> {
    check_options(opts)?;
    let mesh = validate::surface(mesh)?;
    let frames = local_frames(&mesh);
    let used = used_vertices(&mesh);
    let sample: Vec<LocalFrame> = frames
        .iter()
        .zip(&used)
        .filter(|(_, &u)| u)
        .map(|(f, _)| *f)
        .collect();
    let curve = deposition_curve(&sample, opts);
    let star = fastest(&curve);
    let sweep = Sweep::new(&mesh, &frames, &used, opts, star.theta_deg.to_radians());
    let (curves, side_steps) = sweep.curves()?;
    let join_limit = 2.0 * side_steps.iter().copied().fold(sweep.w_flat, f64::max);
    let (waypoints, print_length, travel_length) = join_curves(&curves, join_limit);
    if waypoints.is_empty() {
        return Err(GenerateError::Parameter(
            "no drive plane crosses the surface: is it flat along the drive direction?".into(),
        ));
    }
    Ok(IsoplanarResult {
        toolpath: Toolpath {
            layers: vec![Layer {
                name: "0".into(),
                waypoints,
                surface: Some(mesh),
            }],
        },
        curve,
        theta_star_deg: star.theta_deg,
        side_steps,
        print_length,
        travel_length,
    })
}

/// Every setting a positive number, the θ step at most 90°.
fn check_options(opts: &IsoplanarOptions) -> Result<(), GenerateError> {
    for (name, v) in [
        ("nozzle width", opts.nozzle),
        ("layer height", opts.height),
        ("chord error", opts.chord_error),
        ("largest step", opts.max_step),
        ("θ step", opts.theta_step_deg),
        ("feed probe", opts.feed_probe),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(GenerateError::Parameter(format!(
                "the {name} must be a positive number"
            )));
        }
    }
    if opts.theta_step_deg > 90.0 {
        return Err(GenerateError::Parameter(
            "the θ step must be at most 90°".into(),
        ));
    }
    Ok(())
}

/// Per vertex: is it a corner of a triangle?
fn used_vertices(mesh: &Mesh) -> Vec<bool> {
    let mut used = vec![false; mesh.vertices.len()];
    mesh.triangles
        .iter()
        .flatten()
        .for_each(|&v| used[v as usize] = true);
    used
}

/// θ*: the first sample of the largest deposition rate (values within
/// 10⁻⁶ of each other count as tied).
fn fastest(curve: &[CurvePoint]) -> CurvePoint {
    let mut star = curve[0];
    for c in curve {
        if c.v_e > star.v_e * (1.0 + 1e-6) {
            star = *c;
        }
    }
    star
}

/// The drive planes of one angle θ over a surface: their normal `q`, the
/// horizontal direction `g` along them, and what each vertex says about
/// the side step and the forward step.
struct Sweep<'a> {
    mesh: &'a Mesh,
    frames: &'a [LocalFrame],
    opts: &'a IsoplanarOptions,
    q: DVec3,
    g: DVec3,
    /// Per vertex: w_eff(θ), plane offset per mm of side step, convex
    /// curvature along the feed direction.
    per_vertex: Vec<[f64; 3]>,
    /// The range of `q · x` over the used vertices.
    c_range: (f64, f64),
    /// The effective width on a flat layer.
    w_flat: f64,
    /// The smallest plane offset taken (a twentieth of `w_flat`).
    min_offset: f64,
    /// The first plane's offset from the extreme, twice over.
    first: f64,
}

impl<'a> Sweep<'a> {
    fn new(
        mesh: &'a Mesh,
        frames: &'a [LocalFrame],
        used: &[bool],
        opts: &'a IsoplanarOptions,
        theta: f64,
    ) -> Self {
        let q = drive_normal(theta);
        let g = DVec3::new(theta.cos(), -theta.sin(), 0.0);
        let rates = vertex_rates(frames, opts, theta);
        let per_vertex: Vec<[f64; 3]> = frames
            .iter()
            .zip(&rates)
            .map(|(fr, r)| {
                let qn = q.dot(fr.normal);
                let qt = (1.0 - qn * qn).max(0.0).sqrt();
                [r[0], qt, fr.convex_curvature(feed_dir(fr, q))]
            })
            .collect();
        let cs: Vec<f64> = mesh
            .vertices
            .iter()
            .zip(used)
            .filter(|(_, &u)| u)
            .map(|(v, _)| q.dot(DVec3::from(v.map(f64::from))))
            .collect();
        let c_min = cs.iter().copied().fold(f64::INFINITY, f64::min);
        let c_max = cs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let w_flat = effective_width(opts.nozzle, opts.height, 0.0);
        let min_offset = 0.05 * w_flat;
        let first = per_vertex
            .iter()
            .zip(used)
            .filter(|(_, &u)| u)
            .map(|(v, _)| v[0] * v[1])
            .fold(f64::INFINITY, f64::min)
            .max(min_offset);
        Sweep {
            mesh,
            frames,
            opts,
            q,
            g,
            per_vertex,
            c_range: (c_min, c_max),
            w_flat,
            min_offset,
            first,
        }
    }

    /// Per-vertex value `k` interpolated at a section point.
    fn at_point(&self, p: &SectionPoint, k: usize) -> f64 {
        let (a, b) = (
            self.per_vertex[p.edge.0 as usize][k],
            self.per_vertex[p.edge.1 as usize][k],
        );
        a + p.t * (b - a)
    }

    /// The vertex normals interpolated at a section point.
    fn normal_at(&self, p: &SectionPoint) -> DVec3 {
        unit(lerp(
            self.frames[p.edge.0 as usize].normal,
            self.frames[p.edge.1 as usize].normal,
            p.t,
        ))
    }

    /// Every drive plane's curve from the extreme of the surface, the
    /// first half a side step in, each next one the smallest effective
    /// width along the current curve further (Eq. 14); and the side steps
    /// after the first.
    fn curves(&self) -> Result<(Vec<Vec<Piece>>, Vec<f64>), GenerateError> {
        let (c_min, c_max) = self.c_range;
        let mut c = c_min + 0.5 * self.first;
        let mut curves: Vec<Vec<Piece>> = Vec::new();
        let mut side_steps = Vec::new();
        let mut last_offset = self.first;
        while c < c_max {
            if curves.len() > 1_000_000 {
                return Err(GenerateError::Parameter(
                    "more than a million drive planes: use a wider nozzle".into(),
                ));
            }
            let Some((pieces, width, offset)) = self.curve(c, curves.len() % 2 == 1) else {
                c += last_offset;
                continue;
            };
            curves.push(pieces);
            let step = offset.max(self.min_offset);
            if curves.len() > 1 {
                side_steps.push(width);
            }
            last_offset = step;
            c += step;
        }
        Ok((curves, side_steps))
    }

    /// The plane `q · x = c`'s section, its pieces ordered along `g` (or
    /// against it, `reverse`) and sampled; with the smallest effective
    /// width along it and that width as a plane offset. `None` where the
    /// plane misses the surface.
    fn curve(&self, c: f64, reverse: bool) -> Option<(Vec<Piece>, f64, f64)> {
        let mut polys = section(self.mesh, self.q, c);
        if polys.is_empty() {
            return None;
        }
        // Eq. 14: the smallest effective width along this curve, as a plane offset.
        let mut width = f64::INFINITY;
        let mut offset = f64::INFINITY;
        for p in polys.iter().flat_map(|p| &p.points) {
            let w = self.at_point(p, 0);
            width = width.min(w);
            offset = offset.min(w * self.at_point(p, 1));
        }
        // Orient each piece along g, order pieces along g; zig-zag.
        let g = self.g;
        for p in &mut polys {
            let (a, b) = (p.points[0].pos, p.points[p.points.len() - 1].pos);
            if !p.closed && g.dot(a) > g.dot(b) {
                p.points.reverse();
            }
        }
        polys.sort_by(|a, b| g.dot(a.points[0].pos).total_cmp(&g.dot(b.points[0].pos)));
        if reverse {
            polys.reverse();
            for p in &mut polys {
                p.points.reverse();
            }
        }
        let pieces = polys
            .iter()
            .map(|p| {
                let mut pts: Vec<SectionPoint> = p.points.clone();
                if p.closed {
                    pts.push(pts[0]);
                }
                sample_piece(&pts, self.opts, &|sp| self.at_point(sp, 2), &|sp| {
                    self.normal_at(sp)
                })
            })
            .collect();
        Some((pieces, width, offset))
    }
}

/// Every curve's samples in order as one layer's waypoints, with the
/// printing length (along the curves, and joins up to `join_limit`) and
/// the travel (longer joins).
fn join_curves(curves: &[Vec<Piece>], join_limit: f64) -> (Vec<Waypoint>, f64, f64) {
    let mut waypoints = Vec::new();
    let (mut print, mut travel) = (0.0, 0.0);
    let mut prev: Option<DVec3> = None;
    for (pos, nrm) in curves.iter().flatten() {
        for (k, (p, n)) in pos.iter().zip(nrm).enumerate() {
            if let Some(a) = prev {
                let d = a.distance(*p);
                if k == 0 && d > join_limit {
                    travel += d;
                } else {
                    print += d;
                }
            }
            prev = Some(*p);
            waypoints.push(Waypoint {
                pos: p.as_vec3().to_array(),
                dir: n.as_vec3().to_array(),
            });
        }
    }
    (waypoints, print, travel)
}

/// Sample one section piece (`pts`, in order) by the chord-error forward
/// step; returns positions and normals.
fn sample_piece(
    pts: &[SectionPoint],
    opts: &IsoplanarOptions,
    kappa: &dyn Fn(&SectionPoint) -> f64,
    normal: &dyn Fn(&SectionPoint) -> DVec3,
) -> Piece {
    // Arc length at each point.
    let mut s = vec![0.0];
    for w in pts.windows(2) {
        s.push(s[s.len() - 1] + w[0].pos.distance(w[1].pos));
    }
    let total = s[s.len() - 1];
    // Segment index, position and normal at arc length x.
    let eval = |x: f64| -> (usize, DVec3, DVec3) {
        let j = s
            .partition_point(|&v| v <= x)
            .clamp(1, pts.len().max(2) - 1);
        if pts.len() == 1 {
            return (0, pts[0].pos, normal(&pts[0]));
        }
        let (a, b) = (&pts[j - 1], &pts[j]);
        let len = s[j] - s[j - 1];
        let t = if len > 0.0 {
            ((x - s[j - 1]) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (
            j,
            lerp(a.pos, b.pos, t),
            unit(lerp(normal(a), normal(b), t)),
        )
    };
    let d = opts.chord_error;
    let (_, p0, n0) = eval(0.0);
    let mut pos = vec![p0];
    let mut nrm = vec![n0];
    let mut x = 0.0;
    while x < total - 1e-9 {
        let (j0, _, _) = eval(x);
        let k0 = {
            let (a, b) = (&pts[j0 - 1], &pts[j0.min(pts.len() - 1)]);
            let t = if s[j0] > s[j0 - 1] {
                (x - s[j0 - 1]) / (s[j0] - s[j0 - 1])
            } else {
                0.0
            };
            kappa(a) + t.clamp(0.0, 1.0) * (kappa(b) - kappa(a))
        }
        .abs();
        // Eq. 12 (a circle of radius r_f has sagitta δ over this chord;
        // on a circle smaller than δ every chord is within δ).
        let mut step = if k0 <= 1e-12 {
            opts.max_step
        } else if d < 1.0 / k0 {
            (8.0 * d / k0 - 4.0 * d * d).sqrt()
        } else {
            2.0 / k0
        }
        .min(opts.max_step);
        let start = *pos.last().expect("non-empty");
        loop {
            let xe = (x + step).min(total);
            let (je, pe, ne) = eval(xe);
            // Section points strictly between start and end must be within δ of the chord.
            let ok = (j0..je).all(|i| {
                s[i] <= x || s[i] >= xe || point_segment_distance(pts[i].pos, start, pe) <= d
            });
            if ok || step < 1e-6 {
                x = xe;
                pos.push(pe);
                nrm.push(ne);
                break;
            }
            step *= 0.7;
        }
    }
    (pos, nrm)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forward_steps_follow_eq_12_on_a_circle() {
        let r = 10.0;
        let n = 2000;
        let pts: Vec<SectionPoint> = (0..=n)
            .map(|i| {
                let a = 0.5 * PI * i as f64 / n as f64;
                SectionPoint {
                    pos: DVec3::new(r * a.sin(), 0.0, r * a.cos()),
                    edge: (0, 1),
                    t: 0.0,
                }
            })
            .collect();
        let opts = IsoplanarOptions::default();
        let (pos, nrm) = sample_piece(&pts, &opts, &|_| 1.0 / r, &|p| p.pos / r);
        let d = opts.chord_error;
        let lf = (8.0 * d * r - 4.0 * d * d).sqrt();
        // 15.7 mm of arc in steps of ~2 mm
        assert_eq!(
            pos.len(),
            (0.5 * PI * r / lf).ceil() as usize + 1,
            "{}",
            pos.len()
        );
        for w in pos.windows(2).take(pos.len() - 2) {
            let chord = w[0].distance(w[1]);
            assert!((chord - lf).abs() < 1e-2, "{chord} vs {lf}");
            let mid = lerp(w[0], w[1], 0.5);
            let sagitta = r - mid.length();
            assert!(sagitta <= d + 1e-6 && sagitta > 0.9 * d, "{sagitta}");
        }
        assert!(nrm
            .iter()
            .zip(&pos)
            .all(|(n, p)| (n.dot(*p) / r - 1.0).abs() < 1e-6));
    }

    #[test]
    fn flat_width_is_a_quarter_pi_of_the_nozzle() {
        assert!((effective_width(0.4, 0.2, 0.0) - PI * 0.1).abs() < 1e-15);
        assert!(effective_width(0.4, 0.2, 0.1) > effective_width(0.4, 0.2, 0.0));
        assert!(effective_width(0.4, 0.2, -0.1) < effective_width(0.4, 0.2, 0.0));
    }
}
