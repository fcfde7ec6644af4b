//! GPU backend tests. They run on whatever Vulkan adapter is present —
//! lavapipe in CI, where `.ci/run` sets MAAMPLAN_REQUIRE_GPU=1 so a missing
//! adapter fails. Elsewhere, without a Vulkan driver, they skip saying why.

mod common;

use common::*;
use maamplan::collide::brute::BruteBackend;
use maamplan::collide::cpu::{expand, reduce, CpuBackend};
use maamplan::collide::gpu::moves::{gpu_motion, gpu_move};
use maamplan::collide::gpu::wire::RESULT_HIT;
use maamplan::collide::gpu::{GpuBackend, GpuContext, GpuOptions};
use maamplan::collide::moves::SampledMove;
use maamplan::collide::sample::tilted_queries;
use maamplan::collide::Backend;
use maamplan::default_job::box_mesh;
use maamplan::kinematics::Machine;
use maamplan::scene::{GpuQuery, Query, Scene, SceneConfig};

/// The GPU backend over `scene`, or `None` (skip) when no adapter exists
/// and the environment does not require one.
fn gpu(scene: &Scene, opts: GpuOptions) -> Option<GpuBackend> {
    context().map(|ctx| GpuBackend::new(ctx, scene, opts).expect("GPU backend"))
}

/// An opened GPU, or `None` (skip) as for [`gpu`].
fn context() -> Option<GpuContext> {
    let ctx = GpuContext::open(false).expect("opening the GPU");
    if ctx.is_none() {
        if std::env::var("MAAMPLAN_REQUIRE_GPU").is_ok_and(|v| v == "1") {
            panic!("MAAMPLAN_REQUIRE_GPU=1 but no GPU adapter found: install mesa-vulkan-drivers");
        }
        eprintln!("skipping: no Vulkan adapter (install mesa-vulkan-drivers for lavapipe)");
    }
    ctx
}

/// Fails naming how many `what` differ and the first ten, if any do.
fn assert_none_differ<T: std::fmt::Debug>(what: &str, differ: &[T]) {
    assert!(
        differ.is_empty(),
        "{what}: {} differ: {:?}",
        differ.len(),
        &differ[..differ.len().min(10)]
    );
}

/// Default options but for `batch` queries a dispatch.
fn batches_of(batch: usize) -> GpuOptions {
    GpuOptions {
        batch: Some(batch),
        ..GpuOptions::default()
    }
}

/// `base` at each margin of [`MARGINS`] and each sloped one of
/// [`SLOPED`], with what to call each set in messages.
fn at_every_margin(base: &[Query], what: &str) -> Vec<(Vec<Query>, String)> {
    let margins = MARGINS.map(|m| (m, 0.0)).into_iter().chain(SLOPED);
    margins
        .map(|(margin, slope)| {
            let queries = with_slope(base, margin, slope);
            (queries, format!("{what}, margin {margin} + {slope} per mm"))
        })
        .collect()
}

/// GPU and CPU verdicts agree, except near-contacts (the head's surface
/// within 1e-3 mm of the query's margin; listed).
fn agree(scene: &Scene, queries: &[Query], gpu: &GpuBackend, what: &str) -> usize {
    agree_with(scene, queries, gpu, what).0
}

/// As [`agree`]; also returns the GPU's verdicts.
fn agree_with(
    scene: &Scene,
    queries: &[Query],
    gpu: &GpuBackend,
    what: &str,
) -> (usize, Vec<bool>) {
    let cpu = CpuBackend::new(scene).evaluate(queries).unwrap();
    let got = gpu.evaluate(queries).unwrap();
    assert_eq!(got.len(), queries.len());
    near_contacts_only(scene, queries, &cpu, &got, &format!("{what}, gpu vs cpu"));
    (cpu.iter().filter(|&&c| c).count(), got)
}

