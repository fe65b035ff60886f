//! Criterion benchmarks of `arm_core::sweep` on the example arm (`examples/example_arm.toml`):
//! 1e4, 1e5 and 1e6 poses × 1 payload, baseline model, all outputs (the status included); one thread against two
//! (a pool of two built per call, `threads: Some(2)`, and rayon's global pool, `None`, which
//! has two threads on a 2-CPU machine); stored against reduced (max over groups of 8 poses).
//! The poses are given as rows (`Poses::Rows`, random angles) and, in `sweep_grid/…`, as a
//! regular grid of the same ranges that the core walks itself (`Poses::Grid`, sines and
//! cosines looked up per axis value). Output buffers are allocated once per size and reused,
//! so this measures the core. Run with `cargo bench -p arm_benches --bench sweep`; see
//! `docs/benchmarks.md`.

use std::hint::black_box;
use std::time::Duration;

use arm_benches::{angles, example_arm, ok};
use arm_core::sweep::{
    sweep, sweep_poses, CellFields, Cells, Grid, Poses, Reduce, ReduceOp, SweepOptions, SweepOut,
};
use arm_core::EffectSet;
use criterion::{
    criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput,
};

/// Poses per call.
const SIZES: [usize; 3] = [10_000, 100_000, 1_000_000];
/// Rows per group of the reduced runs.
const GROUP: usize = 8;

/// Every output buffer of a sweep.
struct Buffers {
    force: Vec<f64>,
    dx: Vec<f64>,
    dy: Vec<f64>,
    dalpha: Vec<f64>,
    dl: Vec<f64>,
    ok: Vec<bool>,
    status: Vec<u8>,
    length: Vec<f64>,
    reachable: Vec<bool>,
    ex: Vec<f64>,
    ey: Vec<f64>,
}

impl Buffers {
    fn new(rows: usize, poses: usize, n: usize) -> Self {
        let z = |k: usize| vec![0.0; k];
        Self {
            force: z(rows * n),
            dx: z(rows),
            dy: z(rows),
            dalpha: z(rows * n),
            dl: z(rows * n),
            ok: vec![false; rows],
            status: vec![0; rows],
            length: z(poses * n),
            reachable: vec![false; poses],
            ex: z(poses),
            ey: z(poses),
        }
    }

    fn out(&mut self) -> SweepOut<'_> {
        SweepOut {
            cells: Cells::Values(CellFields {
                force_n: &mut self.force,
                dx_mm: &mut self.dx,
                dy_mm: &mut self.dy,
                dalpha_deg: &mut self.dalpha,
                dl_mm: &mut self.dl,
            }),
            ok: &mut self.ok,
            status: &mut self.status,
            length_mm: &mut self.length,
            reachable: &mut self.reachable,
            effector_x_mm: &mut self.ex,
            effector_y_mm: &mut self.ey,
        }
    }
}

fn never(_finished: usize) -> bool {
    false
}

fn bench_sweep(c: &mut Criterion) {
    let arm = example_arm();
    let effects = EffectSet::empty();
    let mass = [5.0];
    eprintln!(
        "arm_benches/sweep: {} hardware threads",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
    );
    for (label, reduce) in [
        ("stored", None),
        (
            "reduced",
            Some(Reduce {
                op: ReduceOp::Max,
                group: GROUP,
            }),
        ),
    ] {
        for (tlabel, threads) in [("1t", Some(1)), ("2t", Some(2)), ("pool", None)] {
            let mut group = c.benchmark_group(format!("sweep/baseline/{label}/{tlabel}"));
            group
                .sampling_mode(SamplingMode::Flat)
                .sample_size(10)
                .warm_up_time(Duration::from_millis(500))
                .measurement_time(Duration::from_secs(3));
            for poses in SIZES {
                let alpha = angles(poses);
                let rows = poses * mass.len() / reduce.map_or(1, |r: Reduce| r.group);
                let mut buf = Buffers::new(rows, poses, arm.n());
                let opts = SweepOptions {
                    self_weight: true,
                    reduce,
                    threads,
                    ..Default::default()
                };
                // Every cell must solve: a benchmark of NaN cells would measure nothing.
                ok(
                    sweep(&arm, &effects, &alpha, &mass, opts, buf.out(), &never),
                    "sweep check",
                );
                assert!(buf.ok.iter().all(|&o| o) && buf.dy.iter().all(|d| d.is_finite()));
                group.throughput(Throughput::Elements(poses as u64));
                group.bench_with_input(BenchmarkId::from_parameter(poses), &alpha, |b, alpha| {
                    b.iter(|| {
                        let r = sweep(
                            &arm,
                            &effects,
                            black_box(alpha),
                            &mass,
                            opts,
                            buf.out(),
                            &never,
                        );
                        black_box(r.is_ok())
                    });
                });
            }
            group.finish();
        }
    }
}

/// The grid of each size: (α1, α2, α3) values over the ranges of `angles`.
fn grid_axes(poses: usize) -> [Vec<f64>; 3] {
    let (a, b, c) = match poses {
        10_000 => (25, 20, 20),
        100_000 => (50, 50, 40),
        _ => (100, 100, 100),
    };
    let axis = |lo: f64, hi: f64, k: usize| -> Vec<f64> {
        (0..k)
            .map(|i| lo + (hi - lo) * i as f64 / (k - 1) as f64)
            .collect()
    };
    [
        axis(60.0, 110.0, a),
        axis(0.0, 30.0, b),
        axis(-10.0, 10.0, c),
    ]
}

fn bench_sweep_grid(c: &mut Criterion) {
    let arm = example_arm();
    let effects = EffectSet::empty();
    let mass = [5.0];
    for (tlabel, threads) in [("1t", Some(1)), ("pool", None)] {
        let mut group = c.benchmark_group(format!("sweep_grid/baseline/stored/{tlabel}"));
        group
            .sampling_mode(SamplingMode::Flat)
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(3));
        for poses in SIZES {
            let axes = grid_axes(poses);
            let views: Vec<&[f64]> = axes.iter().map(|a| a.as_slice()).collect();
            let src = Poses::Grid(Grid {
                axes: &views,
                links: &[0, 1, 2],
                start: 0,
                count: poses,
            });
            let mut buf = Buffers::new(poses, poses, arm.n());
            let opts = SweepOptions {
                threads,
                ..Default::default()
            };
            ok(
                sweep_poses(&arm, &effects, src, &mass, opts, buf.out(), &never),
                "grid sweep check",
            );
            assert!(buf.ok.iter().all(|&o| o) && buf.dy.iter().all(|d| d.is_finite()));
            group.throughput(Throughput::Elements(poses as u64));
            group.bench_function(BenchmarkId::from_parameter(poses), |b| {
                b.iter(|| {
                    let r = sweep_poses(&arm, &effects, src, &mass, opts, buf.out(), &never);
                    black_box(r.is_ok())
                });
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench_sweep, bench_sweep_grid);
criterion_main!(benches);
