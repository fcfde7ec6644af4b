//! The printed-so-far scene: the platform and every layer surface as one
//! soup of stamped triangles under one BVH, plus the head. A triangle with
//! stamp `s` exists for queries whose cutoff is greater than `s`; the
//! platform has stamp 0 and layer surface `k`'s triangles take the global
//! index + 1 of the nearest waypoint of layer `k` (DESIGN.md).

pub mod beads;
pub mod bvh;
pub mod gpu_types;
pub mod head;
pub mod head_cache;
pub mod hull_plane;
mod nearest;
pub mod slab;
mod stamp;

pub use beads::BeadSettings;
pub use gpu_types::{GpuHeadParams, GpuNode, GpuPartNode, GpuQuery, GpuTriangle};
pub use head::{Head, HeadConfig};
pub use head_cache::CacheOutcome;
pub use stamp::{cutoff, stamp_of};

use crate::geometry::{Aabb, Mesh, Pose};
use crate::toolpath::Toolpath;
use rayon::prelude::*;

/// What can go wrong building a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A required mesh or the whole scene has no triangles.
    #[error("{0}")]
    Empty(String),
    /// The head mesh has holes, so "inside the head" is undefined.
    #[error("the head mesh is not closed ({0} open edges): containment needs a watertight head; repair it (e.g. close holes in a mesh editor)")]
    HeadNotClosed(usize),
    /// The head mesh's triangles face inwards.
    #[error("the head mesh is inside out (negative volume): flip its triangle winding")]
    HeadInsideOut,
    /// More triangles than one BVH can index.
    #[error(
        "{0} triangles exceed the 134,217,728 one BVH can index: split the part into layer ranges"
    )]
    TooLarge(usize),
    /// A bug, not a user error.
    #[error("internal error: {0}")]
    Internal(String),
}

/// What the printed-so-far part is modelled from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PartModel {
    /// Each layer's surface where the toolpath gives one, the beads it
    /// deposits where it does not.
    #[default]
    Auto,
    /// Layer surfaces only: a layer without one adds no material.
    Surfaces,
    /// The beads the toolpath deposits ([`beads`]), surfaces ignored.
    Beads,
}

/// What a scene's part was made of, as reports name it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartSource {
    /// Every layer's surface.
    Surfaces,
    /// The deposited beads of every layer.
    Beads,
    /// Surfaces where given, beads elsewhere.
    SurfacesAndBeads,
    /// Nothing but the platform: no layer gave a surface or a bead.
    PlatformOnly,
}

impl PartSource {
    /// The name reports use (`surfaces`, `beads`, `surfaces+beads`,
    /// `platform only`).
    pub fn name(self) -> &'static str {
        match self {
            PartSource::Surfaces => "surfaces",
            PartSource::Beads => "beads",
            PartSource::SurfacesAndBeads => "surfaces+beads",
            PartSource::PlatformOnly => "platform only",
        }
    }

    /// The warning a run gives when only the platform was checked.
    pub fn warning(self) -> Option<&'static str> {
        (self == PartSource::PlatformOnly).then_some(
            "no part was modelled (no layer surface and no printing segment): only the platform was checked",
        )
    }
}

/// Scene construction settings.
#[derive(Clone, Copy, Debug, Default)]
pub struct SceneConfig {
    /// Head data settings (tip clearance, grid resolution).
    pub head: HeadConfig,
    /// Split part and platform triangles longer than this (mm); default:
    /// an eighth of the head's size, so a triangle never dwarfs the head.
    pub max_edge: Option<f32>,
    /// Keep the head's derived data between runs in the user's cache
    /// folder ([`head_cache::cache_dir`]); off by default, on in the CLI.
    pub head_cache: bool,
    /// What the part is modelled from.
    pub part: PartModel,
    /// How beads are made, where the part is modelled from them.
    pub beads: BeadSettings,
    /// Waypoints farther than this from the origin (mm) are out of the
    /// machine's reach in every orientation
    /// ([`crate::kinematics::Machine::reach`]): never visited, they do not
    /// size the contact tolerance. `None`: every waypoint does.
    pub reach: Option<f32>,
}

