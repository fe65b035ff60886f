//! Criterion benchmarks of `arm_core::compensate_batch` (1e3, 1e4, 1e5 poses) on the example
//! arm of `examples/example_arm.toml`: the baseline model and five effects (compliances,
//! bending, base tilt, a clearance taken up), with the default Jacobian (quasi-Newton for this
//! 3-link arm) and with finite differences; and, on one thread, 1000 poses through
//! `Compensator::compensate` against 1000 model solves. Run with
//! `cargo bench -p arm_benches --bench compensate`; see `docs/benchmarks.md`.

use std::hint::black_box;
use std::time::Duration;

use arm_benches::{example_arm, ok, uniform};
use arm_core::effects::{
    ActuatorCompliance, BaseCompliance, JointClearance, LinkBending, MountCompliance, Unloaded,
};
use arm_core::{
    Arm, BatchInput, CompensateBuffers, CompensateOptions, Compensator, Effect, EffectSet,
    JacobianKind, SolveOptions, Workspace, V2,
};
use criterion::{
    criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput,
};

/// Batch sizes (poses per call).
const SIZES: [usize; 3] = [1_000, 10_000, 100_000];

/// One effect of each elastic kind and a joint clearance taken up by the self-weight, with
/// plausible values for the example arm (a centred play would flip side between steps at
/// the poses whose actuator force changes sign: a benchmark of statuses, not of speed).
fn effects(arm: &Arm) -> EffectSet {
    ok(
        EffectSet::new(
            arm,
            vec![
                Effect::ActuatorCompliance(ActuatorCompliance {
                    actuator: 0,
                    stiffness: 1500.0,
                }),
                Effect::MountCompliance(MountCompliance {
                    actuator: 1,
                    stiffness: 4000.0,
                }),
                Effect::JointClearance(JointClearance {
                    joint: 2,
                    clearance: 0.15,
                    unloaded: Unloaded::TakenUp,
                }),
                Effect::LinkBending(LinkBending {
                    link: 1,
                    ei: 2.0e10,
                }),
                Effect::BaseCompliance(BaseCompliance { stiffness: 5.0e8 }),
            ],
        ),
        "effect set",
    )
}

/// `rows` reproducible poses: α ∈ [60, 110] × [0, 30] × [−10, 10] degrees, payload masses
/// 0..7 kg (downward force), from `arm_benches::uniform` (the poses of the solve benchmark).
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
    let auto = CompensateOptions::default();
    let fd = CompensateOptions {
        jacobian: JacobianKind::FiniteDifference,
        ..auto
    };
    let cases = [
        ("baseline", EffectSet::empty(), auto),
        ("effects", effects(&arm), auto),
        ("effects_finite_difference", effects(&arm), fd),
    ];
    eprintln!(
        "arm_benches: {} hardware threads, RAYON_NUM_THREADS={}",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| "unset".into()),
    );
    for (name, effects, opts) in &cases {
        let mut group = c.benchmark_group(format!("compensate_batch/{name}"));
        group
            .sampling_mode(SamplingMode::Flat)
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(4));
        for rows in SIZES {
            let (alpha, payload) = poses(rows, arm.g);
            let input = BatchInput {
                alpha_deg: &alpha,
                payload_n: &payload,
            };
            let mut buf = CompensateBuffers::new(rows, arm.n());
            ok(
                arm_core::compensate_batch(&arm, effects, input, *opts, buf.out()),
                "batch check",
            );
            let good = buf.status.iter().filter(|s| **s == 0).count();
            let mut steps: Vec<u32> = buf.iterations.clone();
            steps.sort_unstable();
            eprintln!(
                "compensate_batch/{name}/{rows}: {good} of {rows} ok, statuses {:?}, steps median \
                 {} / 99 % {} / max {}",
                (0..4)
                    .map(|c| buf.status.iter().filter(|s| **s == c).count())
                    .collect::<Vec<_>>(),
                steps[rows / 2],
                steps[rows * 99 / 100],
                steps[rows - 1],
            );
            group.throughput(Throughput::Elements(rows as u64));
            group.bench_with_input(BenchmarkId::from_parameter(rows), &input, |b, input| {
                b.iter(|| {
                    let r = arm_core::compensate_batch(
                        &arm,
                        effects,
                        *black_box(input),
                        *opts,
                        buf.out(),
                    );
                    black_box(r.is_ok())
                });
            });
        }
        group.finish();
    }
}

/// One thread, pose after pose through `Compensator::compensate` (1000 poses per iteration):
/// the per-pose cost without the batch's parallelism, next to one `Workspace::solve`.
fn bench_one_thread(c: &mut Criterion) {
    let arm = example_arm();
    let eff = effects(&arm);
    let (alpha, payload) = poses(1000, arm.g);
    let rad: Vec<f64> = alpha.iter().map(|d| d.to_radians()).collect();
    let mut group = c.benchmark_group("one_thread");
    group
        .sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .throughput(Throughput::Elements(1000));
    let opts = CompensateOptions::default();
    let mut comp = Compensator::new(&arm);
    group.bench_function("compensate_1000_poses", |b| {
        b.iter(|| {
            for k in 0..1000 {
                let p = V2::new(payload[2 * k], payload[2 * k + 1]);
                let r = comp.compensate(&arm, &eff, black_box(&rad[3 * k..3 * k + 3]), p, &opts, k);
                black_box(r.is_ok());
            }
        });
    });
    let mut ws = Workspace::new(&arm);
    group.bench_function("solve_1000_poses", |b| {
        b.iter(|| {
            for k in 0..1000 {
                let p = V2::new(payload[2 * k], payload[2 * k + 1]);
                let r = ws.solve(
                    &arm,
                    &eff,
                    black_box(&rad[3 * k..3 * k + 3]),
                    p,
                    SolveOptions::default(),
                    k,
                );
                black_box(r.is_ok());
            }
        });
    });
    group.finish();
}

criterion_group!(benches, bench_batch, bench_one_thread);
criterion_main!(benches);
