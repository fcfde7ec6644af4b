//! Criterion bench: the whole planner on the embedded default job (cpu
//! backend). Run: `cargo bench --bench planner`. simple_curve's wall time
//! per stage is in BENCHMARKS.md (`maamplan plan` writes it to report.json).

use criterion::{criterion_group, criterion_main, Criterion};
use maamplan::collide::cpu::CpuBackend;
use maamplan::default_job;
use maamplan::kinematics::Machine;
use maamplan::plan::{plan, PlanOptions};

fn planner(c: &mut Criterion) {
    let job = default_job::job();
    let scene = default_job::scene();
    let cpu = CpuBackend::new(&scene);
    let machine = Machine::default();
    let mut g = c.benchmark_group("planner");
    g.sample_size(10);
    g.bench_function("default_job", |b| {
        b.iter(|| {
            plan(
                &scene,
                &job.toolpath,
                &machine,
                &cpu,
                &PlanOptions::default(),
                &mut |_| {},
            )
            .expect("plan")
        })
    });
    g.finish();
}

criterion_group!(benches, planner);
criterion_main!(benches);
