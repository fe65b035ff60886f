//! Outputs not asked for (`outputs=` of `eodarm.solve`, docs/python.md): a `BatchOutput`
//! slice of length 0 is an output the caller does not want, and nothing is written there. A
//! batch with any subset of the outputs gives, for the asked ones, the values of the batch
//! with every output, and the same statuses: on the linear, rotary and mixed example arms, for
//! `solve_batch_status` and `solve_sequence`, on the block kernel and on the general path
//! (a user-written extra deformation, or a joint friction beside a bent link, takes it), with
//! poses that fail under their load (NaN rows), and above the parallel thresholds (the
//! outputs split into chunks).
//!
//! Exact equality is the right check here: both batches run in the same process through the
//! same code path on the same inputs; skipping a write changes no arithmetic, so any
//! difference at all is a bug (a status read from an output that was not written, a row
//! written to the wrong place of a chunk).

#![allow(clippy::unwrap_used)] // test code: a failure should panic
mod common;
use arm_core::effects::{
    DriveCompliance, JointClearance, JointFriction, LinkBending, MountCompliance, Unloaded,
};
use arm_core::examples::example_arm;
use arm_core::{
    solve_batch_general, solve_batch_status, solve_sequence, Arm, BatchBuffers, BatchInput, Drive,
    Effect, EffectSet, ExtraDeformations, RotaryDrive, SequenceInput, SolveOptions, V2,
};
use common::{outputs, OUTPUTS};
use proptest::prelude::*;

/// The example arm with the joints `rotary[i]` turned by a rotary drive instead of its
/// actuator (the actuator's pins unused): 0 linear, 1 rotary, 2 mixed (a drive at joint 2).
fn arm_of(kind: usize) -> Arm {
    let rotary = match kind {
        0 => [false; 3],
        1 => [true; 3],
        _ => [false, true, false],
    };
    let ex = example_arm();
    let (mut links, mut drives) = (ex.links.clone(), ex.drives.clone());
    for i in (0..3).filter(|&i| rotary[i]) {
        links[i].a = V2::zeros();
        if i > 0 {
            links[i - 1].b = V2::zeros();
        }
        drives[i] = Drive::Rotary(RotaryDrive {
            stiffness: 2e7,
            mass_kg: 1.5,
            max_torque: None,
            min_angle: None,
            max_angle: None,
        });
    }
    let b0 = if rotary[0] { V2::zeros() } else { ex.b0 };
    Arm::with_drives(ex.g, ex.o1, b0, ex.pivot, links, drives, ex.measure).unwrap()
}

/// Effects the block kernel takes (`general` false), or with a joint friction beside a bent
/// link, which only the general path solves (sequences included).
fn effects(arm: &Arm, general: bool) -> EffectSet {
    let mut e = vec![
        Effect::JointClearance(JointClearance {
            joint: 2,
            clearance: 0.1,
            unloaded: Unloaded::Centred,
        }),
        Effect::JointFriction(JointFriction {
            joint: 1,
            torque: 2000.0,
        }),
    ];
    e.push(if arm.is_rotary(1) {
        Effect::DriveCompliance(DriveCompliance {
            joint: 1,
            stiffness: 1e7,
        })
    } else {
        Effect::MountCompliance(MountCompliance {
            actuator: 1,
            stiffness: 3000.0,
        })
    });
    if general {
        e.push(Effect::LinkBending(LinkBending { link: 1, ei: 3e9 }));
    }
    EffectSet::new(arm, e).unwrap()
}

/// `rows` poses in the example arm's working range and their payloads (N): 0–10 kg down, and
/// every seventh row a load no pose can carry (NaN where an actuator's triangle cannot close;
/// a drive turns through it, out of the model's range).
fn poses(rows: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut s = seed | 1;
    let mut u = |lo: f64, hi: f64| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        lo + (hi - lo) * ((s >> 11) as f64 / (1u64 << 53) as f64)
    };
    let mut alpha = Vec::new();
    let mut payload = Vec::new();
    for r in 0..rows {
        alpha.extend([u(60.0, 110.0), u(0.0, 30.0), u(-10.0, 10.0)]);
        let fy = if r % 7 == 3 {
            -4e6
        } else {
            -9.81 * u(0.0, 10.0)
        };
        payload.extend([u(-5.0, 5.0), fy]);
    }
    (alpha, payload)
}

const OPTS: SolveOptions = SolveOptions {
    self_weight: true,
    nan_on_failure: true,
};

/// `solve_batch_status` (or `solve_batch_general` when `general`) into buffers holding the
/// outputs `asked` says yes to; with `extra`, a user-written deformation on every row.
fn solve(
    arm: &Arm,
    set: &EffectSet,
    (alpha, payload): (&[f64], &[f64]),
    extra: bool,
    asked: impl Fn(&str) -> bool,
) -> (BatchBuffers, Vec<u8>) {
    let rows = payload.len() / 2;
    let mut b = BatchBuffers::with_outputs(rows, 3, asked);
    let mut st = vec![0u8; rows];
    let input = BatchInput {
        alpha_deg: alpha,
        payload_n: payload,
    };
    let measure: Vec<f64> = (0..rows).flat_map(|r| [0.01 * r as f64, -0.02]).collect();
    let ex = if extra {
        ExtraDeformations {
            measure_mm: Some(&measure),
            ..ExtraDeformations::none()
        }
    } else {
        ExtraDeformations::none()
    };
    solve_batch_status(arm, set, input, ex, OPTS, b.out(), &mut st).unwrap();
    (b, st)
}