#[test]
fn random_scenes_gpu_matches_cpu_and_brute_force() {
    for seed in 0..4u64 {
        let mut r = rng(100 + seed);
        let scene = star_scene(&mut r, 9, 2.5, [1.0, 0.5]);
        // Small bindings split the part: triangles over 4 bindings, nodes over 2.
        let cap = ((scene.part_tris.len() * 48) as u64 / 3 + 48)
            .max((scene.part_nodes.len() * 32) as u64 * 2 / 3 + 32);
        let Some(g) = gpu(
            &scene,
            GpuOptions {
                max_binding_bytes: Some(cap),
                batch: Some(256),
                ..GpuOptions::default()
            },
        ) else {
            return;
        };
        let base = random_queries(&mut r, &scene, 500);
        for (queries, what) in at_every_margin(&base, &format!("seed {seed}")) {
            let (hits, got) = agree_with(&scene, &queries, &g, &what);
            let brute = BruteBackend::new(&scene).evaluate(&queries).unwrap();
            let near = near_contacts_only(
                &scene,
                &queries,
                &brute,
                &got,
                &format!("{what}, gpu vs brute force"),
            );
            assert!(
                near * 100 <= queries.len(),
                "{what}: too many near-contacts"
            );
            eprintln!("{what}: {hits} colliding");
            assert!(hits > 20 && hits < 480, "{what}: {hits} colliding");
        }
    }
}

/// Scenes modelled from beads (no layer surfaces; bead walls kept out of
/// the slab normals) give the GPU the CPU's verdicts, margin by margin.
#[test]
fn bead_scenes_gpu_matches_cpu() {
    use maamplan::default_job::cone_head;
    use maamplan::scene::beads::BeadSettings;
    use maamplan::scene::{HeadConfig, PartModel, PartSource};
    for seed in 0..2u64 {
        let mut r = rng(140 + seed);
        let part = printed_part(&mut r, 3, 0.5, 0.7, 30.0 * seed as f64);
        let cfg = SceneConfig {
            head: HeadConfig {
                tip_clearance: 0.2,
                grid_resolution: 48,
            },
            head_cache: false,
            part: PartModel::Beads,
            beads: BeadSettings::new(0.7, 0.5, 5.0),
            ..SceneConfig::default()
        };
        let head = cone_head(4.0, 5.0, 14.0, 16);
        let scene = Scene::build(&part.toolpath, &head, &part.platform, &cfg).unwrap();
        assert_eq!(scene.part, PartSource::Beads);
        let Some(g) = gpu(&scene, batches_of(128)) else {
            return;
        };
        let base = random_queries(&mut r, &scene, 400);
        for (queries, what) in at_every_margin(&base, &format!("beads, seed {seed}")) {
            let hits = agree(&scene, &queries, &g, &what);
            assert!(
                hits > 20 && hits + 20 < queries.len(),
                "{what}: {hits} colliding"
            );
        }
    }
}

#[test]
fn gpu_verdicts_flip_at_each_poses_own_distance() {
    let mut r = rng(120);
    let scene = star_scene(&mut r, 11, 3.0, [-1.0, 0.8]);
    let Some(g) = gpu(&scene, GpuOptions::default()) else {
        return;
    };
    let base = random_queries(&mut r, &scene, 300);
    let (queries, expected) = margin_boundary_queries(&scene, &base, 1.5);
    assert!(queries.len() > 100, "{} queries", queries.len());
    let got = g.evaluate(&queries).unwrap();
    let wrong: Vec<_> = (0..queries.len())
        .filter(|&i| got[i] != expected[i])
        .map(|i| (i, queries[i].margin, expected[i]))
        .collect();
    assert!(wrong.is_empty(), "{wrong:?}");
}

#[test]
fn margins_decide_flat_and_edge_to_edge_approaches_on_the_gpu() {
    for case in margin_cases() {
        let Some(g) = gpu(&case.scene, GpuOptions::default()) else {
            return;
        };
        assert_eq!(
            g.evaluate(&case.queries).unwrap(),
            case.expected,
            "{}",
            case.what
        );
        let bad = [Query {
            margin: -0.01,
            ..case.queries[0]
        }];
        assert!(matches!(
            g.evaluate(&bad),
            Err(maamplan::collide::CollideError::BadMargin(0))
        ));
    }
}

#[test]
fn simple_curve_every_waypoint_and_100k_tilted_poses() {
    let (_, scene) = simple_curve();
    // One batch for the 100,000 tilted poses, as on a hardware adapter:
    // past 65,535 queries the candidate list holds fewer than 64 a query
    // (the exact dispatch's limit), which full lists and resumed walks
    // make up for.
    let Some(g) = gpu(&scene, batches_of(131_072)) else {
        return;
    };
    assert_eq!(g.batch_size(), 131_072);
    let own = agree(
        &scene,
        &scene.waypoint_queries,
        &g,
        "simple_curve own poses",
    );
    assert!(own < 50);
    let tilted = tilted_queries(&scene.waypoint_queries, 100_000, 3);
    assert!(tilted.len() >= 100_000);
    let at_zero = agree(&scene, &tilted, &g, "simple_curve tilted");
    // The planner's default margin on a slice of the same poses.
    let slice = with_margin(&tilted[..20_000], 0.05);
    let at_margin = agree(&scene, &slice, &g, "simple_curve tilted, margin 0.05");
    assert!(at_margin > 0 && at_zero > 0);
}