/// A group of part triangles that stay together for the parry backend: the
/// platform, or one layer surface. `stamps[i]` belongs to triangle `i`.
#[derive(Clone, Debug)]
pub struct PartGroup {
    /// The group's (subdivided) mesh.
    pub mesh: Mesh,
    /// Stamp per triangle.
    pub stamps: Vec<u32>,
    /// Layer index, `None` for the platform.
    pub layer: Option<usize>,
    /// What the triangles are.
    pub kind: GroupKind,
}

/// What a [`PartGroup`]'s triangles are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GroupKind {
    /// The platform's.
    Platform,
    /// A layer surface's.
    Surface,
    /// Bead solids ([`beads`]), twelve triangles a bead.
    Beads,
}

impl PartGroup {
    /// Is triangle `i` a wall of a solid (a bead's side or end), whose
    /// normal says nothing of which way the material lies thin?
    pub fn is_wall(&self, i: usize) -> bool {
        self.kind == GroupKind::Beads && beads::is_wall(i)
    }

    /// Keep only the triangles whose stamp `keep` accepts (for beads,
    /// whole beads: a bead's twelve triangles share its stamp, so
    /// [`PartGroup::is_wall`] still reads them right).
    pub fn retain_stamps(&mut self, keep: impl Fn(u32) -> bool) {
        let (triangles, stamps) = self
            .mesh
            .triangles
            .iter()
            .zip(&self.stamps)
            .filter(|(_, &s)| keep(s))
            .unzip();
        (self.mesh.triangles, self.stamps) = (triangles, stamps);
    }

    /// Smallest and largest stamp in the group.
    pub fn stamp_range(&self) -> (u32, u32) {
        let lo = self.stamps.iter().copied().min().unwrap_or(u32::MAX);
        let hi = self.stamps.iter().copied().max().unwrap_or(0);
        (lo, hi)
    }
}

/// Everything the evaluators need, built once per job.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Part BVH (platform + layers) as bounding spheres, GPU-ready.
    pub part_nodes: Vec<GpuPartNode>,
    /// Each part node's slab, decoded for the CPU's readers
    /// ([`slab::Slab`]; indexed as `part_nodes`).
    pub part_slabs: Vec<slab::Slab>,
    /// Part triangles in BVH leaf order.
    pub part_tris: Vec<GpuTriangle>,
    /// The head.
    pub head: Head,
    /// Contact tolerance (mm), scaled to the scene.
    pub tol: f32,
    /// The same triangles grouped by source (platform first, then layers).
    pub groups: Vec<PartGroup>,
    /// Every waypoint's pose (minimal rotation from +z) and cutoff, in print order.
    pub waypoint_queries: Vec<Query>,
    /// Layer index of each waypoint.
    pub waypoint_layers: Vec<u32>,
    /// Where the head's data came from.
    pub head_cache: CacheOutcome,
    /// What the part was made of.
    pub part: PartSource,
}

/// A collision query: the head at `pose`, against everything with
/// `stamp < cutoff`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Query {
    /// The head pose.
    pub pose: Pose,
    /// Cutoff stamp.
    pub cutoff: u32,
    /// Safety margin (mm): the query collides when any existing triangle
    /// comes closer than this to the (clearance-lifted) head; 0 = touch.
    pub margin: f32,
    /// Growth of the margin with distance from the nozzle tip (mm per mm,
    /// ≥ 0): a triangle must keep `margin + slope · ρ` from the head, `ρ`
    /// its farthest corner's distance from the tip. Motion proofs use it:
    /// a head point `r` from the tip moves about `δ + ω r` in a move, so
    /// the clearance a pose needs grows with `r` (`prove`). 0 for
    /// a plain safety margin.
    pub slope: f32,
}

