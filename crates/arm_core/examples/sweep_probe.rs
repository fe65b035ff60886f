//! A fixed sweep for instruction counts (docs/benchmarks.md, "Cycle sweeps after the rotary
//! work"): the example arm on `benches/bench_cycle.py`'s grid (121 × 141 × 11 poses × 4
//! payloads, 750 684 cells), baseline model, one thread, every output stored. Run it under
//! `perf stat -e instructions:u` or `valgrind --tool=callgrind`; the first argument `k`
//! repeats the sweep k times (default 1), so that the per-cell count is the difference of two
//! runs divided by the cells, free of the start-up.

use arm_core::examples::example_arm;
use arm_core::sweep::{sweep_poses, CellFields, Cells, Grid, Poses, SweepOptions, SweepOut};
use arm_core::EffectSet;

fn axis(lo: f64, hi: f64, k: usize) -> Vec<f64> {
    (0..k)
        .map(|i| lo + (hi - lo) * i as f64 / (k - 1) as f64)
        .collect()
}

fn never(_finished: usize) -> bool {
    false
}

fn main() {
    let reps: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let arm = example_arm();
    let n = arm.n();
    let effects = EffectSet::empty();
    let axes = [
        axis(60.0, 120.0, 121),
        axis(-30.0, 40.0, 141),
        axis(-5.0, 5.0, 11),
    ];
    let views: Vec<&[f64]> = axes.iter().map(|a| a.as_slice()).collect();
    let poses = 121 * 141 * 11;
    let mass = [1.5, 3.0, 5.0, 6.5];
    let rows = poses * mass.len();
    let z = |k: usize| vec![0.0f64; k];
    let (mut force, mut dx, mut dy, mut dalpha, mut dl) =
        (z(rows * n), z(rows), z(rows), z(rows * n), z(rows * n));
    let (mut ok, mut status) = (vec![false; rows], vec![0u8; rows]);
    let (mut length, mut reachable, mut ex, mut ey) =
        (z(poses * n), vec![false; poses], z(poses), z(poses));
    let opts = SweepOptions {
        threads: Some(1),
        ..Default::default()
    };
    for _ in 0..reps {
        let src = Poses::Grid(Grid {
            axes: &views,
            links: &[0, 1, 2],
            start: 0,
            count: poses,
        });
        let out = SweepOut {
            cells: Cells::Values(CellFields {
                force_n: &mut force,
                dx_mm: &mut dx,
                dy_mm: &mut dy,
                dalpha_deg: &mut dalpha,
                dl_mm: &mut dl,
            }),
            ok: &mut ok,
            status: &mut status,
            length_mm: &mut length,
            reachable: &mut reachable,
            effector_x_mm: &mut ex,
            effector_y_mm: &mut ey,
        };
        if let Err(e) = sweep_poses(&arm, &effects, src, &mass, opts, out, &never) {
            eprintln!("sweep_probe: {e}");
            std::process::exit(1);
        }
    }
    let solved = ok.iter().filter(|&&o| o).count();
    let sum: f64 = dy.iter().filter(|d| d.is_finite()).sum();
    println!("cells {rows} ok {solved} sum(dy) {sum:.9e}");
}
