//! The report's pictures: the machine at the first lines of each problem
//! kind, and an overview of the part's toolpath coloured by what each
//! line does, rendered offscreen ([`super::render`]).
//!
//! A collision's picture shows the head at the pose along its line where
//! it meets the most material (the line sampled as the controller moves
//! it), the material that exists during that line, and the triangles of
//! both within the margin of each other in [`HIGHLIGHT`] (the part's) and
//! [`HEAD_HIGHLIGHT`] (the head's), drawn over everything so nothing
//! hides them. The camera looks at them across the nozzle, from outside
//! the part, with the nozzle pointing down the picture as on the machine.

use super::playback::{LineClass, Playback};
use super::program_glb::{class_color, ProgramScene};
use super::render::{png, Camera, DrawList, Renderer};
use crate::geometry::aabb::point_box_distance;
use crate::geometry::tri_tri_distance::tri_tri_closer_than;
use crate::geometry::{Aabb, Pose, V3};
use crate::io::gcode_read::axes_of;
use crate::plan::head_reach;
use crate::simulate::{machines, ProblemKind};
use glam::Vec3;
use rayon::prelude::*;

/// Lines pictured of each problem kind but collisions.
pub const PER_KIND: usize = 3;

/// Colliding lines pictured.
pub const COLLISIONS_PICTURED: usize = 8;

/// A problem picture's size (pixels).
pub const SIZE: (u32, u32) = (640, 480);

/// The overview's size (pixels).
pub const OVERVIEW_SIZE: (u32, u32) = (896, 640);

/// The colour of part triangles within the margin of the head (unlit).
pub const HIGHLIGHT: [u8; 4] = [255, 0, 255, 0];

/// The colour of head triangles within the margin of the part (lit: the
/// head's triangles can be large, and must not hide what they meet).
pub const HEAD_HIGHLIGHT: [u8; 4] = [0, 200, 230, 255];

/// The part's colour (lit).
const PART: [u8; 4] = [214, 200, 176, 255];

/// The head's colour (lit).
const HEAD: [u8; 4] = [90, 90, 105, 255];

/// The platform's colour (lit).
const PLATFORM: [u8; 4] = [165, 168, 180, 255];

/// Poses sampled along a colliding line.
const SAMPLES: usize = 17;

/// How far around a picture's subject material is drawn, in view radii.
const SHOWN: f32 = 1.6;

/// Widest band searched for what a colliding line meets (mm).
const MAX_BAND: f32 = 8.0;

/// Radius of the scene around a picture's subject drawn (mm), at least.
const VIEW_RADIUS: f32 = 14.0;

/// One problem, pictured.
#[derive(Clone, Debug)]
pub struct Picture {
    /// G-code line.
    pub line: usize,
    /// What.
    pub kind: ProblemKind,
    /// The problem's measured value.
    pub value: f64,
    /// Program time at the line's end (s): where `program.glb` shows it.
    pub time_s: f64,
    /// Part triangles highlighted.
    pub highlighted: usize,
    /// The picture (PNG).
    pub png: Vec<u8>,
}

/// The report's pictures.
#[derive(Clone, Debug, Default)]
pub struct Pictures {
    /// The overview (PNG).
    pub overview: Option<Vec<u8>>,
    /// The first [`PER_KIND`] problems of each kind ([`COLLISIONS_PICTURED`]
    /// collisions), pictured.
    pub problems: Vec<Picture>,
    /// Why there are none, when there is no adapter to render with.
    pub missing: Option<String>,
    /// The adapter they were rendered on.
    pub adapter: String,
}

/// The pictures of `s`, checked at `margin`; without a GPU adapter (or
/// when it fails), none and why.
pub fn pictures(s: &ProgramScene, margin: f32) -> Pictures {
    let drawn = Renderer::open().and_then(|r| {
        let problems = problem_pictures(&r, s, margin)?;
        let (list, camera) = overview(s);
        let (w, h) = OVERVIEW_SIZE;
        let overview = r.draw(&list, &camera, w, h)?;
        // Drawn one after another, encoded on every core.
        let (overview, problems) = rayon::join(
            || png(&overview, w, h),
            || {
                problems
                    .into_par_iter()
                    .map(|(p, rgba)| Picture {
                        png: png(&rgba, SIZE.0, SIZE.1),
                        ..p
                    })
                    .collect()
            },
        );
        Ok((r.adapter().to_string(), overview, problems))
    });
    match drawn {
        Ok((adapter, overview, problems)) => Pictures {
            overview: Some(overview),
            problems,
            missing: None,
            adapter,
        },
        Err(why) => Pictures {
            missing: Some(why),
            ..Default::default()
        },
    }
}

