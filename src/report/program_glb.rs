//! `program.glb`: the program running, as a glTF 2.0 animation any viewer
//! plays. The machine's bodies move as its axes do (for a rotary table,
//! configuration III, the table tilts and turns the part under a head
//! that rises; other machines are shown in the part's frame with the head
//! moving around it), the part appears chunk by chunk as it is printed,
//! the toolpath is drawn coloured by what each line does, and every
//! problem is a marker at its line's tip, named after its G-code line.
//!
//! Node tree (Z up in millimetres, under a root that turns it to glTF's
//! Y up in metres): `X carriage` (−X) → `Y carriage` (−Y) → `cradle`
//! (tilt) → `table` (C) → platform, part chunks, toolpath, markers; and
//! `head` (+Z). Times are the program's ([`Playback`]); keys are
//! added inside a line where straight interpolation between its ends
//! would leave the line's path (large turns; tool-centre-point lines).
//!
//! Size is bounded: at most [`MAX_KEYS`](super::playback::MAX_KEYS) lines
//! kept as keys, at most [`MAX_CHUNKS`] part chunks (each within one
//! layer), about [`MAX_PART_TRIANGLES`] part triangles (a larger part is
//! simplified for the eye; the checks saw all of it) and [`MAX_MARKERS`]
//! markers of each problem kind.

use super::gltf::{quaternion, Builder, Interpolation};
use super::playback::{LineClass, Playback};
use crate::geometry::{Mesh, V3};
use crate::io::gcode_read::axes_of;
use crate::kinematics::{
    head_rotation, linear_axes, Axes, BodyMotion, Configuration, Machine, Rotary,
};
use crate::scene::Scene;
use crate::simulate::ProblemKind;
use rayon::prelude::*;
use serde_json::json;

/// Most part chunks (nodes that appear as the part is printed).
pub const MAX_CHUNKS: usize = 4000;

/// Fewest triangles a part chunk holds, unless its layer has fewer.
pub const MIN_CHUNK_TRIANGLES: usize = 1000;

/// Most part triangles shown: a larger part is simplified to about this
/// many, each chunk on its own.
pub const MAX_PART_TRIANGLES: usize = 1_000_000;

/// The simplifier's error bound, relative to a chunk's extent.
const SIMPLIFY_ERROR: f32 = 0.02;

/// Most markers of one problem kind.
pub const MAX_MARKERS: usize = 200;

/// Largest turn of a rotary axis between two keys of a joint-linear line
/// (degrees): within it, the viewer's rotation between keys is the line's.
const JOINT_STEP_DEG: f64 = 60.0;

/// Largest turn between two keys of a line the controller moves the tip
/// straight along, or of a machine shown in the part frame (degrees).
const TCP_STEP_DEG: f64 = 5.0;

/// Colours (RGBA) of what a line does, for the toolpath and the markers.
pub fn class_color(c: LineClass) -> [f32; 4] {
    match c {
        LineClass::Printing => [0.20, 0.45, 0.85, 1.0],
        LineClass::Travel => [0.60, 0.60, 0.65, 1.0],
        LineClass::Problem(k) => problem_color(k),
    }
}

/// The colour of a problem kind.
pub fn problem_color(k: ProblemKind) -> [f32; 4] {
    match k {
        ProblemKind::Collision => [0.90, 0.05, 0.05, 1.0],
        ProblemKind::TipDeviation => [1.00, 0.55, 0.00, 1.0],
        ProblemKind::TipSpeed => [0.95, 0.85, 0.10, 1.0],
        ProblemKind::Swing => [0.65, 0.15, 0.85, 1.0],
        ProblemKind::Blob => [0.45, 0.25, 0.10, 1.0],
        ProblemKind::LongTravelTurn => [0.10, 0.75, 0.75, 1.0],
    }
}

/// How much a line's class matters when lines share a drawn segment.
fn rank(c: LineClass) -> u8 {
    match c {
        LineClass::Printing => 0,
        LineClass::Travel => 1,
        LineClass::Problem(k) => 7 - k as u8,
    }
}

/// Every class a line can have, in drawing order.
fn all_classes() -> Vec<LineClass> {
    let mut v = vec![LineClass::Printing, LineClass::Travel];
    v.extend(ProblemKind::ALL.map(LineClass::Problem));
    v
}