#[test]
fn callers_on_two_threads_get_their_own_verdicts() {
    // The planner measures the input on one thread while it plans on
    // another, both through one backend: each call's verdicts must be its
    // own, in its own order, whatever the other call does meanwhile.
    let (_, scene) = simple_curve();
    let Some(g) = gpu(&scene, batches_of(1024)) else {
        return;
    };
    let tilted = tilted_queries(&scene.waypoint_queries, 20_000, 5);
    let (a, b) = (&scene.waypoint_queries[..], &with_margin(&tilted, 0.05)[..]);
    let (alone_a, alone_b) = (g.evaluate(a).unwrap(), g.evaluate(b).unwrap());
    assert!(alone_a != alone_b[..alone_a.len().min(alone_b.len())]);
    for _ in 0..3 {
        let (side_a, side_b) = std::thread::scope(|t| {
            let ja = t.spawn(|| g.evaluate(a).unwrap());
            let jb = t.spawn(|| g.evaluate(b).unwrap());
            (ja.join().unwrap(), jb.join().unwrap())
        });
        assert!(
            side_a == alone_a,
            "the waypoints' verdicts changed beside another call"
        );
        assert!(
            side_b == alone_b,
            "the tilted poses' verdicts changed beside another call"
        );
    }
}

#[test]
fn synthetic_part_larger_than_one_binding() {
    // 3.1 million layer triangles: 150 MB of triangles, more than lavapipe's
    // 128 MiB storage binding, so the part is split across bindings. The
    // adapter first: the scene takes a while to build.
    let Some(ctx) = context() else {
        return;
    };
    let mut r = rng(7);
    let mut tp = maamplan::toolpath::Toolpath::default();
    for k in 0..8 {
        let z0 = 1.0 + 0.5 * k as f32;
        let f = move |x: f32, y: f32| z0 + 0.8 * (0.15 * x).sin() * (0.11 * y).cos();
        let surface = height_patch([-60.0, 60.0], [-40.0, 40.0], 440, f);
        let waypoints: Vec<_> = (0..400)
            .map(|i| {
                let (x, y) = (-55.0 + (i % 20) as f32 * 5.5, -35.0 + (i / 20) as f32 * 3.5);
                maamplan::toolpath::Waypoint {
                    pos: [x, y, f(x, y)],
                    dir: [0.0, 0.0, 1.0],
                }
            })
            .collect();
        tp.layers.push(maamplan::toolpath::Layer {
            name: k.to_string(),
            waypoints,
            surface: Some(surface),
        });
    }
    let head = maamplan::default_job::cone_head(10.0, 10.0, 15.0, 32);
    let platform = box_mesh([-80.0, -60.0, -3.0], [80.0, 60.0, 0.0]);
    let scene = Scene::build(&tp, &head, &platform, &SceneConfig::default()).unwrap();
    assert!(
        scene.part_tris.len() >= 3_000_000,
        "{} triangles",
        scene.part_tris.len()
    );
    let options = GpuOptions {
        max_binding_bytes: Some(128 << 20),
        ..GpuOptions::default()
    };
    let g = GpuBackend::new(ctx, &scene, options).expect("GPU backend");
    assert!(
        g.bindings_used.1 >= 2,
        "triangles in {} binding(s)",
        g.bindings_used.1
    );
    let mut queries = tilted_queries(&scene.waypoint_queries, 3000, 3);
    queries.extend(random_queries(&mut r, &scene, 1000));
    let hits = agree(&scene, &queries, &g, "synthetic 3M");
    assert!(
        hits > 100 && hits < queries.len() - 100,
        "{hits} colliding of {}",
        queries.len()
    );
}

