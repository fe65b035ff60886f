//! Payload masses in place of force rows (`solve_batch_masses`, `solve_sequence_masses`):
//! the same results as the forces (0, −m·g) they stand for, and the input refused in the
//! same order as when the whole input is checked before any pose is solved.

#![allow(clippy::unwrap_used)] // test code: a failure should panic

mod common;

use arm_core::examples::example_arm;
use arm_core::{
    solve_batch_masses, solve_batch_status, solve_sequence, solve_sequence_masses, ArmError,
    BatchBuffers, BatchInput, EffectSet, ExtraDeformations, Masses, SequenceInput,
};
use common::{opts, outputs, Rng, OUTPUTS};

/// `rows` poses in the example arm's range and masses of 0–7 kg.
fn inputs(rows: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut rng = Rng(seed);
    let ranges = [(60.0, 110.0), (0.0, 30.0), (-10.0, 10.0)];
    let alpha = (0..rows)
        .flat_map(|_| ranges.map(|(lo, hi)| rng.uniform(lo, hi)))
        .collect();
    let mass = (0..rows).map(|_| rng.uniform(0.0, 7.0)).collect();
    (alpha, mass)
}

fn forces(mass: &[f64], g: f64) -> Vec<f64> {
    mass.iter().flat_map(|&m| [0.0, -m * g]).collect()
}

/// Every output of two batches, bit for bit (the same forces reach the same kernel).
fn same(a: &BatchBuffers, b: &BatchBuffers) {
    for (name, (x, y)) in OUTPUTS
        .into_iter()
        .zip(outputs(a).into_iter().zip(outputs(b)))
    {
        assert_eq!(x.len(), y.len(), "{name}");
        for (r, (u, v)) in x.iter().zip(y.iter()).enumerate() {
            assert!(
                u.to_bits() == v.to_bits(),
                "{name}, element {r}: {u} != {v}"
            );
        }
    }
}

/// `solve` of the poses `alpha` with the force rows of `mass`, and with `masses`: the
/// outputs and statuses of both.
fn both(
    alpha: &[f64],
    mass: &[f64],
    masses: Masses<'_>,
) -> ((BatchBuffers, Vec<u8>), (BatchBuffers, Vec<u8>)) {
    let arm = example_arm();
    let (rows, set) = (mass.len(), EffectSet::empty());
    let payload = forces(mass, arm.g);
    let input = BatchInput {
        alpha_deg: alpha,
        payload_n: &payload,
    };
    let none = ExtraDeformations::none();
    let (mut by_force, mut st_force) = (BatchBuffers::new(rows, 3), vec![0u8; rows]);
    let out = by_force.out();
    solve_batch_status(&arm, &set, input, none, opts(true), out, &mut st_force).unwrap();
    let (mut by_mass, mut st_mass) = (BatchBuffers::new(rows, 3), vec![0u8; rows]);
    let out = by_mass.out();
    solve_batch_masses(&arm, &set, alpha, masses, opts(true), out, &mut st_mass).unwrap();
    ((by_force, st_force), (by_mass, st_mass))
}

#[test]
fn masses_solve_as_the_forces_they_stand_for() {
    // several chunks (1024 poses each) and a partial block at the end
    let rows = 3 * 1024 + 21;
    let (alpha, mass) = inputs(rows, 7);
    let all = vec![4.5; rows];
    // the arm under its own weight alone
    let zero = vec![0.0; rows];
    let ((unloaded, _), _) = both(&alpha, &zero, Masses::All(0.0));
    for (mass, masses) in [(&mass, Masses::Each(&mass)), (&all, Masses::All(4.5))] {
        let ((by_force, st_force), (by_mass, st_mass)) = both(&alpha, mass, masses);
        same(&by_force, &by_mass);
        assert_eq!(st_force, st_mass);
        // the masses reached the poses: a payload makes the tip sag below its self-weight sag
        for (r, (&m, (d, d0))) in mass
            .iter()
            .zip(by_mass.dy_mm.iter().zip(&unloaded.dy_mm))
            .enumerate()
        {
            assert!(
                m == 0.0 || d < d0,
                "pose {r}: {m} kg, dy {d} mm, unloaded {d0} mm"
            );
        }
    }
}