impl Query {
    /// The GPU form; the CPU backend evaluates this same form.
    pub fn to_gpu(&self) -> GpuQuery {
        let c = &self.pose.cols;
        let t = &self.pose.tip;
        GpuQuery {
            rows: [
                [c[0][0], c[0][1], c[0][2], t[0]],
                [c[1][0], c[1][1], c[1][2], t[1]],
                [c[2][0], c[2][1], c[2][2], t[2]],
            ],
            cutoff: self.cutoff,
            margin: self.margin,
            slope: self.slope,
            _pad: 0,
        }
    }
}

/// The platform and the part as stamped groups, in layer order: each
/// layer's surface or its beads, as `model` and the toolpath have them
/// ([`part_sources`]), and what the part was made of.
fn part_groups(
    toolpath: &Toolpath,
    platform: Mesh,
    max_edge: f32,
    cfg: &SceneConfig,
    deposited: Option<Vec<PartGroup>>,
) -> (Vec<PartGroup>, PartSource) {
    let platform = platform.subdivided(max_edge);
    let use_surface = part_sources(toolpath, cfg.part);
    let (surfaces, beads) = rayon::join(
        || surface_groups(toolpath, &use_surface, max_edge),
        || match deposited {
            Some(groups) => groups
                .into_iter()
                .filter(|g| g.layer.is_some_and(|k| !use_surface[k]))
                .collect(),
            None => bead_groups(toolpath, &use_surface, &platform, cfg),
        },
    );
    let source = match (surfaces.is_empty(), beads.is_empty()) {
        (false, true) => PartSource::Surfaces,
        (true, false) => PartSource::Beads,
        (false, false) => PartSource::SurfacesAndBeads,
        (true, true) => PartSource::PlatformOnly,
    };
    let mut layers: Vec<PartGroup> = surfaces.into_iter().chain(beads).collect();
    layers.sort_by_key(|g| g.layer);
    let mut groups = Vec::with_capacity(layers.len() + 1);
    groups.push(PartGroup {
        stamps: vec![0; platform.triangles.len()],
        mesh: platform,
        layer: None,
        kind: GroupKind::Platform,
    });
    groups.extend(layers);
    (groups, source)
}

/// The scene's contact tolerance: `2·10⁻⁶ ×` the largest coordinate of
/// the head, the platform, the surfaces and the waypoints within `reach`
/// (one far out of reach would blunt every test), at least 10⁻⁶ mm.
fn tolerance(toolpath: &Toolpath, platform: &Mesh, head_extent: f32, reach: Option<f32>) -> f32 {
    let max_abs = |m: &Mesh| {
        m.vertices
            .iter()
            .flatten()
            .fold(0.0f32, |a, c| a.max(c.abs()))
    };
    let mut scale = head_extent.max(max_abs(platform));
    for l in &toolpath.layers {
        if let Some(s) = &l.surface {
            scale = scale.max(max_abs(s));
        }
        for w in &l.waypoints {
            let [x, y, z] = w.pos;
            if reach.is_none_or(|r| x.hypot(y).hypot(z) <= r) {
                scale = scale.max(w.pos.iter().fold(0.0f32, |a, c| a.max(c.abs())));
            }
        }
    }
    (2e-6 * scale).max(1e-6)
}

/// Every group's triangles, numbered in group order (their `source`),
/// written side by side straight into one buffer (a parallel collect of
/// unknown length went through a list of vectors and copied each again).
fn triangle_soup(groups: &[PartGroup]) -> Vec<GpuTriangle> {
    let mut soup = vec![GpuTriangle::default(); groups.iter().map(|g| g.stamps.len()).sum()];
    let mut rest = soup.as_mut_slice();
    let mut parts = Vec::with_capacity(groups.len());
    let mut first = 0;
    for g in groups {
        let (part, tail) = std::mem::take(&mut rest).split_at_mut(g.stamps.len());
        parts.push((part, first));
        first += g.stamps.len();
        rest = tail;
    }
    parts
        .into_par_iter()
        .zip(groups)
        .for_each(|((part, first), g)| {
            for (i, t) in part.iter_mut().enumerate() {
                let [v0, v1, v2] = g.mesh.corners(i);
                *t = GpuTriangle {
                    v0,
                    stamp: g.stamps[i],
                    v1,
                    layer: g.layer.map_or(u32::MAX, |l| l as u32),
                    v2,
                    source: (first + i) as u32,
                };
            }
        });
    soup
}