/// The asked outputs of `part` are those of `full`, value for value (NaN where NaN); the
/// others are empty; the statuses are the same.
fn same(full: &(BatchBuffers, Vec<u8>), part: &(BatchBuffers, Vec<u8>), mask: u16) {
    for (k, (a, b)) in outputs(&full.0).iter().zip(outputs(&part.0)).enumerate() {
        if mask & (1 << k) == 0 {
            assert!(b.is_empty(), "{} was not asked for", OUTPUTS[k]);
            continue;
        }
        assert_eq!(a.len(), b.len(), "{}", OUTPUTS[k]);
        for (j, (x, y)) in a.iter().zip(b).enumerate() {
            assert!(
                x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
                "{}[{j}]: {x} with every output, {y} with some",
                OUTPUTS[k]
            );
        }
    }
    assert_eq!(full.1, part.1, "statuses");
}

fn asked(mask: u16) -> impl Fn(&str) -> bool {
    move |key: &str| mask & (1 << OUTPUTS.iter().position(|k| *k == key).unwrap()) != 0
}

/// A batch of `rows` poses with every output, then with each mask's subset.
fn check_solve(kind: usize, path: usize, rows: usize, seed: u64, masks: &[u16]) {
    let arm = arm_of(kind);
    // path 0: the kernel; 1: the general path by its effects; 2: by a user deformation
    let set = effects(&arm, path == 1);
    let (alpha, payload) = poses(rows, seed);
    let extra = path == 2;
    let full = solve(&arm, &set, (&alpha, &payload), extra, |_| true);
    if rows > 3 {
        // the overloaded rows: NaN where an actuator's triangle cannot close (a drive turns)
        assert!(full.1.iter().any(|s| *s != 0), "a row out of the model");
        assert!(
            kind == 1 || full.0.dy_mm.iter().any(|v| v.is_nan()),
            "a failed row"
        );
        assert!(
            full.0.dy_mm.iter().any(|v| v.is_finite()),
            "a solved row is covered"
        );
    }
    for &mask in masks {
        let part = solve(&arm, &set, (&alpha, &payload), extra, asked(mask));
        same(&full, &part, mask);
    }
}

/// `solve_sequence` of `seqs` sequences of the states `masses` (kg) with every output, then
/// with each mask's subset.
fn check_sequence(kind: usize, general: bool, seqs: usize, seed: u64, masses: &[f64]) {
    let arm = arm_of(kind);
    let set = effects(&arm, general);
    let (alpha, _) = poses(seqs, seed);
    let s = masses.len();
    // every fifth sequence has a state no pose can carry (the kernel hands it back)
    let payload: Vec<f64> = (0..seqs)
        .flat_map(|q| {
            masses.iter().enumerate().flat_map(move |(k, m)| {
                let heavy = q % 5 == 2 && k == 1;
                [0.0, if heavy { -4e6 } else { -9.81 * m }]
            })
        })
        .collect();
    let input = SequenceInput {
        alpha_deg: &alpha,
        payload_n: &payload,
        states: s,
    };
    let run = |mask: u16| {
        let mut b = BatchBuffers::with_outputs(seqs * s, 3, asked(mask));
        let mut st = vec![0u8; seqs * s];
        solve_sequence(&arm, &set, input, OPTS, b.out(), &mut st).unwrap();
        (b, st)
    };
    let full = run(u16::MAX);
    assert!(
        kind == 1 || full.0.dy_mm.iter().any(|v| v.is_nan()),
        "a failed state"
    );
    for mask in [
        0u16,
        1 << 5 | 1 << 6,
        1 << 7,
        0b101_0101_0101,
        0b010_1010_1010,
    ] {
        same(&full, &run(mask), mask);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Any subset, any arm, any path, small batches (one chunk, the calling thread).
    #[test]
    fn any_subset_of_a_solve_is_the_full_solve(
        kind in 0usize..3, path in 0usize..3, rows in 1usize..60, seed in any::<u64>(),
        mask in 0u16..(1 << 11),
    ) {
        check_solve(kind, path, rows, seed, &[mask]);
    }
}

/// Above the parallel thresholds: the outputs asked for are cut into chunks, the others
/// stay empty in every chunk.
#[test]
fn subsets_of_a_parallel_solve_are_the_full_solve() {
    let masks = [0u16, 1 << 5 | 1 << 6, 1 << 0 | 1 << 3, 0b110_0000_0001];
    for kind in 0..3 {
        for path in 0..3 {
            check_solve(kind, path, 5000, 31 + kind as u64, &masks);
        }
    }
}

/// Sequences: kernel and general path, one chunk and several (parallel), every arm.
#[test]
fn subsets_of_sequences_are_the_full_sequences() {
    let masses = [2.0, 6.0, 0.0, 4.0];
    for kind in 0..3 {
        for general in [false, true] {
            check_sequence(kind, general, 9, 7, &masses);
            check_sequence(kind, general, 700, 8, &masses);
        }
    }
}

/// An output of the wrong size is still refused, naming it; an empty one is not.
#[test]
fn a_wrong_size_is_refused_and_an_empty_output_is_not() {
    let arm = example_arm();
    let set = EffectSet::new(&arm, vec![]).unwrap();
    let (alpha, payload) = poses(4, 3);
    let mut b = BatchBuffers::with_outputs(4, 3, |k| k != "dx_mm");
    b.dy_mm.pop();
    let input = BatchInput {
        alpha_deg: &alpha,
        payload_n: &payload,
    };
    let none = ExtraDeformations::none;
    let mut st = vec![0u8; 4];
    let err = solve_batch_general(&arm, &set, input, none(), OPTS, b.out(), &mut st).unwrap_err();
    assert!(err.to_string().contains("dy_mm"), "{err}");
    b.dy_mm.push(0.0);
    solve_batch_general(&arm, &set, input, none(), OPTS, b.out(), &mut st).unwrap();
    assert!(b.dx_mm.is_empty() && b.dy_mm.len() == 4);
}
