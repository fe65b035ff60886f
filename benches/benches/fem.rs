//! Criterion benchmarks of the FE model (`arm_core::fem`) on the seed arm with real link
//! sections (a 40 × 40 × 3 mm aluminium box: EI = 7.1e9 N·mm², EA = 3.1e7 N) and a mount
//! compliance at M2, meshed to about 50 and about 150 degrees of freedom:
//!
//! * `fem_pose/<dof>/<solver>`: one whole FE solve of a pose (assembly, factorisation, the
//!   self-weight and payload cases, every output), cycling through a sweep of poses, with
//!   the sparse Cholesky reusing its symbolic analysis (`sparse_reuse`, the default), redoing
//!   it every pose (`sparse_fresh`), and a dense Cholesky of the same matrix (`dense`);
//! * `fem_linear/<dof>/<solver>`: the linear algebra alone, factorisation and a two-column
//!   solve of one assembled K;
//! * `fem_batch/<dof>`: `fem_solve_batch` over 4096 poses (parallel, all threads).
//!
//! Run with `cargo bench -p arm_benches --bench fem`; see `docs/benchmarks.md`.

use std::hint::black_box;
use std::time::Duration;

use arm_benches::{ok, uniform, v};
use arm_core::effects::MountCompliance;
use arm_core::examples::seed2022_arm;
use arm_core::fem::solve::Numeric;
use arm_core::fem::{
    fem_solve_batch, FemBatchBuffers, FemModel, FemOptions, FemWorkspace, LinearSolver, LinkSection,
};
use arm_core::{Arm, BatchInput, Effect, EffectSet, SolveOptions};
use criterion::{
    criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput,
};

/// A 40 × 40 × 3 mm aluminium box section on every link.
const SECTIONS: [LinkSection; 3] = [LinkSection {
    ei: Some(7.1e9),
    ea: Some(3.1e7),
}; 3];

fn effects(arm: &Arm) -> EffectSet {
    ok(
        EffectSet::new(
            arm,
            vec![Effect::MountCompliance(MountCompliance {
                actuator: 1,
                stiffness: 2000.0,
            })],
        ),
        "effects",
    )
}

/// The model whose DOF count is nearest `target`, solved by `solver`.
fn model(arm: &Arm, target: usize, solver: LinearSolver) -> FemModel {
    let build = |m: usize| {
        let opts = FemOptions {
            elements_per_link: m,
            moment_samples: 21,
            solver,
        };
        ok(FemModel::new(arm, &effects(arm), &SECTIONS, opts), "model")
    };
    let best = (1..80)
        .min_by_key(|&m| build(m).n_dof().abs_diff(target))
        .unwrap_or(1);
    build(best)
}

/// `rows` poses around the seed's five configurations (degrees) and payloads 0–7 kg (N).
fn poses(rows: usize) -> (Vec<f64>, Vec<f64>) {
    let mut uniform = uniform();
    let mut alpha = Vec::with_capacity(3 * rows);
    let mut payload = Vec::with_capacity(2 * rows);
    for _ in 0..rows {
        alpha.extend([uniform(58.0, 116.0), uniform(5.0, 16.0), uniform(-2.0, 2.0)]);
        payload.extend([0.0, -uniform(0.0, 7.0) * 9.81]);
    }
    (alpha, payload)
}

const TARGETS: [usize; 2] = [50, 150];
const SOLVERS: [(&str, LinearSolver); 3] = [
    ("sparse_reuse", LinearSolver::Sparse),
    ("sparse_fresh", LinearSolver::SparseFresh),
    ("dense", LinearSolver::Dense),
];

fn bench_pose(c: &mut Criterion) {
    let arm = seed2022_arm();
    let (alpha_deg, payload) = poses(1024);
    let alpha: Vec<f64> = alpha_deg.iter().map(|d| d.to_radians()).collect();
    for target in TARGETS {
        let dof = model(&arm, target, LinearSolver::Sparse).n_dof();
        let mut group = c.benchmark_group(format!("fem_pose/{dof}dof"));
        group
            .sample_size(30)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(3))
            .throughput(Throughput::Elements(1));
        for (name, solver) in SOLVERS {
            let m = model(&arm, target, solver);
            let mut ws = FemWorkspace::new(&m);
            // Every pose of the sweep must solve.
            for k in 0..1024 {
                let p = v(0.0, payload[2 * k + 1]);
                ok(
                    ws.solve(&m, &alpha[3 * k..3 * k + 3], p, true, k),
                    "sweep check",
                );
            }
            let mut k = 0;
            group.bench_function(name, |b| {
                b.iter(|| {
                    k = (k + 1) % 1024;
                    let p = v(0.0, payload[2 * k + 1]);
                    let r = ws.solve(&m, black_box(&alpha[3 * k..3 * k + 3]), p, true, k);
                    black_box(r.is_ok());
                    black_box(ws.dmeasure)
                });
            });
        }
        group.finish();
    }
}

fn bench_linear(c: &mut Criterion) {
    let arm = seed2022_arm();
    let alpha = [
        115.6f64.to_radians(),
        15.4f64.to_radians(),
        0.2f64.to_radians(),
    ];
    for target in TARGETS {
        let m = model(&arm, target, LinearSolver::Sparse);
        let mut ws = FemWorkspace::new(&m);
        ok(ws.assemble(&m, &alpha, 0), "assembly");
        let n = m.n_dof();
        let rhs0: Vec<f64> = (0..2 * n).map(|i| (i % 7) as f64 - 3.0).collect();
        let mut group = c.benchmark_group(format!("fem_linear/{n}dof"));
        group
            .sample_size(30)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(2))
            .throughput(Throughput::Elements(1));
        for (name, solver) in SOLVERS {
            let mut num = Numeric::new(&m.asm, &m.symbolic, solver, 2);
            let mut rhs = rhs0.clone();
            group.bench_function(name, |b| {
                b.iter(|| {
                    if num.factorize(&m.asm, &m.symbolic, &ws.values).is_err() {
                        panic!("factorisation failed");
                    }
                    rhs.copy_from_slice(&rhs0);
                    num.solve(&m.symbolic, black_box(&mut rhs), 2);
                    black_box(rhs[0])
                });
            });
        }
        group.finish();
    }
}

fn bench_batch(c: &mut Criterion) {
    let arm = seed2022_arm();
    let rows = 4096;
    let (alpha, payload) = poses(rows);
    eprintln!(
        "arm_benches/fem: {} hardware threads, RAYON_NUM_THREADS={}",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| "unset".into()),
    );
    let mut group = c.benchmark_group("fem_batch");
    group
        .sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .throughput(Throughput::Elements(rows as u64));
    for target in TARGETS {
        let m = model(&arm, target, LinearSolver::Sparse);
        let mut b = FemBatchBuffers::new(&m, rows);
        let input = BatchInput {
            alpha_deg: &alpha,
            payload_n: &payload,
        };
        let opts = SolveOptions::default();
        let run = |b: &mut FemBatchBuffers| fem_solve_batch(&m, input, opts, b.out());
        ok(run(&mut b), "batch check");
        group.bench_with_input(
            BenchmarkId::from_parameter(format!("{}dof", m.n_dof())),
            &(),
            |bench, _| bench.iter(|| black_box(run(&mut b).is_ok())),
        );
    }
    group.finish();
}

criterion_group!(benches, bench_pose, bench_linear, bench_batch);
criterion_main!(benches);