/// What `program.glb` shows.
pub struct ProgramScene<'a> {
    /// The machine.
    pub machine: &'a Machine,
    /// The head, the platform and the part (stamped as `stamp` says).
    pub scene: &'a Scene,
    /// The program's timing.
    pub playback: &'a Playback<'a>,
    /// A scene stamp in the playback's numbering (identity where the scene
    /// was re-stamped in print order).
    pub stamp: &'a (dyn Fn(u32) -> u32 + Sync),
    /// The machine's other bodies ([`super::machine_bodies`]).
    pub bodies: &'a [(BodyMotion, Mesh)],
}

/// One key of the animation: a time and the machine's axes then.
#[derive(Clone, Copy, Debug)]
struct Key {
    time: f32,
    axes: Axes,
    /// The move whose line this key lies on.
    mv: usize,
}

/// The GLB bytes.
pub fn program_glb(s: &ProgramScene) -> Vec<u8> {
    let mut b = Builder::default();
    let keys = keys(s.machine, s.playback);
    let rig = rig(&mut b, s.machine);
    animate(&mut b, &rig, s.machine, &keys);
    bodies(&mut b, &rig, s.bodies);
    part(&mut b, rig.part, s);
    head(&mut b, rig.head, s.scene);
    toolpath(&mut b, rig.part, s, &keys);
    markers(&mut b, rig.part, s);
    b.into_glb("program", "program")
}

/// The animation's keys: the first line's start at 0, then each kept
/// line's end, with keys inside lines whose path straight keys would miss.
fn keys(m: &Machine, p: &Playback) -> Vec<Key> {
    let Some(first) = p.moves.first() else {
        return Vec::new();
    };
    let table = m.configuration == Configuration::III;
    let mut keys = vec![Key {
        time: 0.0,
        axes: axes_of(&first.from),
        mv: 0,
    }];
    let mut last_t = 0.0f64;
    for i in p.kept() {
        let prev = keys.last().expect("a first key").axes;
        let to = axes_of(&p.moves[i].to);
        let turn = (to.tilt - prev.tilt)
            .abs()
            .max((to.c - prev.c).abs())
            .to_degrees();
        let tcp = p.moves[i].tcp || !table;
        let step = if tcp { TCP_STEP_DEG } else { JOINT_STEP_DEG };
        let pieces = ((turn / step).ceil() as usize).clamp(1, 720);
        let (t0, t1) = (last_t, p.ends[i]);
        for k in 1..=pieces {
            let f = k as f64 / pieces as f64;
            let axes = if k == pieces {
                to
            } else if p.moves[i].tcp {
                along_tip(m, &prev, &to, f)
            } else {
                prev.lerp(&to, f)
            };
            push_key(
                &mut keys,
                Key {
                    time: (t0 + f * (t1 - t0)) as f32,
                    axes,
                    mv: i,
                },
            );
        }
        last_t = t1;
    }
    keys
}

/// Axes a fraction `f` along a line that moves the tip straight in the
/// part frame with the rotary axes linear.
fn along_tip(m: &Machine, a: &Axes, b: &Axes, f: f64) -> Axes {
    let r = a.lerp(b, f);
    let (pa, pb) = (m.tip(a), m.tip(b));
    let tip = std::array::from_fn(|k| pa[k] + f * (pb[k] - pa[k]));
    Axes {
        xyz: linear_axes(m, tip, r.tilt, r.c),
        ..r
    }
}

/// Append `k`; a key at (or, in f32, before) the last one's time replaces
/// it: glTF's key times strictly increase.
fn push_key(keys: &mut Vec<Key>, k: Key) {
    match keys.last_mut() {
        Some(last) if k.time <= last.time => {
            *last = Key {
                time: last.time,
                ..k
            }
        }
        _ => keys.push(k),
    }
}

/// The animated nodes.
struct Rig {
    /// The root (the machine's base).
    root: usize,
    /// Moves as the axes say, in order: X, Y, cradle, table (for a
    /// rotary table); empty for a machine shown in the part frame.
    axes: Vec<usize>,
    /// Where part-frame things hang.
    part: usize,
    /// The head's node.
    head: usize,
}

