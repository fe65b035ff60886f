//! Deformations from outside the catalogue (user effects, docs/custom-effects.md) and gaps taken up by
//! the unloaded forces (docs/model.md §4): an extra deformation equal to a built-in effect's
//! cause gives that effect's result; zero extras change nothing; bad extras are refused naming
//! the array and row; the batch statics are the solver's; a taken-up gap gives no deflection
//! at zero payload, is bounded by twice the gap, and is the centred gap without self-weight.
//!
//! Extras always take the general path (`Workspace::solve_extra`); the solves they are
//! compared with here take it too (`solve_batch_general`), so that the comparison is of the
//! extras alone. tests/solve_fast.rs compares the block kernel with the general path.

#![allow(clippy::unwrap_used, clippy::needless_range_loop)] // test code: a failure should panic
mod common;
use arm_core::effects::{
    ActuatorCompliance, ActuatorPlay, BaseCompliance, JointClearance, MountCompliance, Unloaded,
};
use arm_core::examples::example_arm;
use arm_core::fem::{FemModel, FemOptions};
use arm_core::geometry::cross;
use arm_core::sensitivity::{jacobian_batch, n_channels, Place};
use arm_core::{
    solve_batch, solve_batch_extra, solve_batch_general, statics_batch, Arm, ArmError,
    BatchBuffers, BatchInput, Effect, EffectSet, ExtraDeformations, Mechanism, SolveOptions,
    StaticsBuffers, Workspace, V2,
};
use common::v;
use proptest::prelude::*;

/// `rows` poses of the example arm (degrees) and payloads of `mass` kg each.
fn batch(arm: &Arm, poses: &[[f64; 3]], mass: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let alpha = poses.iter().flatten().copied().collect();
    let payload = mass.iter().flat_map(|m| [0.0, -m * arm.g]).collect();
    (alpha, payload)
}

fn run(
    arm: &Arm,
    effects: Vec<Effect>,
    input: (&[f64], &[f64]),
    extra: ExtraDeformations<'_>,
) -> BatchBuffers {
    let set = EffectSet::new(arm, effects).unwrap();
    let rows = input.1.len() / 2;
    let mut b = BatchBuffers::new(rows, arm.n());
    let input = BatchInput {
        alpha_deg: input.0,
        payload_n: input.1,
    };
    let mut status = vec![0; rows];
    let opts = SolveOptions::default();
    solve_batch_general(arm, &set, input, extra, opts, b.out(), &mut status).unwrap();
    b
}

/// `solve_batch` through the general path.
fn general(arm: &Arm, set: &EffectSet, input: BatchInput<'_>, opts: SolveOptions) -> BatchBuffers {
    let rows = input.payload_n.len() / 2;
    let mut b = BatchBuffers::new(rows, arm.n());
    let mut status = vec![0; rows];
    let none = ExtraDeformations::none();
    solve_batch_general(arm, set, input, none, opts, b.out(), &mut status).unwrap();
    b
}

/// Every output of `a` within `tol` of `b`'s (absolute, mm/deg/N).
fn assert_close(a: &BatchBuffers, b: &BatchBuffers, tol: f64, what: &str) {
    let fields = [
        ("dx_mm", &a.dx_mm, &b.dx_mm),
        ("dy_mm", &a.dy_mm, &b.dy_mm),
        ("dalpha_deg", &a.dalpha_deg, &b.dalpha_deg),
        ("dl_mm", &a.dl_mm, &b.dl_mm),
        ("dlength_mm", &a.dlength_mm, &b.dlength_mm),
        ("force_n", &a.force_n, &b.force_n),
    ];
    for (name, x, y) in fields {
        for (k, (p, q)) in x.iter().zip(y.iter()).enumerate() {
            assert!((p - q).abs() <= tol, "{what}: {name}[{k}] {p} vs {q}");
        }
    }
}