#[test]
fn plans_are_byte_identical_on_gpu_and_cpu() {
    use maamplan::io::gcode::{write_gcode, GcodeHeader};
    use maamplan::plan::{plan, PlanOptions};
    let (job, scene) = default_scene();
    let Some(g) = gpu(&scene, GpuOptions::default()) else {
        return;
    };
    let m = Machine::default();
    let run = |b: &dyn Backend| {
        let p = plan(
            &scene,
            &job.toolpath,
            &m,
            b,
            &PlanOptions::default(),
            &mut |_| {},
        )
        .unwrap();
        write_gcode(&m, &p.program, &GcodeHeader::default())
    };
    let on_gpu = run(&g);
    let on_cpu = run(&CpuBackend::new(&scene));
    assert!(
        on_gpu == on_cpu,
        "the G-code differs between the gpu and cpu backends"
    );
}

#[test]
fn simulate_gives_the_same_verdicts_on_gpu_and_cpu() {
    use maamplan::io::gcode::read_program;
    use maamplan::plan::PlanOptions;
    use maamplan::simulate;
    let job = simple_curve_job();
    let m = Machine::default();
    let text =
        std::fs::read_to_string(data().join("reference_gcode/simple_curve_Gcode.txt")).unwrap();
    let moves = read_program(&text, &m).unwrap();
    let timeline = simulate::timeline(&m, &job.toolpath, &moves);
    let mut scene = job.scene;
    scene.restamp(|s| timeline.stamp(s));
    let Some(g) = gpu(&scene, GpuOptions::default()) else {
        return;
    };
    // The lines around the reference's colliding swing at line 25844, with
    // the material the whole program printed before them.
    let a = moves.iter().position(|mv| mv.line >= 25_000).unwrap();
    let b = moves.iter().position(|mv| mv.line >= 26_500).unwrap();
    let run = |backend: &dyn Backend| {
        simulate::check_moves(
            &m,
            backend,
            &scene,
            m.margin,
            PlanOptions::default().edge_step,
            &moves[a..b],
            &timeline.cutoffs[a..b],
            None,
        )
        .unwrap()
        .0
    };
    let on_gpu = run(&g);
    let on_cpu = run(&CpuBackend::new(&scene));
    assert_eq!(on_gpu, on_cpu, "line verdicts differ between gpu and cpu");
    let hits = on_cpu.iter().filter(|v| **v == Some(true)).count();
    assert!(hits >= 2, "{hits} colliding lines");
}

/// The scene and queries of the resumed-walk tests: sloped margins over
/// a random scene, in batches of 256.
fn resume_case() -> (Scene, Vec<Query>) {
    let mut r = rng(130);
    let scene = star_scene(&mut r, 9, 2.5, [0.6, -0.4]);
    let base = random_queries(&mut r, &scene, 600);
    (scene, with_slope(&base, 0.05, 0.02))
}

/// Batches of 256 with a candidate list of `capacity` slots, each query
/// handing over at most `per_query` pairs a pass.
fn listed(capacity: u32, per_query: u32) -> GpuOptions {
    GpuOptions {
        batch: Some(256),
        capacity: Some(capacity),
        per_query: Some(per_query),
        ..GpuOptions::default()
    }
}

/// A list large enough for every pair of every walk at once.
const ROOMY: u32 = 1 << 20;

/// Queries that hand over only two pairs a pass resume their walks for
/// the next two: the verdicts are the roomy list's, the list never fills,
/// and fewer pairs are tested (a colliding query's first pairs mostly
/// settle it).
#[test]
fn a_few_pairs_a_pass_resume_the_walks_and_keep_the_verdicts() {
    let (scene, queries) = resume_case();
    let (Some(roomy), Some(few)) = (
        gpu(&scene, listed(ROOMY, u32::MAX)),
        gpu(&scene, listed(ROOMY, 2)),
    ) else {
        return;
    };
    assert!(
        few.evaluate(&queries).unwrap() == roomy.evaluate(&queries).unwrap(),
        "two pairs a pass changed verdicts"
    );
    let fs = few.stats();
    eprintln!("{fs}");
    assert!(fs.full_lists == 0 && fs.resumed_queries > 0, "{fs}");
    assert!(fs.candidates < roomy.stats().candidates, "{fs}");
}

