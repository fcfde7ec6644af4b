//! Differential tests: cpu, parry and brute force agree on random scenes,
//! at every safety margin in `MARGINS`. The only allowed disagreements are
//! near-contacts — the head's surface within 1e-3 mm of the margin from the
//! nearest existing triangle (DESIGN.md) — and each one is listed.

mod common;

use common::*;
use maamplan::collide::brute::BruteBackend;
use maamplan::collide::brute::{tri_tri_distance64, winding_number};
use maamplan::collide::cpu::CpuBackend;
use maamplan::collide::cpu::{
    classify, hull_clear, node_hull_clear, slab_clear, sphere_margin, to_head, triangle_margin,
    SceneView,
};
use maamplan::collide::parry::ParryBackend;
use maamplan::collide::Backend;
use maamplan::default_job::{box_mesh, cone_head};
use maamplan::geometry::Mesh;
use maamplan::scene::{GpuPartNode, GpuQuery, GpuTriangle, HeadConfig, Query, Scene, SceneConfig};

fn cfg(clearance: f32) -> SceneConfig {
    SceneConfig {
        head: HeadConfig {
            tip_clearance: clearance,
            grid_resolution: 48,
        },
        max_edge: None,
        head_cache: false,
        ..SceneConfig::default()
    }
}

/// The cpu and parry backends give `want` for `queries`, verdict for
/// verdict.
fn assert_cpu_and_parry_say(scene: &Scene, queries: &[Query], want: &[bool], what: &str) {
    let cpu = CpuBackend::new(scene);
    let parry = ParryBackend::new(scene).unwrap();
    for b in [&cpu as &dyn Backend, &parry] {
        assert_eq!(b.evaluate(queries).unwrap(), want, "{what}: {}", b.name());
    }
}

/// Compare `backends` against brute force; panic on any disagreement that
/// is not a near-contact. Returns (colliding, free) counts.
fn agree(
    scene: &Scene,
    queries: &[Query],
    backends: &[&dyn Backend],
    what: &str,
) -> (usize, usize) {
    let truth = BruteBackend::new(scene).evaluate(queries).unwrap();
    for b in backends {
        let got = b.evaluate(queries).unwrap();
        let near = near_contacts_only(
            scene,
            queries,
            &truth,
            &got,
            &format!("{what}, {} vs brute force", b.name()),
        );
        assert!(
            near * 100 <= queries.len(),
            "{what}: too many near-contacts for {}",
            b.name()
        );
    }
    let hits = truth.iter().filter(|&&c| c).count();
    (hits, truth.len() - hits)
}

#[test]
fn random_scenes_asymmetric_head() {
    for seed in 0..8u64 {
        let mut r = rng(seed);
        let tp = random_toolpath(&mut r, 3, 0.7);
        let radii: Vec<f32> = (0..11)
            .map(|j| 4.0 + 3.0 * ((j * 7 % 11) as f32 / 11.0))
            .collect();
        let head = star_head(&radii, 6.0, 14.0, [1.5, -0.7]);
        let platform = box_mesh([-40.0, -40.0, -3.0], [40.0, 40.0, 0.0]);
        let scene = Scene::build(&tp, &head, &platform, &cfg(0.2)).unwrap();
        let base = random_queries(&mut r, &scene, 500);
        let cpu = CpuBackend::new(&scene);
        let parry = ParryBackend::new(&scene).unwrap();
        let mut previous = 0;
        for margin in MARGINS {
            let queries = with_margin(&base, margin);
            let what = format!("seed {seed}, margin {margin}");
            let (hit, free) = agree(&scene, &queries, &[&cpu, &parry], &what);
            eprintln!("{what}: {hit} colliding, {free} free");
            assert!(
                hit > 20 && free > 20,
                "{what}: want both verdicts, got {hit} colliding / {free} free"
            );
            assert!(hit >= previous, "{what}: a larger margin frees poses");
            previous = hit;
        }
    }
}