fn poses() -> impl Strategy<Value = Vec<[f64; 3]>> {
    prop::collection::vec(
        (60.0..110.0f64, 0.0..30.0f64, -10.0..10.0f64).prop_map(|(a, b, c)| [a, b, c]),
        1..6,
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// A user effect that returns what a built-in effect's cause is reproduces that effect:
    /// mount compliance as an unseen length −ΔF/k, actuator compliance as a seen length
    /// −ΔF·(1/k′ − 1/k), clearance as the joint offset, base compliance as the tilt ΔM/k.
    #[test]
    fn extras_reproduce_builtin_effects(poses in poses(), m in 0.5..8.0f64, k in 300.0..3000.0f64, c in 0.01..0.5f64, j in 0usize..3) {
        let arm = example_arm();
        let n = arm.n();
        let rows = poses.len();
        let (alpha, payload) = batch(&arm, &poses, &vec![m; rows]);
        let input = (alpha.as_slice(), payload.as_slice());
        let base = run(&arm, vec![], input, ExtraDeformations::none());
        let df = &base.dforce_n;

        let unseen: Vec<f64> = (0..rows * n).map(|q| if q % n == j { -df[q] / k } else { 0.0 }).collect();
        let mount = run(&arm, vec![Effect::MountCompliance(MountCompliance { actuator: j, stiffness: k })], input, ExtraDeformations::none());
        let extra = run(&arm, vec![], input, ExtraDeformations { unseen_mm: Some(&unseen), ..Default::default() });
        assert_close(&extra, &mount, 1e-12, "unseen length = mount_compliance");

        let k0 = arm.actuator(j).unwrap().stiffness;
        let seen: Vec<f64> = (0..rows * n).map(|q| if q % n == j { -df[q] * (1.0 / k - 1.0 / k0) } else { 0.0 }).collect();
        let body = run(&arm, vec![Effect::ActuatorCompliance(ActuatorCompliance { actuator: j, stiffness: k })], input, ExtraDeformations::none());
        let extra = run(&arm, vec![], input, ExtraDeformations { seen_mm: Some(&seen), ..Default::default() });
        assert_close(&extra, &body, 1e-12, "seen length = actuator_compliance");

        for unloaded in [Unloaded::Centred, Unloaded::TakenUp] {
            let clearance = vec![Effect::JointClearance(JointClearance { joint: j, clearance: c, unloaded })];
            let set = EffectSet::new(&arm, clearance.clone()).unwrap();
            let mut offsets = vec![0.0; rows * n * 2];
            let mut ws = Workspace::new(&arm);
            for r in 0..rows {
                let a: Vec<f64> = poses[r].iter().map(|d| d.to_radians()).collect();
                ws.solve(&arm, &set, &a, v(0.0, -m * arm.g), SolveOptions::default(), r).unwrap();
                let off = ws.def.joint_offset[j];
                offsets[2 * (r * n + j)] = off.x;
                offsets[2 * (r * n + j) + 1] = off.y;
            }
            let want = run(&arm, clearance, input, ExtraDeformations::none());
            let extra = run(&arm, vec![], input, ExtraDeformations { joint_mm: Some(&offsets), ..Default::default() });
            assert_close(&extra, &want, 1e-12, "joint offset = joint_clearance");
        }

        let kb = 1e8 * c;
        let mut ws = Workspace::new(&arm);
        let tilt: Vec<f64> = poses.iter().map(|p| {
            let a: Vec<f64> = p.iter().map(|d| d.to_radians()).collect();
            ws.solve(&arm, &EffectSet::empty(), &a, V2::zeros(), SolveOptions::default(), 0).unwrap();
            cross(ws.frames.joint[n] - arm.pivot, v(0.0, -m * arm.g)) / kb
        }).collect();
        let tilted = run(&arm, vec![Effect::BaseCompliance(BaseCompliance { stiffness: kb })], input, ExtraDeformations::none());
        let extra = run(&arm, vec![], input, ExtraDeformations { tilt_rad: Some(&tilt), ..Default::default() });
        assert_close(&extra, &tilted, 1e-12, "tilt = base_compliance");
    }

    /// A measure-point shift moves the measure point by exactly that and nothing else.
    #[test]
    fn measure_shift_adds_to_the_measure_point(poses in poses(), m in 0.0..8.0f64, dx in -1.0..1.0f64, dy in -1.0..1.0f64) {
        let arm = example_arm();
        let rows = poses.len();
        let (alpha, payload) = batch(&arm, &poses, &vec![m; rows]);
        let input = (alpha.as_slice(), payload.as_slice());
        let shift: Vec<f64> = (0..rows).flat_map(|_| [dx, dy]).collect();
        let base = run(&arm, vec![], input, ExtraDeformations::none());
        let moved = run(&arm, vec![], input, ExtraDeformations { measure_mm: Some(&shift), ..Default::default() });
        for r in 0..rows {
            prop_assert!((moved.dx_mm[r] - base.dx_mm[r] - dx).abs() < 1e-12);
            prop_assert!((moved.dy_mm[r] - base.dy_mm[r] - dy).abs() < 1e-12);
        }
        prop_assert_eq!(&moved.dalpha_deg, &base.dalpha_deg);
        prop_assert_eq!(&moved.dl_mm, &base.dl_mm);
    }

    /// Gaps taken up by the unloaded forces: with self-weight and no payload nothing moves;
    /// under load the play changes an actuator by at most twice its play and the clearance
    /// offset is c·(û_loaded − û_unloaded), at most 2c; without self-weight (nothing took the
    /// gap up) a taken-up gap is a centred one.
    #[test]
    fn taken_up_gaps(poses in poses(), m in 0.5..8.0f64, c in 0.0..0.5f64, j in 0usize..3) {
        let arm = example_arm();
        let gaps = |unloaded| vec![
            Effect::ActuatorPlay(ActuatorPlay { actuator: j, play: c, unloaded }),
            Effect::JointClearance(JointClearance { joint: j, clearance: c, unloaded }),
        ];
        let set = EffectSet::new(&arm, gaps(Unloaded::TakenUp)).unwrap();
        let centred = EffectSet::new(&arm, gaps(Unloaded::Centred)).unwrap();
        let plain = EffectSet::empty();
        let mut ws = Workspace::new(&arm);
        let mut ref_ws = Workspace::new(&arm);
        for p in &poses {
            let a: Vec<f64> = p.iter().map(|d| d.to_radians()).collect();
            ws.solve(&arm, &set, &a, V2::zeros(), SolveOptions::default(), 0).unwrap();
            // The gaps' causes vanish exactly; the closed pose is the unloaded one to rounding.
            prop_assert!(ws.def.extra_length.iter().all(|&d| d == 0.0));
            prop_assert!(ws.def.joint_offset.iter().all(|&o| o == V2::zeros()));
            prop_assert!(ws.dmeasure.norm() < 1e-9, "{:?}", ws.dmeasure);
            prop_assert!(ws.new_alpha.iter().zip(&a).all(|(x, y)| (x - y).abs() < 1e-12));

            let load = v(0.0, -m * arm.g);
            ws.solve(&arm, &set, &a, load, SolveOptions::default(), 0).unwrap();
            ref_ws.solve(&arm, &plain, &a, load, SolveOptions::default(), 0).unwrap();
            let play = (ws.new_length[j] - ref_ws.new_length[j]).abs();
            prop_assert!(play <= 2.0 * c + 1e-12, "play length change {play} > 2·{c}");
            let unit = |f: V2| if f.norm() < 1e-9 { V2::zeros() } else { f / f.norm() };
            let want = (unit(-ws.loaded.r[j]) - unit(-ws.weight.r[j])) * c;
            let off = ws.def.joint_offset[j];
            prop_assert!((off - want).norm() <= 1e-12, "offset {off:?} vs {want:?}");
            prop_assert!(off.norm() <= 2.0 * c + 1e-12);

            let no_weight = SolveOptions { self_weight: false, ..Default::default() };
            ws.solve(&arm, &set, &a, load, no_weight, 0).unwrap();
            ref_ws.solve(&arm, &centred, &a, load, no_weight, 0).unwrap();
            prop_assert_eq!(ws.dmeasure, ref_ws.dmeasure);
            prop_assert_eq!(&ws.new_alpha, &ref_ws.new_alpha);
        }
    }
}

/// Zero extras (every array given, all zeros) give the numbers of no extras.
#[test]
fn zero_extras_change_nothing() {
    let arm = example_arm();
    let n = arm.n();
    let poses = [[80.0, 10.0, 0.0], [95.0, 20.0, -5.0], [70.0, 5.0, 8.0]];
    let (alpha, payload) = batch(&arm, &poses, &[0.0, 2.0, 5.0]);
    let input = (alpha.as_slice(), payload.as_slice());
    let effects = || {
        vec![
            Effect::ActuatorPlay(ActuatorPlay {
                actuator: 1,
                play: 0.1,
                unloaded: Unloaded::Centred,
            }),
            Effect::JointClearance(JointClearance {
                joint: 2,
                clearance: 0.1,
                unloaded: Unloaded::TakenUp,
            }),
            Effect::BaseCompliance(BaseCompliance { stiffness: 5e7 }),
        ]
    };
    let (z1, z2, zj) = (vec![0.0; 3 * n], vec![0.0; 3], vec![0.0; 3 * n * 2]);
    let zeros = ExtraDeformations {
        seen_mm: Some(&z1),
        unseen_mm: Some(&z1),
        turn_rad: None,
        joint_mm: Some(&zj),
        tilt_rad: Some(&z2[..3]),
        measure_mm: Some(&[0.0; 6]),
    };
    let with = run(&arm, effects(), input, zeros);
    let without = run(&arm, effects(), input, ExtraDeformations::none());
    assert_eq!(with, without);
    // And `solve_batch` is `solve_batch_extra` without extras (both on the block kernel).
    let set = EffectSet::new(&arm, effects()).unwrap();
    let input = BatchInput {
        alpha_deg: &alpha,
        payload_n: &payload,
    };
    let mut b = BatchBuffers::new(3, n);
    solve_batch(&arm, &set, input, SolveOptions::default(), b.out()).unwrap();
    let mut e = BatchBuffers::new(3, n);
    let none = ExtraDeformations::none();
    solve_batch_extra(&arm, &set, input, none, SolveOptions::default(), e.out()).unwrap();
    assert_eq!(b, e);
}

/// A wrong size names the array; a NaN names the array and its row.
#[test]
fn bad_extras_are_refused_naming_array_and_row() {
    let arm = example_arm();
    let n = arm.n();
    let poses = [[80.0, 10.0, 0.0], [95.0, 20.0, -5.0], [70.0, 5.0, 8.0]];
    let (alpha, payload) = batch(&arm, &poses, &[1.0, 2.0, 5.0]);
    let set = EffectSet::empty();
    let input = BatchInput {
        alpha_deg: &alpha,
        payload_n: &payload,
    };
    let solve = |extra: ExtraDeformations<'_>| {
        let mut b = BatchBuffers::new(3, n);
        solve_batch_extra(&arm, &set, input, extra, SolveOptions::default(), b.out())
    };
    let short = vec![0.0; 2 * n];
    let err = solve(ExtraDeformations {
        unseen_mm: Some(&short),
        ..Default::default()
    })
    .unwrap_err();
    assert_eq!(
        err,
        ArmError::Shape {
            what: "extra_unseen_mm",
            expected: 3 * n,
            got: 2 * n
        }
    );
    let mut joint = vec![0.0; 3 * n * 2];
    joint[2 * (2 * n + 1) + 1] = f64::NAN;
    let err = solve(ExtraDeformations {
        joint_mm: Some(&joint),
        ..Default::default()
    })
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "pose row 2: extra_joint_mm has a non-finite value"
    );
    let tilt = [0.0, f64::INFINITY, 0.0];
    let err = solve(ExtraDeformations {
        tilt_rad: Some(&tilt),
        ..Default::default()
    })
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "pose row 1: extra_tilt_rad has a non-finite value"
    );
}