/// A batch whose candidate list fills resumes the walks that have pairs
/// left, each from the pair after the last it handed over: the verdicts
/// are the roomy list's (and the cpu's), no batch is submitted twice, and
/// no pair is tested twice (no more exact tests than the roomy list, which
/// takes them all).
#[test]
fn full_candidate_lists_resume_the_walks_and_redo_nothing() {
    let (scene, queries) = resume_case();
    let (Some(roomy), Some(tight)) = (
        gpu(&scene, listed(ROOMY, u32::MAX)),
        gpu(&scene, listed(16, u32::MAX)),
    ) else {
        return;
    };
    let want = roomy.evaluate(&queries).unwrap();
    let got = tight.evaluate(&queries).unwrap();
    assert!(got == want, "a full list changed verdicts");
    let cpu = CpuBackend::new(&scene).evaluate(&queries).unwrap();
    near_contacts_only(&scene, &queries, &cpu, &got, "full lists, gpu vs cpu");
    let (rs, ts) = (roomy.stats(), tight.stats());
    eprintln!("{rs}\n{ts}");
    assert_eq!((rs.full_lists, rs.resumed_passes), (0, 0), "{rs}");
    assert!(ts.full_lists > 0 && ts.resumed_queries > 0, "{ts}");
    assert_eq!(
        (ts.batches, ts.queries),
        (rs.batches, rs.queries),
        "a batch was redone"
    );
    assert!(
        ts.candidates <= rs.candidates,
        "pairs tested twice: {ts} / {rs}"
    );
    assert!(ts.candidates > 16 * ts.batches, "{ts}");
}

/// The same with each walk kernel besides the default (persistent lanes
/// where the adapter has subgroups): one query an invocation, and
/// persistent lanes with subgroup appends.
#[test]
fn full_candidate_lists_resume_the_walks_of_every_walk_kernel() {
    let (scene, queries) = resume_case();
    let Some(roomy) = gpu(&scene, listed(ROOMY, u32::MAX)) else {
        return;
    };
    let want = roomy.evaluate(&queries).unwrap();
    for (subgroups, appends) in [(false, false), (true, true)] {
        let Some(other) = gpu(
            &scene,
            GpuOptions {
                subgroups: Some(subgroups),
                subgroup_appends: Some(appends),
                ..listed(16, u32::MAX)
            },
        ) else {
            return;
        };
        assert!(
            other.evaluate(&queries).unwrap() == want,
            "a full list changed verdicts (subgroups {}, subgroup appends {})",
            other.tuning().subgroups,
            other.tuning().subgroup_appends
        );
        let os = other.stats();
        assert!(
            os.full_lists > 0 && os.candidates <= roomy.stats().candidates,
            "{os}"
        );
    }
}

/// Random scenes at every margin and slope, and simple_curve's tilted
/// poses: what `collide_traverse` hands over per query (hit, and its
/// undecided triangles in walk order) is what its mirror
/// `collide::cpu::traverse::walk` lists, query by query.
#[test]
fn the_walk_kernel_lists_what_its_cpu_mirror_lists() {
    use maamplan::collide::cpu::{traverse, SceneView};
    let mut cases: Vec<(Scene, Vec<Query>, String)> = Vec::new();
    for seed in 0..3u64 {
        let mut r = rng(140 + seed);
        let scene = star_scene(&mut r, 9, 2.5, [1.0, -0.5]);
        let base = random_queries(&mut r, &scene, 400);
        let mut queries = Vec::new();
        for (margin, slope) in MARGINS.map(|m| (m, 0.0)).into_iter().chain(SLOPED) {
            queries.extend(with_slope(&base, margin, slope));
        }
        cases.push((scene, queries, format!("seed {seed}")));
    }
    let (_, sc) = simple_curve();
    let tilted = tilted_queries(&sc.waypoint_queries, 4_000, 11);
    let mut queries = with_margin(&tilted, 0.05);
    queries.extend(with_slope(&tilted, 0.05, 0.02));
    cases.push((sc, queries, "simple_curve tilted".into()));
    // Every entry point and way of appending: one query an invocation
    // with one atomic per pair, and (where the adapter has subgroups, as
    // lavapipe does) persistent lanes with one atomic per pair or per
    // subgroup.
    let kernels = [
        (false, false, "one query an invocation"),
        (true, false, "persistent lanes"),
        (true, true, "persistent lanes, subgroup appends"),
    ];
    for ((scene, queries, what), (subgroups, appends, kernel)) in cases
        .iter()
        .flat_map(|c| kernels.iter().map(move |k| (c, *k)))
    {
        let Some(g) = gpu(
            scene,
            GpuOptions {
                batch: Some(4096),
                capacity: Some(1 << 22),
                subgroups: Some(subgroups),
                subgroup_appends: Some(appends),
                ..GpuOptions::default()
            },
        ) else {
            return;
        };
        let offered = g.adapter().subgroups;
        assert_eq!(
            (g.tuning().subgroups, g.tuning().subgroup_appends),
            (subgroups && offered, appends && subgroups && offered),
            "{kernel} asked"
        );
        let what = format!("{what}, {kernel} (subgroups offered: {offered})");
        let view = SceneView::new(scene);
        let (mut pairs, mut hits, mut differ) = (0, 0, Vec::new());
        for chunk in queries.chunks(4096) {
            let got = g.walks(chunk).unwrap();
            for (q, w) in chunk.iter().zip(got) {
                let want = traverse::walk(&view, &q.to_gpu());
                pairs += want.candidates.len();
                hits += want.hit as usize;
                if w != want {
                    differ.push((
                        q.margin,
                        want.hit,
                        w.hit,
                        want.candidates.len(),
                        w.candidates.len(),
                    ));
                }
            }
        }
        eprintln!(
            "{what}: {} queries, {hits} hit by the walk, {pairs} pairs",
            queries.len()
        );
        assert_none_differ(&format!("{what}: walks"), &differ);
        assert!(
            hits > 0 && pairs > queries.len(),
            "{what}: a walk with nothing to compare"
        );
    }
}