#[test]
fn a_bad_input_is_named_before_a_pose_that_cannot_be_solved() {
    let arm = example_arm();
    let rows = 4 * 1024;
    let (mut alpha, mut mass) = inputs(rows, 11);
    let set = EffectSet::empty();
    let strict = arm_core::SolveOptions {
        self_weight: true,
        nan_on_failure: false,
    };
    let run = |alpha: &[f64], mass: &[f64]| {
        let mut b = BatchBuffers::new(rows, 3);
        let mut st = vec![0u8; rows];
        solve_batch_masses(
            &arm,
            &set,
            alpha,
            Masses::Each(mass),
            strict,
            b.out(),
            &mut st,
        )
    };
    // a pose that cannot be solved (far beyond its stroke: a huge payload) in the first
    // chunk, a NaN angle in the last: the NaN is named, as a check of the whole input first
    // would name it
    mass[5] = 1e9;
    alpha[3 * (rows - 2) + 1] = f64::NAN;
    let err = run(&alpha, &mass).unwrap_err();
    assert!(
        matches!(err, ArmError::NonFinite { row, what: "alpha_deg" } if row == rows - 2),
        "{err}"
    );
    // without the NaN, the pose that cannot be solved
    alpha[3 * (rows - 2) + 1] = 10.0;
    let err = run(&alpha, &mass).unwrap_err();
    assert!(!matches!(err, ArmError::NonFinite { .. }), "{err}");
    assert!(err.to_string().starts_with("pose row 5"), "{err}");
    // a negative mass names its row; the lowest of two, in different chunks
    mass[5] = 1.0;
    mass[2000] = -1.5;
    mass[3000] = -2.0;
    let err = run(&alpha, &mass).unwrap_err();
    assert_eq!(err.to_string(), "pose row 2000: mass_kg is negative (-1.5)");
}

#[test]
fn sequence_masses_solve_as_their_forces_shared_or_one_row_each() {
    let arm = example_arm();
    let (seqs, states) = (300, 5); // several chunks of whole sequences
    let (alpha, _) = inputs(seqs, 3);
    let shared = [0.0, 2.5, 7.0, 1.0, 0.0];
    let each: Vec<f64> = (0..seqs).flat_map(|_| shared).collect();
    let payload = forces(&each, arm.g);
    let set = EffectSet::empty();
    let total = seqs * states;
    let input = SequenceInput {
        alpha_deg: &alpha,
        payload_n: &payload,
        states,
    };
    let mut by_force = BatchBuffers::new(total, 3);
    let mut st_force = vec![0u8; total];
    solve_sequence(&arm, &set, input, opts(true), by_force.out(), &mut st_force).unwrap();
    for masses in [&shared[..], &each[..]] {
        let mut by_mass = BatchBuffers::new(total, 3);
        let mut st_mass = vec![0u8; total];
        let (o, st) = (by_mass.out(), &mut st_mass);
        solve_sequence_masses(&arm, &set, &alpha, masses, states, opts(true), o, st).unwrap();
        same(&by_force, &by_mass);
        assert_eq!(st_force, st_mass);
    }
    // a negative mass of a shared row is refused naming the first sequence and the state
    let bad = [0.0, 2.5, -7.0, 1.0, 0.0];
    let mut b = BatchBuffers::new(total, 3);
    let mut st = vec![0u8; total];
    let err = solve_sequence_masses(
        &arm,
        &set,
        &alpha,
        &bad,
        states,
        opts(true),
        b.out(),
        &mut st,
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "pose row 0: mass_kg is negative (state 2: -7.0)"
    );
}
