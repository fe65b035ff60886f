//! Criterion benchmarks of `arm_core::sweep` on the example arm (`examples/example_arm.toml`):
//! 1e4, 1e5 and 1e6 poses × 1 payload, baseline model, all outputs; one thread against two
//! (a pool of two built per call, `threads: Some(2)`, and rayon's global pool, `None`, which
//! has two threads on a 2-CPU machine); stored against reduced (max over groups of 8 poses). Output buffers are allocated once per
//! size and reused, so this measures the core. Run with `cargo bench -p arm_benches --bench
//! sweep`; see `docs/benchmarks.md`.

use std::hint::black_box;
use std::time::Duration;

use arm_benches::{angles, example_arm, ok};
use arm_core::sweep::{sweep, CellFields, Cells, Reduce, ReduceOp, SweepOptions, SweepOut};
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

criterion_group!(benches, bench_sweep);
criterion_main!(benches);
