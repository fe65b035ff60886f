//! Load sequences (`solve_sequence`) and the friction elements, on the contract's example arm
//! at one pose: the frictionless states of a sequence are `solve`'s single loadings; a zero friction is no
//! friction; a cycle leaves `L/k` on the body's sensor at the return; a monotonic loading is
//! a row of single loadings (the deadband).
//!
//! Tolerances: 1e-9 mm (the block kernel against the general path agree to ≈ 1e-13 mm,
//! tests/solve_fast.rs); exact equality where the same path computes the same numbers.

#![allow(clippy::unwrap_used)] // test code: a failure should panic
use arm_core::effects::{ActuatorFriction, JointFriction, MountCompliance};
use arm_core::examples::example_arm;
use arm_core::{
    solve_batch_general, solve_sequence, BatchBuffers, BatchInput, Effect, EffectSet,
    ExtraDeformations, SequenceInput, SolveOptions,
};

const POSE: [f64; 3] = [90.0, 10.0, 0.0];
const G: f64 = 9.81;

fn sequence(effects: Vec<Effect>, masses: &[f64]) -> BatchBuffers {
    let arm = example_arm();
    let set = EffectSet::new(&arm, effects).unwrap();
    let payload: Vec<f64> = masses.iter().flat_map(|m| [0.0, -m * G]).collect();
    let mut b = BatchBuffers::new(masses.len(), 3);
    let mut status = vec![0u8; masses.len()];
    let input = SequenceInput {
        alpha_deg: &POSE,
        payload_n: &payload,
        states: masses.len(),
    };
    solve_sequence(
        &arm,
        &set,
        input,
        SolveOptions::default(),
        b.out(),
        &mut status,
    )
    .unwrap();
    b
}

fn single(effects: Vec<Effect>, masses: &[f64]) -> BatchBuffers {
    let arm = example_arm();
    let set = EffectSet::new(&arm, effects).unwrap();
    let alpha: Vec<f64> = masses.iter().flat_map(|_| POSE).collect();
    let payload: Vec<f64> = masses.iter().flat_map(|m| [0.0, -m * G]).collect();
    let mut b = BatchBuffers::new(masses.len(), 3);
    let input = BatchInput {
        alpha_deg: &alpha,
        payload_n: &payload,
    };
    let mut status = vec![0u8; masses.len()];
    let none = ExtraDeformations::none();
    let opts = SolveOptions::default();
    solve_batch_general(&arm, &set, input, none, opts, b.out(), &mut status).unwrap();
    b
}

fn close(a: &[f64], b: &[f64], tol: f64) {
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() <= tol, "{x} vs {y}");
    }
}

fn friction(limit: f64) -> Effect {
    Effect::ActuatorFriction(ActuatorFriction {
        actuator: 1,
        friction: limit,
    })
}

#[test]
fn frictionless_states_are_single_loadings_from_the_reference() {
    let masses = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0];
    let mount = || {
        vec![Effect::MountCompliance(MountCompliance {
            actuator: 2,
            stiffness: 4000.0,
        })]
    };
    let seq = sequence(mount(), &masses);
    let one = single(mount(), &masses);
    close(&seq.dx_mm, &one.dx_mm, 1e-9);
    close(&seq.dy_mm, &one.dy_mm, 1e-9);
    close(&seq.dl_mm, &one.dl_mm, 1e-9);
    close(&seq.force_n, &one.force_n, 1e-9 * 1e3);
}

#[test]
fn zero_friction_is_no_friction() {
    let masses = [1.5, 6.5, 0.0, 3.0];
    let mut zero = vec![friction(0.0)];
    zero.push(Effect::JointFriction(JointFriction {
        joint: 0,
        torque: 0.0,
    }));
    // The zero frictions run the general path, no friction the block kernel: equal to rounding.
    let a = sequence(zero, &masses);
    let b = sequence(vec![], &masses);
    close(&a.dy_mm, &b.dy_mm, 1e-9);
    close(&a.dl_mm, &b.dl_mm, 1e-9);
    close(&a.force_n, &b.force_n, 1e-9 * 1e3);
}

#[test]
fn a_cycle_leaves_l_over_k_on_the_body() {
    // ΔF_2 is +75 N/kg here: at 6.5 kg the element slipped, and unloading by 486 N > 2L it
    // slips back and holds L: the body stays L/k shorter than at the reference.
    let limit = 60.0;
    let b = sequence(vec![friction(limit)], &[6.5, 0.0]);
    let k = example_arm().actuator(1).unwrap().stiffness;
    assert!((b.dl_mm[3 + 1] + limit / k).abs() < 1e-12);
    assert!(b.dy_mm[1].abs() > 1e-3);
}

#[test]
fn a_monotonic_loading_is_the_deadband_of_each_state() {
    let masses = [0.5, 1.5, 5.0, 6.5];
    let seq = sequence(vec![friction(60.0)], &masses);
    let one = single(vec![friction(60.0)], &masses);
    close(&seq.dy_mm, &one.dy_mm, 1e-9);
    let free = single(vec![], &masses);
    let k = example_arm().actuator(1).unwrap().stiffness;
    for (s, _) in masses.iter().enumerate() {
        let df = free.dforce_n[3 * s + 1];
        let held = df.signum() * (df.abs() - 60.0).max(0.0);
        assert!((seq.dl_mm[3 * s + 1] + held / k).abs() < 1e-9);
    }
}