/// The batch statics are the solver's forces: loaded ones under the payload, unloaded ones
/// at zero payload, and the unloaded lengths; in parallel as on one thread.
#[test]
fn statics_batch_is_the_solvers_statics() {
    let arm = example_arm();
    let n = arm.n();
    let rows = 5000; // above the parallel threshold
    let poses: Vec<[f64; 3]> = (0..rows)
        .map(|r| {
            let t = r as f64 / rows as f64;
            [
                60.0 + 50.0 * t,
                30.0 * (1.0 - t),
                -10.0 + 20.0 * (t * 7.0).fract(),
            ]
        })
        .collect();
    let mass: Vec<f64> = (0..rows).map(|r| (r % 9) as f64).collect();
    let (alpha, payload) = batch(&arm, &poses, &mass);
    let zero = vec![0.0; 2 * rows];
    for self_weight in [true, false] {
        let opts = SolveOptions {
            self_weight,
            ..Default::default()
        };
        let mut st = StaticsBuffers::new(rows, n);
        let input = BatchInput {
            alpha_deg: &alpha,
            payload_n: &payload,
        };
        statics_batch(&arm, input, self_weight, st.out()).unwrap();
        let loaded = general(&arm, &EffectSet::empty(), input, opts);
        let input0 = BatchInput {
            alpha_deg: &alpha,
            payload_n: &zero,
        };
        let unloaded = general(&arm, &EffectSet::empty(), input0, opts);
        assert_eq!(st.force_n, loaded.force_n);
        assert_eq!(st.reaction_n, loaded.reaction_n);
        assert_eq!(st.force0_n, unloaded.force_n);
        assert_eq!(st.reaction0_n, unloaded.reaction_n);
        assert_eq!(st.length_mm, loaded.length_mm);
        if !self_weight {
            assert!(st.force0_n.iter().all(|&f| f == 0.0));
        }
    }
    let mut st = StaticsBuffers::new(1, n);
    let err = statics_batch(
        &arm,
        BatchInput {
            alpha_deg: &[80.0, 10.0, f64::NAN],
            payload_n: &[0.0, 0.0],
        },
        true,
        st.out(),
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "pose row 0: alpha_deg has a non-finite value"
    );
}