/// The node tree of `m`.
fn rig(b: &mut Builder, m: &Machine) -> Rig {
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let root = b.node(json!({
        "name": "machine (mm, Z up)",
        "rotation": [-h, 0.0, 0.0, h],
        "scale": [0.001, 0.001, 0.001],
    }));
    let head = b.node(json!({"name": "head"}));
    b.child(root, head);
    if m.configuration != Configuration::III {
        let part = b.node(json!({"name": "part frame"}));
        b.child(root, part);
        return Rig {
            root,
            axes: Vec::new(),
            part,
            head,
        };
    }
    let mut chain = Vec::new();
    let mut parent = root;
    for name in ["X carriage", "Y carriage", "cradle", "table"] {
        let n = b.node(json!({ "name": name }));
        b.child(parent, n);
        chain.push(n);
        parent = n;
    }
    Rig {
        root,
        axes: chain,
        part: parent,
        head,
    }
}

/// The machine's other bodies, each on the node that moves as it does.
fn bodies(b: &mut Builder, rig: &Rig, bodies: &[(BodyMotion, Mesh)]) {
    if bodies.is_empty() {
        return;
    }
    let mat = b.material("machine", [0.62, 0.66, 0.72, 0.45], false);
    for (k, (motion, mesh)) in bodies.iter().enumerate() {
        let parent = match (motion, rig.axes.as_slice()) {
            (BodyMotion::Base, _) => rig.root,
            (BodyMotion::Head, _) => rig.head,
            (BodyMotion::Table, _) => rig.part,
            (BodyMotion::X, [x, ..]) => *x,
            (BodyMotion::Xy, [_, y, ..]) => *y,
            (BodyMotion::Cradle, [_, _, cradle, _]) => *cradle,
            // Validated away: such bodies belong to a rotary table.
            _ => rig.root,
        };
        let m = whole_mesh(b, mesh, mat);
        let n = b.node(json!({"name": format!("machine body {k} ({motion:?})"), "mesh": m}));
        b.child(parent, n);
    }
}

/// Quaternion of a turn by `a` radians about axis `k` (0 x, 1 y, 2 z).
fn about(k: usize, a: f64) -> [f32; 4] {
    let (s, c) = (a / 2.0).sin_cos();
    let mut q = [0.0, 0.0, 0.0, c as f32];
    q[k] = s as f32;
    q
}

/// The channels: one sampler per animated property, all on one key list.
fn animate(b: &mut Builder, rig: &Rig, m: &Machine, keys: &[Key]) {
    if keys.is_empty() {
        return;
    }
    let times = b.times(&keys.iter().map(|k| k.time).collect::<Vec<_>>());
    let lin = Interpolation::Linear;
    if rig.axes.is_empty() {
        let tips: Vec<[f32; 3]> = keys
            .iter()
            .map(|k| m.tip(&k.axes).map(|x| x as f32))
            .collect();
        let rot: Vec<[f32; 4]> = keys
            .iter()
            .map(|k| {
                let r = head_rotation(m.rotary, k.axes.tilt, k.axes.c);
                quaternion([0, 1, 2].map(|j| r.col(j).as_vec3().to_array()))
            })
            .collect();
        let t = b.vec3_keys(&tips);
        let r = b.quat_keys(&continuous(rot));
        b.channel(rig.head, "translation", times, t, lin);
        b.channel(rig.head, "rotation", times, r, lin);
        return;
    }
    let tilt_axis = if m.rotary == Rotary::BC { 1 } else { 0 };
    let x: Vec<[f32; 3]> = keys
        .iter()
        .map(|k| [-k.axes.xyz[0] as f32, 0.0, 0.0])
        .collect();
    let y: Vec<[f32; 3]> = keys
        .iter()
        .map(|k| [0.0, -k.axes.xyz[1] as f32, 0.0])
        .collect();
    let tilt: Vec<[f32; 4]> = keys.iter().map(|k| about(tilt_axis, k.axes.tilt)).collect();
    let c: Vec<[f32; 4]> = keys.iter().map(|k| about(2, k.axes.c)).collect();
    let z: Vec<[f32; 3]> = keys
        .iter()
        .map(|k| [0.0, 0.0, k.axes.xyz[2] as f32])
        .collect();
    let (x, y, z) = (b.vec3_keys(&x), b.vec3_keys(&y), b.vec3_keys(&z));
    let (tilt, c) = (b.quat_keys(&continuous(tilt)), b.quat_keys(&continuous(c)));
    b.channel(rig.axes[0], "translation", times, x, lin);
    b.channel(rig.axes[1], "translation", times, y, lin);
    b.channel(rig.axes[2], "rotation", times, tilt, lin);
    b.channel(rig.axes[3], "rotation", times, c, lin);
    b.channel(rig.head, "translation", times, z, lin);
}