#[test]
fn solve_with_frictions_is_the_same_on_the_kernel_and_the_general_path() {
    use arm_core::effects::{ActuatorPlay, BaseCompliance, JointClearance, LinkBending, Unloaded};
    let arm = example_arm();
    let effects = vec![
        friction(60.0),
        Effect::JointFriction(JointFriction {
            joint: 2,
            torque: 3000.0,
        }),
        Effect::ActuatorFriction(ActuatorFriction {
            actuator: 2,
            friction: 15.0,
        }),
        Effect::ActuatorPlay(ActuatorPlay {
            actuator: 2,
            play: 0.05,
            unloaded: Unloaded::TakenUp,
        }),
        Effect::JointClearance(JointClearance {
            joint: 2,
            clearance: 0.1,
            unloaded: Unloaded::Centred,
        }),
        Effect::LinkBending(LinkBending { link: 0, ei: 2e10 }),
        Effect::BaseCompliance(BaseCompliance { stiffness: 5e8 }),
    ];
    let set = EffectSet::new(&arm, effects).unwrap();
    let rows = 40;
    let alpha: Vec<f64> = (0..rows)
        .flat_map(|r| {
            let t = r as f64 / rows as f64;
            [85.0 + 10.0 * t, 15.0 - 12.0 * t, -5.0 + 9.0 * t]
        })
        .collect();
    // payloads of both signs and sizes, some within the deadbands
    let payload: Vec<f64> = (0..rows)
        .flat_map(|r| [0.0, -80.0 + 4.0 * r as f64])
        .collect();
    let input = BatchInput {
        alpha_deg: &alpha,
        payload_n: &payload,
    };
    let opts = SolveOptions::default();
    let (mut a, mut b) = (BatchBuffers::new(rows, 3), BatchBuffers::new(rows, 3));
    let (mut sa, mut sb) = (vec![0u8; rows], vec![0u8; rows]);
    let none = ExtraDeformations::none;
    arm_core::solve_batch_status(&arm, &set, input, none(), opts, a.out(), &mut sa).unwrap();
    solve_batch_general(&arm, &set, input, none(), opts, b.out(), &mut sb).unwrap();
    close(&a.dx_mm, &b.dx_mm, 1e-9);
    close(&a.dy_mm, &b.dy_mm, 1e-9);
    close(&a.dl_mm, &b.dl_mm, 1e-9);
    close(&a.dlength_mm, &b.dlength_mm, 1e-9);
    close(&a.dalpha_deg, &b.dalpha_deg, 1e-9);
    close(&a.force_n, &b.force_n, 1e-9 * 1e3);
    close(&a.reaction_n, &b.reaction_n, 1e-9 * 1e3);
    assert_eq!(sa, sb);
}

/// `cycle_returns` is the last state of `solve_sequence`'s `[m, 0]` for every pose and mass:
/// on the block kernel (3 links) and on the general path (a joint friction beside a bent
/// link), exactly (the same numbers by the same path); a non-finite angle is named.
#[test]
fn cycle_returns_are_the_last_state_of_each_cycle() {
    use arm_core::effects::{JointClearance, LinkBending, Unloaded};
    let arm = example_arm();
    let masses = [0.0, 1.5, 6.5, 20.0];
    let mut alpha: Vec<f64> = (0..9)
        .flat_map(|r| {
            let t = r as f64 / 9.0;
            [80.0 + 20.0 * t, 20.0 - 25.0 * t, -8.0 + 12.0 * t]
        })
        .collect();
    alpha.extend_from_slice(&[90.0, 10.0, 0.0]);
    let clearance = Effect::JointClearance(JointClearance {
        joint: 1,
        clearance: 0.1,
        unloaded: Unloaded::Centred,
    });
    let joint = Effect::JointFriction(JointFriction {
        joint: 1,
        torque: 4000.0,
    });
    let bent = Effect::LinkBending(LinkBending { link: 1, ei: 2e10 });
    for effects in [
        vec![friction(60.0), joint.clone(), clearance.clone()],
        vec![friction(60.0), joint, bent], // the general path
    ] {
        let set = EffectSet::new(&arm, effects).unwrap();
        let poses = alpha.len() / 3;
        let (mut dx, mut dy) = (vec![0.0; poses * 4], vec![0.0; poses * 4]);
        arm_core::cycle_returns(&arm, &set, &alpha, &masses, true, &mut dx, &mut dy).unwrap();
        for p in 0..poses {
            for (j, m) in masses.iter().enumerate() {
                let payload = [0.0, -m * arm.g, 0.0, 0.0];
                let input = SequenceInput {
                    alpha_deg: &alpha[3 * p..3 * p + 3],
                    payload_n: &payload,
                    states: 2,
                };
                let mut b = BatchBuffers::new(2, 3);
                let mut status = [0u8; 2];
                let opts = SolveOptions {
                    self_weight: true,
                    nan_on_failure: true,
                };
                solve_sequence(&arm, &set, input, opts, b.out(), &mut status).unwrap();
                let r = p * 4 + j;
                assert_eq!(
                    dx[r].to_bits(),
                    b.dx_mm[1].to_bits(),
                    "dx of pose {p}, {m} kg"
                );
                assert_eq!(
                    dy[r].to_bits(),
                    b.dy_mm[1].to_bits(),
                    "dy of pose {p}, {m} kg"
                );
            }
        }
        // something came back off the reference
        assert!(dy.iter().any(|d| d.abs() > 1e-3));
    }
    // a non-finite angle is named
    let set = EffectSet::new(&arm, vec![friction(60.0)]).unwrap();
    let (mut dx, mut dy) = (vec![0.0; 8], vec![0.0; 8]);
    let bad = [90.0, 10.0, 0.0, 90.0, f64::NAN, 0.0];
    let err = arm_core::cycle_returns(&arm, &set, &bad, &masses, true, &mut dx, &mut dy);
    assert!(
        matches!(err, Err(arm_core::ArmError::NonFinite { row: 1, .. })),
        "{err:?}"
    );
}
