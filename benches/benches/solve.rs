//! Criterion benchmarks of `arm_core::solve_batch` (1e3, 1e4, 1e5 poses; baseline and all six
//! effect kinds at once) and of one pose through `Workspace::solve`, on the example arm of
//! `examples/example_arm.toml`. Run with `cargo bench -p arm_benches`; see `docs/benchmarks.md`.

use std::hint::black_box;
use std::time::Duration;

use arm_benches::{example_arm, ok, six_kinds, uniform, v};
use arm_core::{Arm, BatchBuffers, BatchInput, EffectSet, SolveOptions, Workspace};
use criterion::{
    criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput,
};

/// Batch sizes (poses per call).
const SIZES: [usize; 3] = [1_000, 10_000, 100_000];

/// One effect of each of the six kinds (link 2 bent), with plausible values for the example
/// arm (`arm_benches::six_kinds`).
fn all_effects(arm: &Arm) -> EffectSet {
    ok(EffectSet::new(arm, six_kinds(1)), "effect set")
}

/// `rows` reproducible poses: α ∈ [60, 110] × [0, 30] × [−10, 10] degrees, payload masses
/// 0..7 kg (downward force), from `arm_benches::uniform`.
fn poses(rows: usize, g: f64) -> (Vec<f64>, Vec<f64>) {
    let mut uniform = uniform();
    let mut alpha = Vec::with_capacity(3 * rows);
    let mut payload = Vec::with_capacity(2 * rows);
    for _ in 0..rows {
        alpha.push(uniform(60.0, 110.0));
        alpha.push(uniform(0.0, 30.0));
        alpha.push(uniform(-10.0, 10.0));
        payload.push(0.0);
        payload.push(-uniform(0.0, 7.0) * g);
    }
    (alpha, payload)
}

fn bench_batch(c: &mut Criterion) {
    let arm = example_arm();
    let models = [
        ("baseline", EffectSet::empty()),
        ("all_effects", all_effects(&arm)),
    ];
    let opts = SolveOptions::default();
    eprintln!(
        "arm_benches: {} hardware threads, RAYON_NUM_THREADS={}",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| "unset".into()),
    );
    for (name, effects) in &models {
        let mut group = c.benchmark_group(format!("solve_batch/{name}"));
        group
            .sampling_mode(SamplingMode::Flat)
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(3));
        for rows in SIZES {
            let (alpha, payload) = poses(rows, arm.g);
            let input = BatchInput {
                alpha_deg: &alpha,
                payload_n: &payload,
            };
            // Output buffers allocated once per size and reused by every iteration.
            let mut buf = BatchBuffers::new(rows, arm.n());
            // Every pose must solve: a benchmark of error returns would measure nothing.
            ok(
                arm_core::solve_batch(&arm, effects, input, opts, buf.out()),
                "batch check",
            );
            assert!(buf.dy_mm.iter().all(|d| d.is_finite()));
            group.throughput(Throughput::Elements(rows as u64));
            group.bench_with_input(BenchmarkId::from_parameter(rows), &input, |b, input| {
                b.iter(|| {
                    let r =
                        arm_core::solve_batch(&arm, effects, *black_box(input), opts, buf.out());
                    black_box(r.is_ok())
                });
            });
        }
        group.finish();
    }
}

fn bench_single(c: &mut Criterion) {
    let arm = example_arm();
    let models = [
        ("baseline", EffectSet::empty()),
        ("all_effects", all_effects(&arm)),
    ];
    let opts = SolveOptions::default();
    let alpha = [90f64.to_radians(), 10f64.to_radians(), 0.0];
    let payload = v(0.0, -5.0 * arm.g);
    let mut group = c.benchmark_group("workspace_solve");
    group
        .sample_size(50)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .throughput(Throughput::Elements(1));
    for (name, effects) in &models {
        let mut ws = Workspace::new(&arm);
        ok(
            ws.solve(&arm, effects, &alpha, payload, opts, 0),
            "single-pose check",
        );
        group.bench_function(*name, |b| {
            b.iter(|| {
                let r = ws.solve(
                    &arm,
                    effects,
                    black_box(&alpha),
                    black_box(payload),
                    opts,
                    0,
                );
                black_box(r.is_ok());
                black_box(ws.dmeasure)
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench_batch, bench_single);
criterion_main!(benches);
