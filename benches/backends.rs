//! Criterion bench: the backends side by side on a fixed scene (the
//! embedded default job) and a fixed set of tilted poses, at margin 0 and
//! at the planner's default safety margin (0.05 mm).
//! Run: `cargo bench --bench backends`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use maamplan::collide::cpu::CpuBackend;
use maamplan::collide::parry::ParryBackend;
use maamplan::collide::sample::tilted_queries;
use maamplan::collide::Backend;
use maamplan::default_job;
use maamplan::scene::{Scene, SceneConfig};

fn backends(c: &mut Criterion) {
    let job = default_job::job();
    let scene = Scene::build(
        &job.toolpath,
        &job.head,
        &job.platform,
        &SceneConfig::default(),
    )
    .expect("default scene");
    let queries = tilted_queries(&scene.waypoint_queries, 2000, 3);
    let with_margin: Vec<_> = queries
        .iter()
        .map(|q| maamplan::scene::Query { margin: 0.05, ..*q })
        .collect();
    let cpu = CpuBackend::new(&scene);
    let parry = ParryBackend::new(&scene).expect("parry backend");
    let mut g = c.benchmark_group("default_job_2000_poses");
    g.throughput(Throughput::Elements(queries.len() as u64));
    g.sample_size(10);
    let list: [&dyn Backend; 2] = [&cpu, &parry];
    for b in list {
        g.bench_function(b.name(), |bench| {
            bench.iter(|| b.evaluate(&queries).expect("evaluate"))
        });
        g.bench_function(format!("{} margin 0.05", b.name()), |bench| {
            bench.iter(|| b.evaluate(&with_margin).expect("evaluate"))
        });
    }
    g.finish();
}

criterion_group!(benches, backends);
criterion_main!(benches);