/// The first problems of each kind, pictured: each with its pixels
/// (RGBA), its PNG left to encode.
fn problem_pictures(
    r: &Renderer,
    s: &ProgramScene,
    margin: f32,
) -> Result<Vec<(Picture, Vec<u8>)>, String> {
    let p = s.playback;
    let part = bounds(
        s.scene
            .groups
            .iter()
            .filter(|g| g.layer.is_some())
            .flat_map(|g| g.mesh.vertices.iter()),
    );
    let part_center = (part != Aabb::EMPTY).then(|| Vec3::from(part.center()));
    let mut out = Vec::new();
    for kind in ProblemKind::ALL {
        let shown = if kind == ProblemKind::Collision {
            COLLISIONS_PICTURED
        } else {
            PER_KIND
        };
        for q in p.problems.iter().filter(|q| q.kind == kind).take(shown) {
            let Some(i) = p.index_of_line(q.line) else {
                continue;
            };
            let (list, camera, highlighted) = problem_view(s, i, kind, margin, part_center);
            let rgba = r.draw(&list, &camera, SIZE.0, SIZE.1)?;
            let picture = Picture {
                line: q.line,
                kind,
                value: q.value,
                time_s: p.ends[i],
                highlighted,
                png: Vec::new(),
            };
            out.push((picture, rgba));
        }
    }
    Ok(out)
}

/// The material that exists while a move runs, near it.
struct Material {
    /// Triangles (corners, part frame).
    tris: Vec<[V3; 3]>,
    /// Their bounds.
    boxes: Vec<Aabb>,
    /// Which are the platform's.
    platform: Vec<bool>,
}

/// The triangles that exist while move `i` runs and reach within
/// `radius` of `center`.
fn material(s: &ProgramScene, i: usize, center: Vec3, radius: f32) -> Material {
    let cutoff = s.playback.cutoffs[i];
    let found: Vec<([V3; 3], Aabb, bool)> = s
        .scene
        .groups
        .par_iter()
        .flat_map_iter(|g| {
            (0..g.mesh.triangles.len()).filter_map(move |t| {
                if (s.stamp)(g.stamps[t]) >= cutoff {
                    return None;
                }
                let tri = g.mesh.corners(t);
                let b = bounds(tri.iter());
                (point_box_distance(center.to_array(), b.min, b.max) <= radius).then_some((
                    tri,
                    b,
                    g.layer.is_none(),
                ))
            })
        })
        .collect();
    Material {
        tris: found.iter().map(|f| f.0).collect(),
        boxes: found.iter().map(|f| f.1).collect(),
        platform: found.iter().map(|f| f.2).collect(),
    }
}

/// What meets what at one pose: the indices (in `part`) of part
/// triangles within `margin` of the `head`'s, and the head's within
/// `margin` of the part's.
fn contacts(head: &[[V3; 3]], part: &Material, margin: f32) -> (Vec<usize>, Vec<usize>) {
    let whole = bounds(head.iter().flatten());
    let apart = |a: Aabb, b: Aabb| {
        (0..3).any(|k| a.min[k] > b.max[k] + margin || a.max[k] < b.min[k] - margin)
    };
    let head_boxes: Vec<Aabb> = head.iter().map(|t| bounds(t.iter())).collect();
    let per_part: Vec<(usize, Vec<usize>)> = (0..part.tris.len())
        .into_par_iter()
        .filter_map(|t| {
            let bt = part.boxes[t];
            if apart(bt, whole) {
                return None;
            }
            let [a, b, c] = part.tris[t];
            let hits: Vec<usize> = (0..head.len())
                .filter(|&h| !apart(bt, head_boxes[h]))
                .filter(|&h| {
                    let [p, q, r] = head[h];
                    tri_tri_closer_than(a, b, c, p, q, r, margin)
                })
                .collect();
            (!hits.is_empty()).then_some((t, hits))
        })
        .collect();
    let part_hits = per_part.iter().map(|(t, _)| *t).collect();
    let mut head_hits: Vec<usize> = per_part.into_iter().flat_map(|(_, h)| h).collect();
    head_hits.sort_unstable();
    head_hits.dedup();
    (part_hits, head_hits)
}