/// The pairs those walks hand over, each through `collide_exact` alone
/// and through its mirror `collide::cpu::exact::pair_hits`: the same
/// verdict, pair by pair, at every margin (crossing, nearness within the
/// margin, and containment all occur).
#[test]
fn the_exact_kernel_decides_each_pair_as_its_cpu_mirror_does() {
    use maamplan::collide::cpu::{exact, traverse, SceneView};
    for seed in 0..3u64 {
        let mut r = rng(150 + seed);
        let scene = star_scene(&mut r, 9, 2.5, [-0.7, 0.9]);
        let view = SceneView::new(&scene);
        let base = random_queries(&mut r, &scene, 300);
        let mut pairs: Vec<(Query, u32)> = Vec::new();
        for (margin, slope) in MARGINS.map(|m| (m, 0.0)).into_iter().chain(SLOPED) {
            for q in with_slope(&base, margin, slope) {
                let w = traverse::walk(&view, &q.to_gpu());
                pairs.extend(w.candidates.iter().map(|&t| (q, t)));
            }
        }
        let Some(g) = gpu(
            &scene,
            GpuOptions {
                batch: Some(8192),
                capacity: Some(8192),
                ..GpuOptions::default()
            },
        ) else {
            return;
        };
        let mut differ = Vec::new();
        let mut hits = 0;
        for chunk in pairs.chunks(8192) {
            let got = g.exact_pairs(chunk).unwrap();
            for ((q, t), h) in chunk.iter().zip(got) {
                let want = exact::pair_hits(&view, &q.to_gpu(), *t);
                hits += want as usize;
                if h != want {
                    differ.push((q.margin, q.slope, *t, want));
                }
            }
        }
        eprintln!("seed {seed}: {} pairs, {hits} hit", pairs.len());
        assert_none_differ(&format!("seed {seed}: pairs"), &differ);
        assert!(
            hits > 0 && hits < pairs.len(),
            "seed {seed}: {hits} of {} pairs hit",
            pairs.len()
        );
    }
}

/// Random moves over a random scene, for every Table I configuration,
/// both rotary pairs and both interpolations (joint-linear and the tip
/// straight), with a gpu backend whose batches are small enough that
/// several are in flight and whose lists fill.
struct MoveCase {
    scene: Scene,
    g: GpuBackend,
    /// Per machine: its name and its moves.
    machines: Vec<(Machine, String, Vec<SampledMove>)>,
}