#[test]
fn random_scenes_sloped_margins() {
    let mut decided_by_slope = [0; SLOPED.len()];
    for seed in 30..34u64 {
        let mut r = rng(seed);
        let scene = star_scene(&mut r, 11, 3.0, [1.2, -0.4]);
        let base = random_queries(&mut r, &scene, 400);
        let cpu = CpuBackend::new(&scene);
        let parry = ParryBackend::new(&scene).unwrap();
        for (k, (margin, slope)) in SLOPED.into_iter().enumerate() {
            let what = format!("seed {seed}, margin {margin} + {slope} per mm");
            let queries = with_slope(&base, margin, slope);
            let (hit, free) = agree(&scene, &queries, &[&cpu, &parry], &what);
            assert!(
                hit > 20 && free > 20,
                "{what}: {hit} colliding / {free} free"
            );
            // The slope decides verdicts of its own: poses free at the
            // plain margin that collide once it grows away from the tip.
            let plain = BruteBackend::new(&scene)
                .evaluate(&with_margin(&base, margin))
                .unwrap();
            let sloped = cpu.evaluate(&queries).unwrap();
            assert!(
                plain.iter().zip(&sloped).all(|(p, s)| !p || *s),
                "{what}: a slope freed a pose"
            );
            let decided = plain
                .iter()
                .zip(&sloped)
                .filter(|(p, s)| !**p && **s)
                .count();
            eprintln!("{what}: {hit} colliding, {decided} by the slope");
            decided_by_slope[k] += decided;
        }
    }
    assert!(
        decided_by_slope.iter().all(|&d| d >= 10),
        "verdicts the slopes decided: {decided_by_slope:?}"
    );
}

/// The two kernels' CPU mirrors together — the walk's hit or any of the
/// pairs it hands over hitting by the exact tests — give the cpu
/// evaluator's verdict, query by query, at every margin and slope: the
/// gpu backend's split into passes decides what the one walk decides.
#[test]
fn the_kernel_mirrors_together_give_the_evaluators_verdicts() {
    use maamplan::collide::cpu::{exact, query_hits, traverse};
    for seed in 40..43u64 {
        let mut r = rng(seed);
        let scene = star_scene(&mut r, 11, 3.0, [-0.8, 0.6]);
        let view = SceneView::new(&scene);
        let base = random_queries(&mut r, &scene, 400);
        let (mut by_walk, mut by_pairs, mut free) = (0, 0, 0);
        for (margin, slope) in MARGINS.map(|m| (m, 0.0)).into_iter().chain(SLOPED) {
            for q in with_slope(&base, margin, slope) {
                let q = q.to_gpu();
                let w = traverse::walk(&view, &q);
                let pairs = w.candidates.iter().any(|&t| exact::pair_hits(&view, &q, t));
                assert_eq!(
                    w.hit || pairs,
                    query_hits(&view, &q),
                    "seed {seed}, margin {margin} + {slope} per mm"
                );
                by_walk += w.hit as usize;
                by_pairs += (!w.hit && pairs) as usize;
                free += !(w.hit || pairs) as usize;
            }
        }
        eprintln!("seed {seed}: {by_walk} decided by the walk, {by_pairs} by the exact tests, {free} free");
        assert!(by_walk > 50 && by_pairs > 50 && free > 50);
    }
}

#[test]
fn verdicts_flip_at_each_poses_own_distance() {
    for seed in 20..23u64 {
        let mut r = rng(seed);
        let scene = star_scene(&mut r, 11, 3.0, [-1.0, 0.8]);
        let base = random_queries(&mut r, &scene, 300);
        let (queries, expected) = margin_boundary_queries(&scene, &base, 1.5);
        assert!(
            queries.len() > 100,
            "seed {seed}: {} queries",
            queries.len()
        );
        let cpu = CpuBackend::new(&scene);
        let parry = ParryBackend::new(&scene).unwrap();
        let brute = BruteBackend::new(&scene);
        for b in [&cpu as &dyn Backend, &parry, &brute] {
            let got = b.evaluate(&queries).unwrap();
            let wrong: Vec<_> = (0..queries.len())
                .filter(|&i| got[i] != expected[i])
                .map(|i| (i, queries[i].margin, expected[i]))
                .collect();
            assert!(wrong.is_empty(), "seed {seed}, {}: {wrong:?}", b.name());
        }
    }
}