/// Quaternions each in the hemisphere of the one before, so that every
/// viewer turns the short way between keys, the way the axis turns.
fn continuous(mut q: Vec<[f32; 4]>) -> Vec<[f32; 4]> {
    for i in 1..q.len() {
        let d: f32 = (0..4).map(|k| q[i][k] * q[i - 1][k]).sum();
        if d < 0.0 {
            q[i] = q[i].map(|x| -x);
        }
    }
    q
}

/// The platform, and the part in chunks that appear as they are printed.
/// The nodes' meshes are made on every core ([`PartNode::shown`]), then
/// added in order: the same file as one by one.
fn part(b: &mut Builder, parent: usize, s: &ProgramScene) {
    let platform_mat = b.material("platform", [0.55, 0.55, 0.60, 1.0], false);
    let layer_mats = [
        b.material("part (even layers)", [0.85, 0.80, 0.70, 1.0], false),
        b.material("part (odd layers)", [0.78, 0.70, 0.58, 1.0], false),
    ];
    let total: usize = s.scene.groups.iter().map(|g| g.mesh.triangles.len()).sum();
    let chunk_size = (total / MAX_CHUNKS + 1).max(MIN_CHUNK_TRIANGLES);
    let keep = (MAX_PART_TRIANGLES as f64 / total.max(1) as f64).min(1.0);
    let nodes = part_nodes(s, chunk_size);
    let meshes: Vec<(Vec<V3>, Vec<[u32; 3]>)> = nodes.par_iter().map(|n| n.shown(keep)).collect();
    let p = s.playback;
    for (node, (vertices, triangles)) in nodes.iter().zip(meshes) {
        let &PartNode::Chunk {
            layer, k, after, ..
        } = node
        else {
            let mesh = add_mesh(b, &vertices, &triangles, platform_mat);
            let n = b.node(json!({"name": "platform", "mesh": mesh}));
            b.child(parent, n);
            continue;
        };
        let mesh = add_mesh(b, &vertices, &triangles, layer_mats[layer % 2]);
        let time = p.ends[after] as f32;
        let n = b.node(json!({
            "name": format!("layer {layer} part {k}"),
            "mesh": mesh,
            "scale": [0.0, 0.0, 0.0],
            "extras": {"layer": layer, "appears_s": time, "after_line": p.moves[after].line},
        }));
        b.child(parent, n);
        let times = b.times(&[0.0, time.max(f32::MIN_POSITIVE)]);
        let scales = b.vec3_keys(&[[0.0; 3], [1.0; 3]]);
        b.channel(n, "scale", times, scales, Interpolation::Step);
    }
}

/// One node of the part: a platform whole, or a chunk of a layer's
/// triangles that appear together.
enum PartNode<'s> {
    Platform(&'s Mesh),
    Chunk {
        mesh: &'s Mesh,
        layer: usize,
        /// The chunk's number within its layer.
        k: usize,
        /// Its triangles (corners indexing `mesh`'s vertices), in the
        /// order they appear.
        triangles: Vec<[u32; 3]>,
        /// The move after which the last of them exists.
        after: usize,
    },
}

impl PartNode<'_> {
    /// Its mesh as shown: a chunk simplified to about `keep` of its
    /// triangles ([`shown_mesh`]).
    fn shown(&self, keep: f64) -> (Vec<V3>, Vec<[u32; 3]>) {
        match self {
            PartNode::Platform(m) => shown_mesh(&m.vertices, &m.triangles, 1.0),
            PartNode::Chunk {
                mesh, triangles, ..
            } => shown_mesh(&mesh.vertices, triangles, keep),
        }
    }
}