/// The taken-up codes (6 play, 7 clearance) build taken-up gaps; the sensitivity path solves
/// them like the solver; the FE model refuses them by name.
#[test]
fn taken_up_codes_in_every_path() {
    let arm = example_arm();
    let n = arm.n();
    let play = Effect::from_code(6, 1, 0.2).unwrap();
    let clear = Effect::from_code(7, 2, 0.15).unwrap();
    assert_eq!(play.unloaded(), Some(Unloaded::TakenUp));
    assert_eq!(clear.unloaded(), Some(Unloaded::TakenUp));
    assert_eq!(
        Effect::from_code(2, 1, 0.2).unwrap().unloaded(),
        Some(Unloaded::Centred)
    );
    assert_eq!(play.label(), "actuator_play@M2");
    // Centred and taken-up at one place are the same effect twice.
    let twice = EffectSet::new(
        &arm,
        vec![play.clone(), Effect::from_code(2, 1, 0.1).unwrap()],
    );
    assert!(matches!(twice, Err(ArmError::InvalidEffect { .. })));

    let poses = [[80.0, 10.0, 0.0], [95.0, 20.0, -5.0]];
    let (alpha, payload) = batch(&arm, &poses, &[2.0, 5.0]);
    let input = BatchInput {
        alpha_deg: &alpha,
        payload_n: &payload,
    };
    let solved = run(
        &arm,
        vec![play.clone(), clear.clone()],
        (&alpha, &payload),
        ExtraDeformations::none(),
    );
    let model = [
        (Place { code: 6, index: 1 }, 0.2),
        (Place { code: 7, index: 2 }, 0.15),
    ];
    let c = n_channels(n);
    let (mut y, mut jac) = (vec![0.0; 2 * c], vec![0.0; 2 * c]);
    let probes = [Place { code: 6, index: 1 }];
    jacobian_batch(
        &arm,
        &model,
        &probes,
        input,
        SolveOptions::default(),
        &mut y,
        &mut jac,
    )
    .unwrap();
    // The Jacobian's path and the block kernel close the triangles by different formulas
    // (the kernel without the cancellation of cos′ − cos where no geometric effect touches a
    // link): they agree to rounding carried by ~1 m levers, ~1e-12 mm; 1e-9 mm bounds it.
    for r in 0..2 {
        assert!((y[r * c] - solved.dx_mm[r]).abs() < 1e-9);
        assert!((y[r * c + 1] - solved.dy_mm[r]).abs() < 1e-9);
    }

    let set = EffectSet::new_unchecked(&arm, vec![clear]).unwrap();
    let err = FemModel::new(&arm, &set, &[], FemOptions::default()).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("joint_clearance@O3 (taken up)") && msg.contains("centred"),
        "{msg}"
    );
}
