//! Criterion benchmark of `arm_core::sensitivity::jacobian_batch`, the model and its
//! derivatives that `fit` and `diagnose` evaluate: the example arm, a mount spring in the
//! model, 6 probes (the body and mount springs of the three actuators: 13 solves per pose), at
//! 1e3, 1e4 and 1e5 poses, on the block kernel and through the general path
//! (`jacobian_batch_general`, pose by pose). Run with `cargo bench -p arm_benches --bench
//! jacobian`; see `docs/benchmarks.md`.

use std::hint::black_box;
use std::time::Duration;

use arm_benches::{angles, example_arm, ok, uniform};
use arm_core::sensitivity::{jacobian_batch, jacobian_batch_general, n_channels, Place};
use arm_core::{BatchInput, SolveOptions};
use criterion::{
    criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput,
};

/// Batch sizes (poses per call).
const SIZES: [usize; 3] = [1_000, 10_000, 100_000];

fn bench_jacobian(c: &mut Criterion) {
    let arm = example_arm();
    let model = [(Place { code: 1, index: 1 }, 1.0 / 3000.0)];
    let probes: Vec<Place> = (0..2)
        .flat_map(|code| (0..3).map(move |index| Place { code, index }))
        .collect();
    let opts = SolveOptions::default();
    let ch = n_channels(arm.n());
    for (name, general) in [("block", false), ("general", true)] {
        let mut group = c.benchmark_group(format!("jacobian_6_probes/{name}"));
        group
            .sampling_mode(SamplingMode::Flat)
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(3));
        for rows in SIZES {
            let alpha = angles(rows);
            let mut mass = uniform();
            let payload: Vec<f64> = (0..rows)
                .flat_map(|_| [0.0, -mass(0.0, 7.0) * arm.g])
                .collect();
            let input = BatchInput {
                alpha_deg: &alpha,
                payload_n: &payload,
            };
            let (mut y, mut jac) = (vec![0.0; rows * ch], vec![0.0; rows * ch * probes.len()]);
            let run = if general {
                jacobian_batch_general
            } else {
                jacobian_batch
            };
            // Every pose must solve: a benchmark of error returns would measure nothing.
            ok(
                run(&arm, &model, &probes, input, opts, &mut y, &mut jac),
                "jacobian check",
            );
            assert!(y.iter().chain(&jac).all(|v| v.is_finite()));
            group.throughput(Throughput::Elements(rows as u64));
            group.bench_with_input(BenchmarkId::from_parameter(rows), &input, |b, input| {
                b.iter(|| {
                    let r = run(
                        &arm,
                        &model,
                        &probes,
                        *black_box(input),
                        opts,
                        &mut y,
                        &mut jac,
                    );
                    black_box(r.is_ok())
                });
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench_jacobian);
criterion_main!(benches);