/// The platforms, and each layer's printed triangles by the move after
/// which they exist, cut into chunks of `chunk_size` (triangles never
/// printed are left out).
fn part_nodes<'s>(s: &ProgramScene<'s>, chunk_size: usize) -> Vec<PartNode<'s>> {
    let p = s.playback;
    let mut nodes = Vec::new();
    for g in &s.scene.groups {
        let Some(layer) = g.layer else {
            nodes.push(PartNode::Platform(&g.mesh));
            continue;
        };
        let mut order: Vec<(usize, usize)> = (0..g.mesh.triangles.len())
            .filter_map(|t| p.appears_after((s.stamp)(g.stamps[t])).map(|i| (i, t)))
            .collect();
        order.sort_unstable();
        for (k, chunk) in order.chunks(chunk_size).enumerate() {
            nodes.push(PartNode::Chunk {
                mesh: &g.mesh,
                layer,
                k,
                triangles: chunk.iter().map(|&(_, t)| g.mesh.triangles[t]).collect(),
                after: chunk.last().expect("a chunk is not empty").0,
            });
        }
    }
    nodes
}

/// The mesh of `triangles` over `vertices` as shown (vertices compacted),
/// simplified to about `keep` of its triangles when `keep < 1`.
fn shown_mesh(vertices: &[V3], triangles: &[[u32; 3]], keep: f64) -> (Vec<V3>, Vec<[u32; 3]>) {
    let (vertices, triangles) = compact(vertices, triangles.iter().copied());
    if keep < 1.0 && triangles.len() > 8 {
        let simpler = simplified(&vertices, &triangles, keep);
        compact(&vertices, simpler.into_iter())
    } else {
        (vertices, triangles)
    }
}

/// All of mesh `m` (vertices compacted) in `material`: its index.
fn whole_mesh(b: &mut Builder, m: &Mesh, material: usize) -> usize {
    let (vertices, triangles) = shown_mesh(&m.vertices, &m.triangles, 1.0);
    add_mesh(b, &vertices, &triangles, material)
}

/// A mesh of `triangles` over `vertices` in `material`: its index.
fn add_mesh(b: &mut Builder, vertices: &[V3], triangles: &[[u32; 3]], material: usize) -> usize {
    let pos = b.positions(vertices);
    let idx = b.triangles(triangles);
    b.mesh(
        "part",
        vec![json!({"attributes": {"POSITION": pos}, "indices": idx, "material": material})],
    )
}

/// The vertices `triangles` use, renumbered in order of first use.
fn compact(vertices: &[V3], triangles: impl Iterator<Item = [u32; 3]>) -> (Vec<V3>, Vec<[u32; 3]>) {
    let mut map = vec![u32::MAX; vertices.len()];
    let mut used = Vec::new();
    let tris = triangles
        .map(|t| {
            t.map(|v| {
                let v = v as usize;
                if map[v] == u32::MAX {
                    map[v] = used.len() as u32;
                    used.push(vertices[v]);
                }
                map[v]
            })
        })
        .collect();
    (used, tris)
}

/// About `keep` of `triangles` covering the same surface (meshoptimizer,
/// borders kept so neighbouring chunks still meet; where that cannot get
/// near the count, its sloppy simplifier).
fn simplified(vertices: &[V3], triangles: &[[u32; 3]], keep: f64) -> Vec<[u32; 3]> {
    let target = ((triangles.len() as f64 * keep).ceil() as usize).max(1) * 3;
    let adapter = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(vertices), 12, 0)
        .expect("positions are 12-byte vertices");
    let indices = triangles.as_flattened();
    let mut out = meshopt::simplify(
        indices,
        &adapter,
        target,
        SIMPLIFY_ERROR,
        meshopt::SimplifyOptions::LockBorder,
        None,
    );
    if out.len() > 2 * target {
        out = meshopt::simplify_sloppy(indices, &adapter, target, SIMPLIFY_ERROR, None);
    }
    out.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()
}

/// The head's mesh on its node.
fn head(b: &mut Builder, node: usize, scene: &Scene) {
    let mat = b.material("head", [0.30, 0.30, 0.35, 1.0], false);
    let mesh = whole_mesh(b, &scene.head.mesh, mat);
    let n = b.node(json!({"name": "head mesh", "mesh": mesh}));
    b.child(node, n);
}