/// Per layer: is its surface the part's material there (`true`), or its
/// beads? Surfaces win wherever the toolpath gives one, unless `model`
/// asks for beads; with [`PartModel::Surfaces`] no layer is beads.
fn part_sources(toolpath: &Toolpath, model: PartModel) -> Vec<bool> {
    toolpath
        .layers
        .iter()
        .map(|l| {
            let has = l.surface.as_ref().is_some_and(|s| !s.triangles.is_empty());
            match model {
                PartModel::Auto => has,
                PartModel::Surfaces => true,
                PartModel::Beads => false,
            }
        })
        .collect()
}

/// The surfaces of the layers `use_surface` picks: welded, degenerate
/// triangles dropped, subdivided to `max_edge`, each triangle stamped by
/// its nearest waypoint ([`stamp`]); layers in parallel, in layer order.
fn surface_groups(toolpath: &Toolpath, use_surface: &[bool], max_edge: f32) -> Vec<PartGroup> {
    let offsets = toolpath.layer_offsets();
    toolpath
        .layers
        .par_iter()
        .enumerate()
        .filter_map(|(k, layer)| {
            if !use_surface[k] {
                return None;
            }
            let surface = layer.surface.as_ref()?;
            let (surface, _) = surface.welded().without_degenerate();
            if surface.triangles.is_empty() || layer.waypoints.is_empty() {
                return None;
            }
            let mesh = surface.subdivided(max_edge);
            let stamps = stamp::nearest_waypoint_stamps(&mesh, &layer.waypoints, offsets[k]);
            Some(PartGroup {
                mesh,
                stamps,
                layer: Some(k),
                kind: GroupKind::Surface,
            })
        })
        .collect()
}

/// The beads of the layers `use_surface` leaves to them ([`beads`]),
/// deposited along the whole toolpath (a bead rests on what is below it,
/// whatever models that).
fn bead_groups(
    toolpath: &Toolpath,
    use_surface: &[bool],
    platform: &Mesh,
    cfg: &SceneConfig,
) -> Vec<PartGroup> {
    if use_surface.iter().all(|&s| s) {
        return Vec::new();
    }
    let held = beads::HeldPath::of(toolpath);
    beads::deposit(held.path(), platform, &cfg.beads)
        .groups
        .into_iter()
        .filter(|g| g.layer.is_some_and(|k| !use_surface[k]))
        .collect()
}

impl Scene {
    /// Build the scene from a toolpath (layer surfaces optional), the head
    /// (closed, its own frame) and the platform (part frame).
    pub fn build(
        toolpath: &Toolpath,
        head_mesh: &Mesh,
        platform: &Mesh,
        cfg: &SceneConfig,
    ) -> Result<Scene, SceneError> {
        Scene::build_deposited(toolpath, head_mesh, platform, cfg, None)
    }