/// The [`MoveCase`], or `None` (skip) without an adapter.
fn move_case() -> Option<MoveCase> {
    use maamplan::kinematics::post::Dialect;
    use maamplan::kinematics::{Configuration, Rotary};
    let mut r = rng(160);
    let scene = star_scene(&mut r, 9, 2.5, [0.4, 0.7]);
    let g = gpu(
        &scene,
        GpuOptions {
            batch: Some(512),
            capacity: Some(256),
            per_query: Some(4),
            ..GpuOptions::default()
        },
    )?;
    let mut machines = Vec::new();
    for configuration in [Configuration::I, Configuration::II, Configuration::III] {
        for rotary in [Rotary::BC, Rotary::AC] {
            for dialect in [Dialect::Joint, Dialect::G43_4] {
                let mut m = Machine {
                    configuration,
                    rotary,
                    d: 35.0,
                    h: 60.0,
                    r: 12.0,
                    ..Machine::default()
                };
                m.post.dialect = dialect;
                let what = format!("{configuration:?} {rotary:?} {dialect:?}");
                let moves = random_moves(&mut r, &m, &scene.waypoint_queries);
                machines.push((m, what, moves));
            }
        }
    }
    Some(MoveCase { scene, g, machines })
}

/// 150 moves of `m` between nearby waypoints `wq`, the nozzle tilted at
/// random, at random margins, cut into 1 to 11 intervals.
fn random_moves(r: &mut rand_chacha::ChaCha8Rng, m: &Machine, wq: &[Query]) -> Vec<SampledMove> {
    use maamplan::kinematics::inverse;
    use rand::Rng;
    (0..150)
        .map(|_| {
            let i = r.random_range(0..wq.len() - 3);
            let j = i + r.random_range(1..3);
            let dir = |r: &mut rand_chacha::ChaCha8Rng| {
                let t = r.random_range(0.0f32..0.6);
                let a = r.random_range(0.0f32..std::f32::consts::TAU);
                [t.sin() * a.cos(), t.sin() * a.sin(), t.cos()]
            };
            let from = inverse(m, wq[i].pose.tip, dir(r))[0];
            let to = inverse(m, wq[j].pose.tip, dir(r))[r.random_range(0..2)];
            SampledMove {
                from,
                to,
                cutoff: wq[i].cutoff,
                margin: MARGINS[r.random_range(0..MARGINS.len())],
                intervals: r.random_range(1..12),
            }
        })
        .collect()
}

/// The samples `collide_expand` poses for `moves`, in slot order.
fn expanded(g: &GpuBackend, m: &Machine, moves: &[SampledMove]) -> Vec<GpuQuery> {
    let mut device = Vec::new();
    for chunk in moves.chunks(50) {
        device.extend(g.expanded(m, chunk).unwrap());
    }
    device
}

/// The samples `collide_expand` poses are its mirror's
/// (`collide::cpu::expand`) to the GPU's `sin`/`cos`, and the `f64`
/// kinematics' (`Machine::pose_along`) to `f32` rounding.
#[test]
fn the_expand_kernel_poses_samples_as_its_mirror_and_the_kinematics_do() {
    let Some(case) = move_case() else {
        return;
    };
    for (m, what, moves) in &case.machines {
        let device = expanded(&case.g, m, moves);
        let motion = gpu_motion(m, moves.len());
        let mut first = 0;
        for mv in moves {
            let gm = gpu_move(mv, first);
            let mirror = expand::samples(&motion, &gm);
            let n = mv.intervals as f64;
            for (k, q) in mirror.iter().enumerate() {
                let exact = Query {
                    pose: m.pose_along(&mv.from, &mv.to, (k + 1) as f64 / n),
                    cutoff: mv.cutoff,
                    margin: mv.margin,
                    slope: 0.0,
                }
                .to_gpu();
                let d = &device[first as usize + k];
                for row in 0..3 {
                    for col in 0..4 {
                        let tol = if col == 3 { 1e-3 } else { 1e-5 };
                        let (a, b, c) = (d.rows[row][col], q.rows[row][col], exact.rows[row][col]);
                        assert!((a - b).abs() <= tol, "{what}: device {a} vs mirror {b}");
                        assert!((b - c).abs() <= tol, "{what}: mirror {b} vs f64 {c}");
                    }
                }
                assert_eq!((d.cutoff, d.margin), (mv.cutoff, mv.margin));
            }
            first += gm.count;
        }
    }
}