/// The tip's path in the part frame through the keys, one line primitive
/// per class (a segment takes the worst class of the lines it spans).
fn toolpath(b: &mut Builder, parent: usize, s: &ProgramScene, keys: &[Key]) {
    if keys.len() < 2 {
        return;
    }
    let p = s.playback;
    let tips: Vec<[f32; 3]> = keys
        .iter()
        .map(|k| s.machine.tip(&k.axes).map(|x| x as f32))
        .collect();
    let classes = all_classes();
    let mut lines: Vec<Vec<u32>> = vec![Vec::new(); classes.len()];
    for j in 1..keys.len() {
        let first = if keys[j - 1].mv == keys[j].mv {
            keys[j].mv
        } else {
            keys[j - 1].mv + 1
        };
        let class = (first..=keys[j].mv.max(first))
            .map(|i| p.classes[i])
            .max_by_key(|&c| rank(c))
            .unwrap_or(LineClass::Travel);
        let slot = classes
            .iter()
            .position(|&c| c == class)
            .expect("every class");
        lines[slot].extend([j as u32 - 1, j as u32]);
    }
    let pos = b.positions(&tips);
    let mut prims = Vec::new();
    for (class, idx) in classes.iter().zip(&lines) {
        if idx.is_empty() {
            continue;
        }
        let mat = b.material(&class_name(*class), class_color(*class), true);
        let ind = b.indices(idx);
        prims.push(
            json!({"attributes": {"POSITION": pos}, "indices": ind, "mode": 1, "material": mat}),
        );
    }
    let mesh = b.mesh("toolpath", prims);
    let n = b.node(json!({"name": "toolpath", "mesh": mesh}));
    b.child(parent, n);
}

/// What a class is called in the scene.
pub fn class_name(c: LineClass) -> String {
    match c {
        LineClass::Printing => "printing".into(),
        LineClass::Travel => "travel".into(),
        LineClass::Problem(k) => kind_name(k).into(),
    }
}

/// What a problem kind is called in the scene and on the page.
pub fn kind_name(k: ProblemKind) -> &'static str {
    match k {
        ProblemKind::Collision => "collision",
        ProblemKind::TipDeviation => "tip deviation",
        ProblemKind::TipSpeed => "tip speed",
        ProblemKind::Swing => "swing",
        ProblemKind::Blob => "blob",
        ProblemKind::LongTravelTurn => "long travel turn",
    }
}

