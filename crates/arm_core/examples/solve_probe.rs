//! Fixed `solve` and `solve_sequence` workloads for instruction counts (docs/benchmarks.md,
//! "Kernel compute"): the example arm, 10⁵ poses in `bench_floor.py`'s working range with
//! payloads 0–7 kg (`solve`, baseline model), or 10⁴ sequences of its 8 states with its two
//! frictions, clearance and mount (`seq`) or without effects (`seq0`); `rsolve` is `solve` on
//! the rotary arm (`examples/rotary_arm.toml`: three geared motors with angle ranges and
//! torque limits, in `bench_floor.py`'s working range); every output stored,
//! into buffers allocated once (the core's compute, no page faults). Run it under
//! `valgrind --tool=callgrind` with `RAYON_NUM_THREADS=1`; the second argument `k` repeats
//! the work k times (default 1), so that the per-pose count is the difference of two runs
//! divided by the poses, free of the start-up.
//!
//! ```sh
//! cargo build --release -p arm_core --example solve_probe
//! RAYON_NUM_THREADS=1 valgrind --tool=callgrind target/release/examples/solve_probe solve 2
//! ```

use arm_core::effects::{
    ActuatorFriction, JointClearance, JointFriction, MountCompliance, Unloaded,
};
use arm_core::examples::example_arm;
use arm_core::{
    solve_batch_status, solve_sequence, Arm, BatchBuffers, BatchInput, Drive, Effect, EffectSet,
    ExtraDeformations, Link, RotaryDrive, SequenceInput, SolveOptions, V2,
};

/// `examples/rotary_arm.toml` (unused pins at zero, as Python gives them).
fn rotary_arm() -> arm_core::Result<Arm> {
    let z = V2::zeros();
    let link = |next: V2, c: V2, mass_kg: f64| Link {
        next,
        a: z,
        b: z,
        c,
        mass_kg,
    };
    let drive = |stiffness: f64, mass_kg: f64, torque: f64, lo: f64, hi: f64| {
        Drive::Rotary(RotaryDrive {
            stiffness,
            mass_kg,
            max_torque: Some(torque),
            min_angle: Some(f64::to_radians(lo)),
            max_angle: Some(f64::to_radians(hi)),
        })
    };
    Arm::with_drives(
        9.81,
        z,
        z,
        V2::new(-250.0, -320.0),
        vec![
            link(V2::new(560.0, 0.0), V2::new(250.0, 6.0), 4.2),
            link(V2::new(480.0, 0.0), V2::new(200.0, 4.0), 2.9),
            link(V2::new(420.0, -20.0), V2::new(190.0, -8.0), 2.4),
        ],
        vec![
            drive(4.0e7, 3.6, 2.6e5, -30.0, 150.0),
            drive(1.5e7, 2.6, 1.2e5, -160.0, 160.0),
            drive(4.0e6, 1.4, 4.5e4, -120.0, 120.0),
        ],
        V2::new(330.0, 25.0),
    )
}

/// A fixed pseudo-random sequence in [0, 1) (the same numbers on every machine).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn main() -> arm_core::Result<()> {
    let mut args = std::env::args().skip(1);
    let what = args.next().unwrap_or_else(|| "solve".into());
    let reps: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(1);
    let arm = if what == "rsolve" {
        rotary_arm()?
    } else {
        example_arm()
    };
    let opts = SolveOptions {
        self_weight: true,
        nan_on_failure: true,
    };
    let mut rng = Lcg(1);
    // absolute angles; the rotary arm's working range is of the relative ones, summed
    let (ranges, relative) = if what == "rsolve" {
        ([(0.0, 60.0), (-60.0, 0.0), (-40.0, 20.0)], true)
    } else {
        ([(60.0, 110.0), (0.0, 30.0), (-10.0, 10.0)], false)
    };
    let mut pose = || {
        let mut q = ranges.map(|(lo, hi)| lo + (hi - lo) * rng.next());
        if relative {
            q[1] += q[0];
            q[2] += q[1];
        }
        q
    };
    let g = 9.81;
    let mut checksum = 0.0;
    if what == "seq" || what == "seq0" {
        let seqs = 10_000;
        let masses = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0, 3.0];
        let effects = if what == "seq0" {
            vec![]
        } else {
            vec![
                Effect::ActuatorFriction(ActuatorFriction {
                    actuator: 0,
                    friction: 40.0,
                }),
                Effect::JointFriction(JointFriction {
                    joint: 2,
                    torque: 4000.0,
                }),
                Effect::JointClearance(JointClearance {
                    joint: 2,
                    clearance: 0.15,
                    unloaded: Unloaded::Centred,
                }),
                Effect::MountCompliance(MountCompliance {
                    actuator: 1,
                    stiffness: 4000.0,
                }),
            ]
        };
        let set = EffectSet::new(&arm, effects)?;
        let alpha: Vec<f64> = (0..seqs).flat_map(|_| pose()).collect();
        let payload: Vec<f64> = (0..seqs)
            .flat_map(|_| masses.iter().flat_map(|m| [0.0, -m * g]))
            .collect();
        let input = SequenceInput {
            alpha_deg: &alpha,
            payload_n: &payload,
            states: masses.len(),
        };
        let rows = seqs * masses.len();
        let mut b = BatchBuffers::new(rows, arm.n());
        let mut st = vec![0u8; rows];
        for _ in 0..reps {
            solve_sequence(&arm, &set, input, opts, b.out(), &mut st)?;
            checksum += b.dy_mm.iter().sum::<f64>();
        }
    } else {
        let rows = 100_000;
        let alpha: Vec<f64> = (0..rows).flat_map(|_| pose()).collect();
        let payload: Vec<f64> = (0..rows)
            .flat_map(|_| [0.0, -7.0 * g * rng.next()])
            .collect();
        let input = BatchInput {
            alpha_deg: &alpha,
            payload_n: &payload,
        };
        let set = EffectSet::empty();
        let mut b = BatchBuffers::new(rows, arm.n());
        let mut st = vec![0u8; rows];
        for _ in 0..reps {
            let extra = ExtraDeformations::default();
            solve_batch_status(&arm, &set, input, extra, opts, b.out(), &mut st)?;
            checksum += b.dy_mm.iter().sum::<f64>();
        }
    }
    println!("{what} × {reps}: Σ dy = {checksum:.6e}");
    Ok(())
}