/// The box around points.
fn bounds<'a>(pts: impl Iterator<Item = &'a V3>) -> Aabb {
    pts.fold(Aabb::EMPTY, |b, p| b.grow(*p))
}

/// The head's triangles at `pose` (part frame).
fn head_at(s: &ProgramScene, pose: &Pose) -> Vec<[V3; 3]> {
    let m = &s.scene.head.mesh;
    (0..m.triangles.len())
        .map(|t| m.corners(t).map(|v| pose.to_part(v)))
        .collect()
}

/// The moment a picture shows: the head's pose, the part triangles
/// (indices in the material) and head triangles within the margin.
struct Moment {
    pose: Pose,
    hits: Vec<usize>,
    head_hits: Vec<usize>,
}

/// The picture of move `i`'s problem `kind`: what to draw, the camera,
/// and how many part triangles are highlighted.
fn problem_view(
    s: &ProgramScene,
    i: usize,
    kind: ProblemKind,
    margin: f32,
    part_center: Option<Vec3>,
) -> (DrawList, Camera, usize) {
    let mv = &s.playback.moves[i];
    let (joint, tcp) = machines(s.machine);
    let m = if mv.tcp { &tcp } else { &joint };
    let (from, to) = (axes_of(&mv.from), axes_of(&mv.to));
    // Whatever the head can reach along the line.
    let tip = |a| Vec3::from(m.tip(a).map(|x| x as f32));
    let (a, b) = (tip(&from), tip(&to));
    let reach = head_reach(s.scene) as f32;
    // What the head can meet along a colliding line; else what the
    // picture shows around the line's end.
    let part = if kind == ProblemKind::Collision {
        material(
            s,
            i,
            (a + b) / 2.0,
            reach + (b - a).length() / 2.0 + MAX_BAND,
        )
    } else {
        material(s, i, b, SHOWN * VIEW_RADIUS)
    };
    let moment = if kind == ProblemKind::Collision {
        meeting(s, &part, margin, |t| m.pose_along(&from, &to, t))
    } else {
        None
    };
    let moment = moment.unwrap_or_else(|| Moment {
        pose: m.pose_along(&from, &to, 1.0),
        hits: Vec::new(),
        head_hits: Vec::new(),
    });
    let hits = &moment.hits;
    let target = if hits.is_empty() {
        Vec3::from(moment.pose.tip)
    } else {
        hits.iter()
            .flat_map(|&t| part.tris[t].iter().map(|&v| Vec3::from(v)))
            .sum::<Vec3>()
            / (3 * hits.len()) as f32
    };
    let spread = hits
        .iter()
        .flat_map(|&t| part.tris[t].iter())
        .map(|&v| (Vec3::from(v) - target).length())
        .fold(0.0, f32::max);
    let radius = VIEW_RADIUS.max(spread + 4.0);
    let mut list = scene_at(s, &part, &moment, target, SHOWN * radius);
    // The line's own path, in its problem's colour.
    let color = class_color(LineClass::Problem(kind)).map(|c| (c * 255.0) as u8);
    let path: Vec<V3> = (0..=8)
        .map(|k| m.tip_along(&from, &to, k as f64 / 8.0).map(|x| x as f32))
        .collect();
    for w in path.windows(2) {
        list.line(w[0], w[1], [color[0], color[1], color[2], 0]);
    }
    let pose = &moment.pose;
    let axis = Vec3::from(pose.axis()).normalize();
    let camera = Camera::framing(
        target,
        radius,
        side_view(part_center, target, axis, pose),
        axis,
    );
    (list, camera, hits.len())
}

/// Where along a colliding line (`pose_at` its pose at a fraction) the
/// head meets the most of `part` within the margin. Between samples the
/// head may come closer than at any of them: then what lies within a
/// wider band is shown; `None` if nothing lies within [`MAX_BAND`].
fn meeting(
    s: &ProgramScene,
    part: &Material,
    margin: f32,
    pose_at: impl Fn(f64) -> Pose,
) -> Option<Moment> {
    let mut band = margin;
    while band <= MAX_BAND {
        let mut best: Option<Moment> = None;
        for k in 0..SAMPLES {
            let pose = pose_at(k as f64 / (SAMPLES - 1) as f64);
            let (hits, head_hits) = contacts(&head_at(s, &pose), part, band);
            if hits.len() > best.as_ref().map_or(0, |b| b.hits.len()) {
                best = Some(Moment {
                    pose,
                    hits,
                    head_hits,
                });
            }
        }
        if best.is_some() {
            return best;
        }
        band *= 2.0;
    }
    None
}