#[test]
fn margins_decide_flat_and_edge_to_edge_approaches() {
    for case in margin_cases() {
        let truth = BruteBackend::new(&case.scene)
            .evaluate(&case.queries)
            .unwrap();
        assert_eq!(truth, case.expected, "{}: brute force", case.what);
        assert_cpu_and_parry_say(&case.scene, &case.queries, &case.expected, case.what);
    }
}

#[test]
fn negative_or_nan_margins_are_refused() {
    let (_, scene) = default_scene();
    let q = scene.waypoint_queries[0];
    for margin in [-0.01, f32::NAN, f32::INFINITY] {
        let queries = [q, Query { margin, ..q }];
        let backends: [&dyn Backend; 3] = [
            &CpuBackend::new(&scene),
            &ParryBackend::new(&scene).unwrap(),
            &BruteBackend::new(&scene),
        ];
        for b in backends {
            let err = b.evaluate(&queries).unwrap_err();
            assert!(
                matches!(err, maamplan::collide::CollideError::BadMargin(1)),
                "{}: {err}",
                b.name()
            );
        }
    }
}

#[test]
fn fully_contained_triangles_collide() {
    // One tiny triangle floating in mid-air, far from the platform; the head
    // placed around it without touching it.
    let tri = Mesh {
        vertices: vec![[0.0, 0.0, 30.0], [0.2, 0.0, 30.0], [0.0, 0.2, 30.1]],
        triangles: vec![[0, 1, 2]],
    };
    let tp = one_layer(tri, [0.0, 0.0, 30.0]);
    let head = cone_head(10.0, 10.0, 20.0, 24);
    let platform = box_mesh([-50.0, -50.0, -2.0], [50.0, 50.0, 0.0]);
    let scene = Scene::build(&tp, &head, &platform, &cfg(0.3)).unwrap();
    // The triangle has stamp 1: cutoff 2 sees it.
    let inside = Query {
        pose: pose([0.0, 0.0, 20.0], [0.0, 0.0, 1.0]),
        cutoff: 2,
        margin: 0.0,
        slope: 0.0,
    };
    let above = Query {
        pose: pose([0.0, 0.0, 32.0], [0.0, 0.0, 1.0]),
        cutoff: 2,
        margin: 0.0,
        slope: 0.0,
    };
    let not_yet = Query {
        cutoff: 1,
        ..inside
    };
    let queries = [inside, above, not_yet];
    let truth = BruteBackend::new(&scene).evaluate(&queries).unwrap();
    assert_eq!(truth, vec![true, false, false]);
    assert_cpu_and_parry_say(&scene, &queries, &truth, "inside, above, not yet");
}