/// Each move's verdict (`collide_reduce`) is its mirror's
/// (`collide::cpu::reduce`) over the cpu's verdicts on those very samples.
#[test]
fn the_reduce_kernel_gives_each_move_its_samples_verdict() {
    let Some(case) = move_case() else {
        return;
    };
    let cpu = CpuBackend::new(&case.scene);
    let (mut moved, mut hits) = (0, 0);
    for (m, what, moves) in &case.machines {
        let device = expanded(&case.g, m, moves);
        let got = case.g.sampled_moves(m, moves).unwrap();
        let sample_words: Vec<u32> = cpu
            .evaluate(&device.iter().map(query_of).collect::<Vec<_>>())
            .unwrap()
            .into_iter()
            .map(|h| h as u32 * RESULT_HIT)
            .collect();
        let mut first = 0;
        for (mv, &h) in moves.iter().zip(&got) {
            let gm = gpu_move(mv, first);
            let want = reduce::move_result(&gm, &sample_words) != 0;
            assert_eq!(h, want, "{what}: a move's reduction");
            first += gm.count;
        }
        moved += moves.len();
        hits += got.iter().filter(|&&h| h).count();
    }
    let stats = case.g.stats();
    eprintln!("{moved} moves, {hits} colliding; {stats}");
    assert!(
        hits * 10 > moved && hits * 10 < moved * 9,
        "{hits} of {moved} moves collide"
    );
    assert!(stats.full_lists > 0, "{stats}");
}

/// Against the cpu backend posing the samples in `f64` on the host, moves
/// asked as moves (`Backend::sampled_moves`) differ only where a sample
/// is a near-contact.
#[test]
fn moves_posed_on_the_device_differ_from_the_hosts_only_at_near_contacts() {
    let Some(case) = move_case() else {
        return;
    };
    let cpu = CpuBackend::new(&case.scene);
    let near_sample = |m: &Machine, mv: &SampledMove| {
        let n = mv.intervals as f64;
        (1..mv.intervals)
            .map(|k| {
                let q = Query {
                    pose: m.pose_along(&mv.from, &mv.to, k as f64 / n),
                    cutoff: mv.cutoff,
                    margin: mv.margin,
                    slope: 0.0,
                };
                margin_slack(&case.scene, &q).abs()
            })
            .fold(f64::INFINITY, f64::min)
    };
    let mut near = 0;
    for (m, what, moves) in &case.machines {
        let got = case.g.sampled_moves(m, moves).unwrap();
        let host = cpu.sampled_moves(m, moves).unwrap();
        for (i, mv) in moves
            .iter()
            .enumerate()
            .filter(|(i, _)| host[*i] != got[*i])
        {
            let slack = near_sample(m, mv);
            assert!(
                slack < 1e-3,
                "{what}: move {i} differs {slack} mm from its margin"
            );
            near += 1;
        }
    }
    eprintln!("{near} near-contacts");
}

/// A query from the words the kernels read (rows of the rotation's
/// columns, the tip in the fourth place).
fn query_of(q: &GpuQuery) -> Query {
    let col = |i: usize| [q.rows[i][0], q.rows[i][1], q.rows[i][2]];
    Query {
        pose: maamplan::geometry::Pose {
            cols: [col(0), col(1), col(2)],
            tip: [q.rows[0][3], q.rows[1][3], q.rows[2][3]],
        },
        cutoff: q.cutoff,
        margin: q.margin,
        slope: q.slope,
    }
}

#[test]
fn bench_tuning_flags_change_the_walk_not_its_verdicts() {
    // `bench`'s --gpu-* flags reach the backend (its summary names the
    // tuning: batch, share, kernel and order), and the verdicts stay the
    // cpu's. (That a small share resumes walks is the library's test,
    // `a_few_pairs_a_pass_resume_the_walks_and_keep_the_verdicts`.)
    if context().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    let out = cli(&[
        "bench",
        "--backends",
        "gpu,cpu",
        "--queries",
        "3000",
        "--tilts",
        "5",
        "--gpu-batch",
        "512",
        "--gpu-walk",
        "lane",
        "--gpu-share",
        "2",
        "--gpu-order",
        "off",
        "--json",
        json.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    assert!(
        stdout.contains(
            "[batches of 512, 2 pairs a query a pass, one query an invocation, queries as given]"
        ),
        "{stdout}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let results = report["results"].as_array().unwrap();
    assert_eq!(results[1]["disagreements_with_first"], 0, "{stdout}");
    let summary = results[0]["summary"].as_str().expect("the gpu's summary");
    assert!(summary.contains("queries as given"), "{summary}");
    assert!(results[1]["summary"].is_null(), "{stdout}");
    assert!(results[0]["colliding"].as_u64().unwrap() > 0, "{stdout}");
}