/// The material within `radius` of `target` and the head at the moment,
/// what meets highlighted.
fn scene_at(s: &ProgramScene, part: &Material, at: &Moment, target: Vec3, radius: f32) -> DrawList {
    let mut list = DrawList::default();
    let mut is_hit = vec![false; part.tris.len()];
    for &t in &at.hits {
        is_hit[t] = true;
    }
    for (t, tri) in part.tris.iter().enumerate() {
        if is_hit[t] {
            list.overlay_triangle(*tri, HIGHLIGHT);
        } else if tri
            .iter()
            .any(|&v| (Vec3::from(v) - target).length() < radius)
        {
            let color = if part.platform[t] { PLATFORM } else { PART };
            list.triangle(*tri, color);
        }
    }
    let head = head_at(s, &at.pose);
    let mut is_head_hit = vec![false; head.len()];
    for &h in &at.head_hits {
        is_head_hit[h] = true;
    }
    for (h, tri) in head.iter().enumerate() {
        let color = if is_head_hit[h] { HEAD_HIGHLIGHT } else { HEAD };
        list.triangle(*tri, color);
    }
    list
}

/// A direction to look from at `target`: across the nozzle `axis`, from
/// the side of the part `target` is on, a little from above.
fn side_view(part_center: Option<Vec3>, target: Vec3, axis: Vec3, pose: &Pose) -> Vec3 {
    let out = target - part_center.unwrap_or(target);
    let mut side = out - axis * out.dot(axis);
    if side.length() < 1e-3 {
        side = Vec3::from(pose.cols[0]);
    }
    side.normalize() * 30f32.to_radians().cos() + axis * 30f32.to_radians().sin()
}

/// The overview: the platform under the part and the tip's path through
/// every line, coloured by what the line does, problems as markers.
fn overview(s: &ProgramScene) -> (DrawList, Camera) {
    let p: &Playback = s.playback;
    let mut list = DrawList::default();
    let tips: Vec<V3> = p
        .moves
        .iter()
        .map(|mv| s.machine.tip(&axes_of(&mv.to)).map(|x| x as f32))
        .collect();
    for i in 1..tips.len() {
        let c = class_color(p.classes[i]).map(|c| (c * 255.0) as u8);
        list.line(tips[i - 1], tips[i], [c[0], c[1], c[2], 0]);
    }
    for q in p.problems {
        let Some(i) = p.index_of_line(q.line) else {
            continue;
        };
        let c = class_color(LineClass::Problem(q.kind)).map(|c| (c * 255.0) as u8);
        marker(&mut list, tips[i], 1.2, [c[0], c[1], c[2], 0]);
    }
    // Framed on what is printed: travels may rise far above the part.
    let printed = (0..tips.len())
        .filter(|&i| p.moves[i].extrudes())
        .map(|i| &tips[i]);
    let printed = bounds(printed);
    let (lo, hi) = if printed != Aabb::EMPTY {
        (Vec3::from(printed.min), Vec3::from(printed.max))
    } else {
        (Vec3::ZERO, Vec3::ONE)
    };
    let center = (lo + hi) / 2.0;
    let radius = ((hi - lo).length() / 2.0).max(5.0);
    for g in s.scene.groups.iter().filter(|g| g.layer.is_none()) {
        for t in 0..g.mesh.triangles.len() {
            let tri = g.mesh.corners(t);
            if tri
                .iter()
                .any(|&v| (Vec3::from(v) - center).length() < 1.6 * radius)
            {
                list.triangle(tri, PLATFORM);
            }
        }
    }
    let camera = Camera::framing(center, radius * 1.05, Vec3::new(1.0, -1.3, 0.9), Vec3::Z);
    (list, camera)
}

/// An octahedron of `radius` at `at`, drawn over everything.
fn marker(list: &mut DrawList, at: V3, radius: f32, c: [u8; 4]) {
    let v = |k: usize, sign: f32| {
        let mut p = at;
        p[k] += sign * radius;
        p
    };
    for sx in [1.0, -1.0] {
        for sy in [1.0, -1.0] {
            for sz in [1.0, -1.0] {
                list.overlay_triangle([v(0, sx), v(1, sy), v(2, sz)], c);
            }
        }
    }
}