#[test]
fn coplanar_and_edge_touching_contacts() {
    // A box head (closed, flat faces) over a flat square part triangle pair.
    let head = box_mesh([-2.0, -2.0, 0.0], [2.0, 2.0, 4.0]);
    let square = Mesh {
        vertices: vec![
            [-1.0, -1.0, 5.0],
            [1.0, -1.0, 5.0],
            [1.0, 1.0, 5.0],
            [-1.0, 1.0, 5.0],
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    };
    let tp = one_layer(square, [0.0, 0.0, 5.0]);
    let platform = box_mesh([-50.0, -50.0, -2.0], [50.0, 50.0, -1.0]);
    let scene = Scene::build(&tp, &head, &platform, &cfg(0.0)).unwrap();
    let at = |tip: [f32; 3], axis: [f32; 3]| Query {
        pose: pose(tip, axis),
        cutoff: 2,
        margin: 0.0,
        slope: 0.0,
    };
    let queries = [
        // Head's top face exactly on the square's plane, overlapping: coplanar contact.
        at([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]),
        // Top face coplanar, side by side sharing an edge line (x = 1 vs x = 1).
        at([3.0, 0.0, 1.0], [0.0, 0.0, 1.0]),
        // Coplanar but apart.
        at([3.5, 0.0, 1.0], [0.0, 0.0, 1.0]),
        // Just below the plane: a clear gap.
        at([0.0, 0.0, 0.9], [0.0, 0.0, 1.0]),
        // Half a millimetre through it.
        at([0.0, 0.0, 1.5], [0.0, 0.0, 1.0]),
    ];
    let truth = BruteBackend::new(&scene).evaluate(&queries).unwrap();
    assert_eq!(truth, vec![true, true, false, false, true]);
    let cpu = CpuBackend::new(&scene);
    assert_eq!(cpu.evaluate(&queries).unwrap(), truth);
    // parry may call the exact touches either way; they are near-contacts.
    let parry = ParryBackend::new(&scene)
        .unwrap()
        .evaluate(&queries)
        .unwrap();
    for i in [2, 3, 4] {
        assert_eq!(parry[i], truth[i], "query {i}");
    }
}

/// One flat layer printed left to right, and a head lowered 0.5 mm into
/// it at x = 5 (waypoint 15), asked at every cutoff from 1 to 22.
fn half_printed_layer() -> (Scene, Vec<Query>) {
    let surface = height_patch([-10.0, 10.0], [-2.0, 2.0], 20, |_, _| 1.0);
    let waypoints: Vec<_> = (0..21)
        .map(|i| maamplan::toolpath::Waypoint {
            pos: [-10.0 + i as f32, 0.0, 1.0],
            dir: [0.0, 0.0, 1.0],
        })
        .collect();
    let tp = maamplan::toolpath::Toolpath {
        layers: vec![maamplan::toolpath::Layer {
            name: "0".into(),
            waypoints,
            surface: Some(surface),
        }],
    };
    let head = cone_head(3.0, 3.0, 6.0, 16);
    let platform = box_mesh([-50.0, -50.0, -2.0], [50.0, 50.0, 0.0]);
    let scene = Scene::build(&tp, &head, &platform, &cfg(0.3)).unwrap();
    let p = pose([5.0, 0.0, 0.5], [0.0, 0.0, 1.0]);
    let queries: Vec<Query> = (1..=22)
        .map(|cutoff| Query {
            pose: p,
            cutoff,
            margin: 0.0,
            slope: 0.0,
        })
        .collect();
    (scene, queries)
}

#[test]
fn stamps_cut_a_layer_in_half() {
    // The head standing on the right half sees the layer only once the
    // cutoff passes the waypoints there.
    let (scene, queries) = half_printed_layer();
    let truth = BruteBackend::new(&scene).evaluate(&queries).unwrap();
    let first_hit = truth
        .iter()
        .position(|&c| c)
        .expect("collides once printed");
    assert!(
        truth[first_hit..].iter().all(|&c| c),
        "monotone in the cutoff"
    );
    assert!(
        (10..=16).contains(&first_hit),
        "first colliding cutoff {}",
        first_hit + 1
    );
    assert_cpu_and_parry_say(&scene, &queries, &truth, "cutoffs 1 to 22");
}

#[test]
fn a_hits_witness_counts_only_where_it_exists() {
    // The cpu backend tries the triangle of its previous hit first. Asked
    // from the latest cutoff down, the triangles that decided the hits
    // stop existing one by one: each verdict must still be the brute
    // force's, and the same as asking each pose alone.
    let (scene, mut queries) = half_printed_layer();
    queries.reverse();
    let truth = BruteBackend::new(&scene).evaluate(&queries).unwrap();
    assert!(truth[0] && !truth[truth.len() - 1], "hits, then free");
    let cpu = CpuBackend::new(&scene);
    assert_eq!(cpu.evaluate(&queries).unwrap(), truth);
    let alone: Vec<bool> = queries
        .iter()
        .map(|q| cpu.evaluate(std::slice::from_ref(q)).unwrap()[0])
        .collect();
    assert_eq!(alone, truth);
}

/// The nodes of the part tree a walk for `q` meets as the backends walk
/// it: each node that exists at the cutoff and whose sphere the grid
/// cannot settle goes to `visit` (with its centre in the head frame and
/// the margin it must keep), which answers whether to walk on below it.
fn walk_undecided(
    scene: &Scene,
    q: &GpuQuery,
    mut visit: impl FnMut(usize, &GpuPartNode, [f32; 3], f32) -> bool,
) {
    let view = SceneView::new(scene);
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        let node = scene.part_nodes[i];
        if node.min_stamp >= q.cutoff {
            continue;
        }
        let c = to_head(q, node.center);
        let m = sphere_margin(q, c, node.radius);
        if classify(view.head, view.grid, c, node.radius, m) != 0 {
            continue;
        }
        if visit(i, &node, c, m) && node.leaf_range().is_none() {
            stack.extend([node.packed as usize, node.packed as usize + 1]);
        }
    }
}