/// A marker (an octahedron 3 mm across) at the tip of each problem's line,
/// the first [`MAX_MARKERS`] of each kind.
fn markers(b: &mut Builder, parent: usize, s: &ProgramScene) {
    let p = s.playback;
    let r = 1.5f32;
    let v = vec![
        [r, 0.0, 0.0],
        [-r, 0.0, 0.0],
        [0.0, r, 0.0],
        [0.0, -r, 0.0],
        [0.0, 0.0, r],
        [0.0, 0.0, -r],
    ];
    let t: Vec<[u32; 3]> = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    let octahedron = Mesh {
        vertices: v,
        triangles: t,
    };
    for kind in ProblemKind::ALL {
        let of: Vec<_> = p
            .problems
            .iter()
            .filter(|q| q.kind == kind)
            .take(MAX_MARKERS)
            .collect();
        if of.is_empty() {
            continue;
        }
        let mat = b.material(
            &format!("{} marker", kind_name(kind)),
            problem_color(kind),
            true,
        );
        let mesh = whole_mesh(b, &octahedron, mat);
        for q in of {
            let Some(i) = p.index_of_line(q.line) else {
                continue;
            };
            let tip = s.machine.tip(&axes_of(&p.moves[i].to)).map(|x| x as f32);
            let n = b.node(json!({
                "name": format!("{} at line {}", kind_name(kind), q.line),
                "mesh": mesh,
                "translation": tip,
                "extras": {"line": q.line, "kind": kind_name(kind), "value": q.value, "time_s": p.ends[i]},
            }));
            b.child(parent, n);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::gcode_read::GcodeMove;
    use crate::simulate::{MoveReport, Simulation, Timeline};

    /// A line from `a` to `b` (`[X, Y, Z, tilt°, C°]`) lasting `seconds`.
    fn line(n: usize, a: [f64; 5], b: [f64; 5], tcp: bool) -> GcodeMove {
        GcodeMove {
            line: n,
            linear: true,
            from: a,
            to: b,
            e: 0.0,
            de: 0.1,
            f: 600.0,
            inverse_time: false,
            tcp,
            tool: 0,
            dwell: 0.0,
        }
    }

    fn measured(moves: &[GcodeMove], seconds: &[f64]) -> (Simulation, Timeline) {
        let reports = moves
            .iter()
            .zip(seconds)
            .map(|(mv, &s)| MoveReport {
                line: mv.line,
                extrudes: true,
                tcp: mv.tcp,
                layer: Some(0),
                seconds: s,
                length_mm: 1.0,
                tip_speed: 1.0,
                deviation_mm: 0.0,
                rotary_step_deg: 0.0,
                tilt_deg: mv.to[3],
                c_deg: mv.to[4],
                e_per_mm: 0.1,
                collides: false,
            })
            .collect();
        let sim = Simulation {
            summary: Default::default(),
            problems: Vec::new(),
            moves: reports,
        };
        let timeline = Timeline {
            printed: Vec::new(),
            cutoffs: (0..moves.len() as u32).collect(),
            layers: vec![Some(0); moves.len()],
        };
        (sim, timeline)
    }

    #[test]
    fn a_big_turn_gets_keys_inside_its_line_and_times_strictly_increase() {
        let m = Machine::default();
        let moves = [
            line(
                1,
                [0.0, 0.0, 10.0, 0.0, 0.0],
                [5.0, 0.0, 10.0, 0.0, 0.0],
                false,
            ),
            // Half a turn of C under joint interpolation: 3 pieces of 60°.
            line(
                2,
                [5.0, 0.0, 10.0, 0.0, 0.0],
                [5.0, 0.0, 10.0, 0.0, 180.0],
                false,
            ),
            // A line of no duration ends where the one before does.
            line(
                3,
                [5.0, 0.0, 10.0, 0.0, 180.0],
                [5.0, 0.0, 10.0, 0.0, 180.0],
                false,
            ),
        ];
        let (sim, timeline) = measured(&moves, &[1.0, 6.0, 0.0]);
        let p = Playback::new(&moves, &sim, &timeline);
        let keys = keys(&m, &p);
        let times: Vec<f32> = keys.iter().map(|k| k.time).collect();
        assert_eq!(times, vec![0.0, 1.0, 3.0, 5.0, 7.0]);
        assert!((keys[2].axes.c.to_degrees() - 60.0).abs() < 1e-9);
        assert_eq!(keys.last().unwrap().mv, 2);
    }

    #[test]
    fn a_tool_centre_point_line_keeps_its_tip_on_the_chord() {
        let m = Machine::default();
        let a = m.axes_at([10.0, 0.0, 5.0], (0.0, 0.0));
        let b = m.axes_at([20.0, 0.0, 5.0], (0.5, 0.6));
        let deg = |x: &Axes| {
            [
                x.xyz[0],
                x.xyz[1],
                x.xyz[2],
                x.tilt.to_degrees(),
                x.c.to_degrees(),
            ]
        };
        let moves = [line(1, deg(&a), deg(&b), true)];
        let (sim, timeline) = measured(&moves, &[2.0]);
        let p = Playback::new(&moves, &sim, &timeline);
        let keys = keys(&m, &p);
        // 0.5 rad of tilt and 0.6 of C: 35° at most 5° a key.
        assert_eq!(keys.len(), 1 + 7);
        for k in &keys {
            let tip = m.tip(&k.axes);
            // Within the written axes' rounding.
            assert!(
                tip[1].abs() < 1e-3 && (tip[2] - 5.0).abs() < 1e-3,
                "{tip:?}"
            );
        }
    }

    #[test]
    fn rotations_take_the_short_way_between_keys() {
        let q = continuous((0..8).map(|k| about(2, k as f64 * 1.2)).collect());
        for w in q.windows(2) {
            let dot: f32 = (0..4).map(|i| w[0][i] * w[1][i]).sum();
            assert!(dot > 0.0);
        }
    }
}