    /// [`Scene::build`] with the beads of the toolpath already laid
    /// (`deposited`: one group per layer, as [`beads::stacked_layers`]
    /// lays them while it finds the layers), where the part is modelled
    /// from beads.
    pub fn build_deposited(
        toolpath: &Toolpath,
        head_mesh: &Mesh,
        platform: &Mesh,
        cfg: &SceneConfig,
        deposited: Option<Vec<PartGroup>>,
    ) -> Result<Scene, SceneError> {
        let (platform, _) = platform.welded().without_degenerate();
        if platform.triangles.is_empty() {
            return Err(SceneError::Empty(
                "the platform mesh has no triangles".into(),
            ));
        }
        let head_extent = Aabb::from_points(&head_mesh.vertices).extent();
        let max_edge = cfg.max_edge.unwrap_or(head_extent / 8.0).max(1e-3);

        let tol = tolerance(toolpath, &platform, head_extent, cfg.reach);

        // The head (its distance grids) and the part's layers do not
        // depend on each other: built side by side.
        let cache = cfg.head_cache.then(head_cache::cache_dir).flatten();
        let (head, (groups, part_source)) = rayon::join(
            || head_cache::load_or_build(head_mesh, &cfg.head, tol, cache.as_deref()),
            || part_groups(toolpath, platform, max_edge, cfg, deposited),
        );
        let (head, head_cache) = head?;

        let soup = triangle_soup(&groups);
        let part = bvh::build(&soup, 4, head_extent * bvh::LAYER_LIFT_PER_HEAD)?;
        drop(soup);
        // (The soup numbers the groups' triangles in group order.)
        let walls: Vec<bool> = if groups.iter().any(|g| g.kind == GroupKind::Beads) {
            groups
                .iter()
                .flat_map(|g| (0..g.stamps.len()).map(|i| g.is_wall(i)))
                .collect()
        } else {
            Vec::new()
        };
        let mut part_nodes = bvh::sphere_nodes(&part);
        slab::add_slabs(&part, &mut part_nodes, &walls);
        let part_slabs = part_nodes.par_iter().map(slab::Slab::of).collect();
        let part_tris = part.triangles;

        let waypoint_queries = toolpath
            .iter()
            .enumerate()
            .map(|(g, (_, w))| Query {
                pose: Pose::from_axis(w.pos, w.dir),
                cutoff: cutoff(g),
                margin: 0.0,
                slope: 0.0,
            })
            .collect();
        let waypoint_layers = toolpath.iter().map(|(k, _)| k as u32).collect();
        Ok(Scene {
            part_nodes,
            part_slabs,
            part_tris,
            head,
            tol,
            groups,
            waypoint_queries,
            waypoint_layers,
            head_cache,
            part: part_source,
        })
    }

    /// Number of part + platform triangles.
    pub fn triangle_count(&self) -> usize {
        self.part_tris.len()
    }

    /// Free the part's BVH (its nodes, their slabs and its triangles in leaf order),
    /// which only the evaluators read, once every backend on the scene is
    /// gone (the borrow checker sees to it): what is left draws the part
    /// and reports on it (`groups`, the head). `plan` releases it before
    /// its report, whose program scene and pictures would otherwise come
    /// on top of it (dome_cut `--part beads --tilt 50`: 1.04 GiB, now the
    /// load's 0.88). A backend built on the scene afterwards refuses it.
    pub fn release_bvh(&mut self) {
        self.part_nodes = Vec::new();
        self.part_slabs = Vec::new();
        self.part_tris = Vec::new();
    }

    /// Whether [`Scene::release_bvh`] has freed the part's BVH (a built
    /// scene always has a root).
    pub fn bvh_released(&self) -> bool {
        self.part_nodes.is_empty()
    }

    /// Replace every part triangle's stamp `s > 0` by `stamp(s)` (the
    /// platform keeps 0) and recompute the BVH's minimum stamps, in place:
    /// how a simulator makes material appear in the order a program prints
    /// it rather than the toolpath's.
    pub fn restamp(&mut self, stamp: impl Fn(u32) -> u32 + Sync) {
        let map = |s: u32| if s == 0 { 0 } else { stamp(s) };
        self.part_tris
            .par_iter_mut()
            .for_each(|t| t.stamp = map(t.stamp));
        for g in &mut self.groups {
            g.stamps.par_iter_mut().for_each(|s| *s = map(*s));
        }
        bvh::refresh_min_stamps(&mut self.part_nodes, &self.part_tris);
    }
}