/// The triangles below node `i` that exist at `cutoff`.
fn existing_below(scene: &Scene, i: usize, cutoff: u32) -> Vec<GpuTriangle> {
    let mut out = Vec::new();
    let mut below = vec![i];
    while let Some(j) = below.pop() {
        let n = scene.part_nodes[j];
        match n.leaf_range() {
            Some((first, count)) => out.extend(
                scene.part_tris[first as usize..(first + count) as usize]
                    .iter()
                    .filter(|t| t.stamp < cutoff),
            ),
            None => below.extend([n.packed as usize, n.packed as usize + 1]),
        }
    }
    out
}

#[test]
fn slabs_skip_only_material_clear_of_the_head() {
    // simple_curve's waypoints at 0.5 mm: walk the tree as the backends
    // do, and where a node's sphere cannot be settled but its slab can
    // (`slab_clear`), check by brute force in f64 that every existing
    // triangle below it keeps more than the margin from every head
    // triangle. The slabs must also be what settles many such nodes:
    // flat layers under the nozzle are what spheres are bad at.
    let (_, scene) = simple_curve();
    let view = SceneView::new(&scene);
    // Half a millimetre: the bead just printed, 0.3 mm under the lifted
    // head, is within it, so a slab that skipped too much would be seen.
    let margin = 0.5f32;
    let head = f64_head(&scene);
    let (mut settled, mut checked) = (0usize, 0usize);
    for base in scene.waypoint_queries.iter().step_by(211) {
        let q = Query { margin, ..*base }.to_gpu();
        walk_undecided(&scene, &q, |i, node, _, m| {
            if !slab_clear(view.head, view.grid, &q, node, m) {
                return true;
            }
            settled += 1;
            for t in existing_below(&scene, i, q.cutoff) {
                let tri = [t.v0, t.v1, t.v2].map(|v| to_head64(&q, v));
                let d = head_distance64(&tri, &head, margin as f64);
                assert!(
                    d > margin as f64,
                    "node {i}: a triangle {d} mm from the head"
                );
                checked += 1;
            }
            false
        });
    }
    assert!(
        settled > 1_000 && checked > 100_000,
        "{settled} nodes, {checked} triangles"
    );
}

/// Waypoint query `base` (the `k`-th asked) at one of the margins and
/// slopes the planner's proofs ask, in turn.
fn as_the_planner_asks(k: usize, base: &Query) -> GpuQuery {
    let (margin, slope) = [(0.05, 0.0), (0.2, 0.0), (0.15, 0.01)][k % 3];
    Query {
        margin,
        slope,
        ..*base
    }
    .to_gpu()
}

/// Part-frame point `p` in `q`'s head frame, in f64.
fn to_head64(q: &GpuQuery, p: [f32; 3]) -> [f64; 3] {
    let d: [f64; 3] = std::array::from_fn(|k| p[k] as f64 - q.rows[k][3] as f64);
    std::array::from_fn(|i| (0..3).map(|j| q.rows[i][j] as f64 * d[j]).sum())
}

/// The clearance `q` asks of triangle `tri` (head frame, f64): its margin
/// grown by its slope at the triangle's farthest corner from the tip.
fn asked_of(q: &GpuQuery, tri: &[[f64; 3]; 3]) -> f64 {
    let reach = tri
        .iter()
        .map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
        .fold(0.0, f64::max);
    q.margin as f64 + q.slope as f64 * reach
}

/// simple_curve with every nozzle tilted 50° about x: the head's flank
/// lies a few tenths of a millimetre over the layers.
fn tilted_simple_curve() -> maamplan::job::LoadedJob {
    simple_curve_job_tilted(Some(50.0))
}

/// The head's triangles in f64 and their boxes.
type Boxes = Vec<[[f64; 2]; 3]>;

fn f64_head(scene: &Scene) -> F64Head {
    let head: Vec<[[f64; 3]; 3]> = scene
        .head
        .triangles
        .iter()
        .map(|t| [t.v0, t.v1, t.v2].map(|v| v.map(|x| x as f64)))
        .collect();
    let boxes = head.iter().map(bounds64).collect();
    (head, boxes)
}

/// A triangle's box, per axis `[min, max]`.
fn bounds64(t: &[[f64; 3]; 3]) -> [[f64; 2]; 3] {
    std::array::from_fn(|k| {
        let v = [t[0][k], t[1][k], t[2][k]];
        [
            v.iter().copied().fold(f64::INFINITY, f64::min),
            v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        ]
    })
}

/// The nearest head triangle's distance from `tri` (head frame, f64) when
/// it is within `within`; infinity otherwise.
fn head_distance64(tri: &[[f64; 3]; 3], (head, boxes): &F64Head, within: f64) -> f64 {
    let tb = bounds64(tri);
    let mut near = f64::INFINITY;
    for (h, hb) in head.iter().zip(boxes) {
        if (0..3).any(|k| tb[k][0] - hb[k][1] > within || hb[k][0] - tb[k][1] > within) {
            continue;
        }
        near = near.min(tri_tri_distance64(tri, h));
    }
    near
}

/// The head's triangles in f64 and their boxes, as [`f64_head`] gives them.
type F64Head = (Vec<[[f64; 3]; 3]>, Boxes);

/// Walk the tilted simple_curve's tree for every `step`-th waypoint, each
/// asked as the planner asks, as the backends do: `visit` gets the pose
/// and each node that neither its sphere nor its slab settles (as
/// [`walk_undecided`] gives them) and answers whether to walk on below it.
fn walk_past_slabs(
    step: usize,
    mut visit: impl FnMut(&Asked, usize, &GpuPartNode, [f32; 3], f32) -> bool,
) {
    let job = tilted_simple_curve();
    let scene = &job.scene;
    let view = SceneView::new(scene);
    let head = f64_head(scene);
    for (k, base) in scene.waypoint_queries.iter().enumerate().step_by(step) {
        let q = as_the_planner_asks(k, base);
        let asked = Asked {
            scene,
            view: &view,
            head: &head,
            k,
            q,
        };
        walk_undecided(scene, &q, |i, node, c, m| {
            !slab_clear(view.head, view.grid, &q, node, m) && visit(&asked, i, node, c, m)
        });
    }
}

/// The `k`-th pose asked of the tilted simple_curve, with what brute
/// force needs to check its triangles.
struct Asked<'a> {
    scene: &'a Scene,
    view: &'a SceneView<'a>,
    head: &'a F64Head,
    k: usize,
    q: GpuQuery,
}

impl Asked<'_> {
    /// Brute force in f64 on existing triangle `t`: the clearance the
    /// query asks of it, and the nearest head triangle's distance when
    /// within `room` more than that (infinity otherwise).
    fn brute(&self, t: &GpuTriangle, room: f64) -> (f64, f64) {
        let tri = [t.v0, t.v1, t.v2].map(|v| to_head64(&self.q, v));
        let need = asked_of(&self.q, &tri);
        (need, head_distance64(&tri, self.head, need + room))
    }

    /// Whether `t`'s first corner lies inside the head (wholly inside is
    /// no clearance at all).
    fn inside_head(&self, t: &GpuTriangle) -> bool {
        winding_number(&self.scene.head.mesh, to_head(&self.q, t.v0)) > 0.5
    }

    /// Fails unless triangle `t`, settled by `what`, lies outside the head
    /// and farther than `need` from it (`near`, by brute force).
    fn assert_clear(&self, what: &str, t: &GpuTriangle, need: f64, near: f64) {
        assert!(
            near > need && !self.inside_head(t),
            "pose {}, {what}: a triangle {near} mm from the head settled at {need}",
            self.k
        );
    }
}

#[test]
fn node_hull_planes_settle_only_material_clear_of_the_head() {
    // Walk the tilted simple_curve's tree as the backends do; wherever a
    // node's sphere and slab cannot settle it but its slab against the
    // hull plane facing it can (`node_hull_clear`), brute force in f64
    // must find every existing triangle below it farther than its margin
    // from every head triangle. And the test must be what settles many
    // such nodes: flat layers beside the flank.
    let (mut settled, mut checked) = (0usize, 0usize);
    walk_past_slabs(1499, |at, i, node, c, m| {
        if !node_hull_clear(at.view.head, at.view.grid, &at.q, node, c, m) {
            return true;
        }
        settled += 1;
        for t in existing_below(at.scene, i, at.q.cutoff) {
            let (need, near) = at.brute(&t, 0.0);
            at.assert_clear(&format!("node {i}"), &t, need, near);
            checked += 1;
        }
        false
    });
    assert!(
        settled > 2_000 && checked > 100_000,
        "{settled} nodes, {checked} triangles"
    );
}

#[test]
fn hull_planes_settle_only_material_clear_of_the_head() {
    // simple_curve with every nozzle tilted 50° about x: the head's flank
    // lies a few tenths of a millimetre over the layers, where a
    // triangle's bounding sphere reaches into the head but the hull plane
    // facing it (`hull_clear`) does not. Walk the tree as the backends
    // do; wherever a leaf triangle's sphere cannot be settled and its
    // plane can, brute force in f64 must find it farther than the margin
    // from every head triangle. And the planes must settle nearly every
    // such triangle that brute force finds clear with room to spare.
    let (mut planes, mut well_clear) = (0usize, 0usize);
    walk_past_slabs(211, |at, i, node, _, _| {
        if node.leaf_range().is_none() {
            return true;
        }
        let q = &at.q;
        for t in existing_below(at.scene, i, q.cutoff) {
            let [a, b, c] = [t.v0, t.v1, t.v2].map(|v| to_head(q, v));
            let mid: [f32; 3] = std::array::from_fn(|i| (a[i] + b[i] + c[i]) * (1.0 / 3.0));
            let r = [a, b, c]
                .iter()
                .map(|v| (0..3).map(|i| (v[i] - mid[i]).powi(2)).sum::<f32>().sqrt())
                .fold(0.0f32, f32::max);
            let tm = triangle_margin(q, a, b, c);
            if classify(at.view.head, at.view.grid, mid, r, tm) != 0 {
                continue;
            }
            let settled = hull_clear(at.view.head, at.view.grid, mid, [a, b, c], tm);
            // Brute force in f64: what the query asks of this triangle,
            // and whether every head triangle keeps it (and keeps it with
            // 0.1 mm to spare).
            let (need, near) = at.brute(&t, 0.1);
            if settled {
                at.assert_clear("its plane", &t, need, near);
            }
            if near > need + 0.1 && !at.inside_head(&t) {
                well_clear += 1;
                planes += settled as usize;
            }
        }
        false
    });
    assert!(
        well_clear > 20_000 && planes * 100 >= well_clear * 99,
        "planes settled {planes} of {well_clear} triangles clear by 0.1 mm more than asked"
    );
}
