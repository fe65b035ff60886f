//! Compensation (docs/compensation.md): the compensated pose, solved under the payload, puts the
//! measure point on the nominal one (and keeps the last link's angle for n ≥ 3); no load, no
//! change; the change is the smallest one for n > 3; stroke limits, singular poses and bad
//! input are reported.

#![allow(clippy::unwrap_used, clippy::needless_range_loop)] // test code: a failure should panic
mod common;
use arm_core::compensate::{CompensateStatus, Compensator, JacobianKind, PoseResult};
use arm_core::effects::{
    ActuatorCompliance, ActuatorPlay, BaseCompliance, JointClearance, LinkBending, MountCompliance,
    Unloaded,
};
use arm_core::examples::example_arm;
use arm_core::geometry::angle;
use arm_core::kinematics::Frames;
use common::{act, link, rad, v};
use std::ops::Mul;

use arm_core::{
    compensate_batch, Arm, ArmError, BatchInput, CompensateBuffers, CompensateOptions, Effect,
    EffectSet, SolveOptions, Workspace, V2,
};

/// A 1-link arm (a boom on one actuator).
fn one_link() -> Arm {
    Arm::new(
        9.81,
        v(0.0, 0.0),
        v(200.0, -60.0),
        v(-100.0, -150.0),
        vec![link(
            v(700.0, 0.0),
            v(150.0, 40.0),
            v(0.0, 0.0),
            v(320.0, -5.0),
            6.0,
        )],
        vec![act(4000.0, 2.0)],
        v(650.0, -30.0),
    )
    .unwrap()
}

/// The 2-link arm of the Python tests (`tests/arms.py`).
fn two_link() -> Arm {
    Arm::new(
        9.81,
        v(0.0, 0.0),
        v(180.0, -60.0),
        v(-150.0, -200.0),
        vec![
            link(
                v(600.0, 20.0),
                v(120.0, 50.0),
                v(-60.0, -40.0),
                v(280.0, 0.0),
                5.0,
            ),
            link(
                v(450.0, 0.0),
                v(100.0, -45.0),
                v(0.0, 0.0),
                v(200.0, -5.0),
                2.5,
            ),
        ],
        vec![act(5000.0, 2.0), act(2500.0, 1.0)],
        v(420.0, -30.0),
    )
    .unwrap()
}

/// A 4-link arm (the Python tests' `four_link_arm`): one more joint than the conditions.
fn four_link() -> Arm {
    Arm::new(
        9.81,
        v(0.0, 0.0),
        v(220.0, -50.0),
        v(-200.0, -250.0),
        vec![
            link(
                v(450.0, 0.0),
                v(100.0, 50.0),
                v(-50.0, -45.0),
                v(200.0, -3.0),
                4.0,
            ),
            link(
                v(350.0, 0.0),
                v(90.0, -50.0),
                v(-100.0, 10.0),
                v(160.0, -2.0),
                2.5,
            ),
            link(
                v(300.0, 0.0),
                v(70.0, -45.0),
                v(-80.0, 15.0),
                v(140.0, -2.0),
                1.8,
            ),
            link(
                v(250.0, 0.0),
                v(50.0, -35.0),
                v(0.0, 0.0),
                v(120.0, -2.0),
                1.0,
            ),
        ],
        vec![
            act(3000.0, 1.5),
            act(2500.0, 1.2),
            act(2000.0, 0.9),
            act(1500.0, 0.7),
        ],
        v(220.0, -30.0),
    )
    .unwrap()
}

/// Elastic effects everywhere they fit, plus a clearance taken up when unloaded.
fn effects(arm: &Arm) -> EffectSet {
    let n = arm.n();
    let mut e = vec![
        Effect::ActuatorCompliance(ActuatorCompliance {
            actuator: 0,
            stiffness: 900.0,
        }),
        Effect::MountCompliance(MountCompliance {
            actuator: n - 1,
            stiffness: 700.0,
        }),
        Effect::LinkBending(LinkBending {
            link: n - 1,
            ei: 1e9,
        }),
        Effect::BaseCompliance(BaseCompliance { stiffness: 5e7 }),
        Effect::JointClearance(JointClearance {
            joint: n - 1,
            clearance: 0.2,
            unloaded: Unloaded::TakenUp,
        }),
    ];
    if n >= 2 {
        e.push(Effect::LinkBending(LinkBending { link: 0, ei: 3e9 }));
    }
    EffectSet::new(arm, e).unwrap()
}

/// (loaded measure point, loaded last angle) of `alpha` (rad) under `payload`.
fn loaded(arm: &Arm, eff: &EffectSet, alpha: &[f64], payload: V2, sw: bool) -> (V2, f64) {
    let mut ws = Workspace::new(arm);
    let opts = SolveOptions {
        self_weight: sw,
        nan_on_failure: false,
    };
    ws.solve(arm, eff, alpha, payload, opts, 0).unwrap();
    (ws.frames.measure + ws.dmeasure, ws.new_alpha[arm.n() - 1])
}

fn nominal_point(arm: &Arm, alpha: &[f64]) -> V2 {
    let mut fr = Frames::new(arm.n());
    fr.fill(arm, alpha);
    fr.measure
}

fn run(
    arm: &Arm,
    eff: &EffectSet,
    alpha: &[f64],
    payload: V2,
    opts: &CompensateOptions,
) -> (PoseResult, Vec<f64>) {
    let mut c = Compensator::new(arm);
    let res = c.compensate(arm, eff, alpha, payload, opts, 0).unwrap();
    (res, c.alpha().to_vec())
}

/// The Jacobian kinds an `n`-link arm accepts.
fn kinds(n: usize) -> Vec<JacobianKind> {
    let mut k = vec![JacobianKind::Auto, JacobianKind::FiniteDifference];
    if n == 2 || n == 3 {
        k.push(JacobianKind::Rigid);
    }
    k
}

fn poses(n: usize) -> Vec<Vec<f64>> {
    match n {
        1 => vec![vec![20.0], vec![5.0], vec![40.0]],
        2 => vec![vec![60.0, 5.0], vec![80.0, -10.0], vec![45.0, 20.0]],
        3 => vec![
            vec![90.0, 10.0, 0.0],
            vec![70.0, 20.0, -10.0],
            vec![100.0, -5.0, 5.0],
        ],
        _ => vec![
            vec![80.0, 20.0, -5.0, -15.0],
            vec![70.0, 30.0, 0.0, -10.0],
            vec![95.0, 5.0, 10.0, -20.0],
        ],
    }
}

#[test]
fn compensated_pose_lands_on_the_nominal_point_and_keeps_the_last_angle() {
    for arm in [two_link(), example_arm(), four_link()] {
        let n = arm.n();
        let eff = effects(&arm);
        for kind in kinds(n) {
            for sw in [true, false] {
                for pose in poses(n) {
                    let a0 = rad(&pose);
                    let p = v(0.0, -7.0 * arm.g);
                    let opts = CompensateOptions {
                        self_weight: sw,
                        jacobian: kind,
                        ..Default::default()
                    };
                    let (res, ac) = run(&arm, &eff, &a0, p, &opts);
                    assert_eq!(res.status, CompensateStatus::Ok, "n={n} {pose:?} {res:?}");
                    let target = nominal_point(&arm, &a0);
                    let (m_nom, _) = loaded(&arm, &eff, &a0, p, sw);
                    let (m, last) = loaded(&arm, &eff, &ac, p, sw);
                    // The uncompensated miss is large, so landing means something.
                    assert!(
                        (m_nom - target).norm() > 0.05,
                        "{}",
                        (m_nom - target).norm()
                    );
                    assert!((m - target).norm() < 1e-6, "n={n}: {}", (m - target).norm());
                    assert!(res.residual_mm < 1e-6);
                    if n >= 3 {
                        assert!((last - a0[n - 1]).abs() < 1e-9, "{}", last - a0[n - 1]);
                    }
                    assert!(res.iterations >= 1);
                    // Deflections of 10–35 mm here, far more than a real arm's; for n > 3 the
                    // count includes the steps back onto the conditions after each tangent step.
                    let most = if n > 3 {
                        40
                    } else if kind.resolve(n) == JacobianKind::Rigid {
                        12
                    } else {
                        6
                    };
                    assert!(res.iterations <= most, "{kind:?}: {} steps", res.iterations);
                }
            }
        }
    }
}

#[test]
fn rigid_and_exact_jacobians_agree_where_the_solution_is_unique() {
    for arm in [two_link(), example_arm()] {
        let eff = effects(&arm);
        for pose in poses(arm.n()) {
            let a0 = rad(&pose);
            let p = v(0.0, -5.0 * arm.g);
            let rigid = CompensateOptions::default();
            let exact = CompensateOptions {
                jacobian: JacobianKind::FiniteDifference,
                ..Default::default()
            };
            let (_, a) = run(&arm, &eff, &a0, p, &rigid);
            let (_, b) = run(&arm, &eff, &a0, p, &exact);
            for j in 0..arm.n() {
                assert!((a[j] - b[j]).abs() < 1e-11, "{} vs {}", a[j], b[j]);
            }
        }
    }
}

#[test]
fn zero_payload_without_self_weight_changes_nothing() {
    for arm in [one_link(), two_link(), example_arm(), four_link()] {
        let n = arm.n();
        // Centred gaps too: with no force at all they have no side to take.
        let mut e: Vec<Effect> = effects(&arm).effects().to_vec();
        e.push(Effect::ActuatorPlay(ActuatorPlay {
            actuator: 0,
            play: 0.3,
            unloaded: Unloaded::Centred,
        }));
        if n > 1 {
            e.push(Effect::JointClearance(JointClearance {
                joint: 0,
                clearance: 0.3,
                unloaded: Unloaded::Centred,
            }));
        }
        let eff = EffectSet::new(&arm, e).unwrap();
        let opts = CompensateOptions {
            self_weight: false,
            ..Default::default()
        };
        for pose in poses(n) {
            let a0 = rad(&pose);
            let (res, ac) = run(&arm, &eff, &a0, V2::zeros(), &opts);
            assert_eq!(res.status, CompensateStatus::Ok);
            assert_eq!(res.iterations, 0);
            assert_eq!(ac, a0);
            assert!(res.residual_mm < 1e-10, "{}", res.residual_mm); // rounding only
        }
    }
}

/// The exact Jacobian (m × n) of the conditions at `alpha`, by central differences.
fn exact_jacobian(arm: &Arm, eff: &EffectSet, alpha: &[f64], p: V2) -> Vec<Vec<f64>> {
    let n = arm.n();
    let s = arm.links[n - 1].next.norm();
    let h = 1e-6;
    let mut jac = vec![vec![0.0; n]; 3];
    for j in 0..n {
        let mut up = alpha.to_vec();
        let mut dn = alpha.to_vec();
        up[j] += h;
        dn[j] -= h;
        let (mu, au) = loaded(arm, eff, &up, p, true);
        let (md, ad) = loaded(arm, eff, &dn, p, true);
        jac[0][j] = (mu.x - md.x) / (2.0 * h);
        jac[1][j] = (mu.y - md.y) / (2.0 * h);
        jac[2][j] = s * (au - ad) / (2.0 * h);
    }
    jac
}

/// Back onto the conditions from `start` by Gauss–Newton with minimum-norm steps (no pull
/// towards the nominal): the nearest point of the solution set, to first order.
fn project(arm: &Arm, eff: &EffectSet, start: &[f64], a0: &[f64], p: V2) -> Vec<f64> {
    let n = arm.n();
    let s = arm.links[n - 1].next.norm();
    let target = nominal_point(arm, a0);
    let mut a = start.to_vec();
    for _ in 0..20 {
        let (m, last) = loaded(arm, eff, &a, p, true);
        let r = [m.x - target.x, m.y - target.y, s * (last - a0[n - 1])];
        if r.iter().map(|x| x * x).sum::<f64>().sqrt() < 1e-11 {
            return a;
        }
        let j = exact_jacobian(arm, eff, &a, p);
        // Δ = −Jᵀ(JJᵀ)⁻¹r, with the 3×3 Gram matrix inverted by nalgebra.
        let jm = nalgebra::DMatrix::from_fn(3, n, |i, k| j[i][k]);
        let gram = &jm * jm.transpose();
        let y = gram
            .try_inverse()
            .unwrap()
            .mul(&nalgebra::DVector::from_row_slice(&r));
        let d = jm.transpose() * y;
        for k in 0..n {
            a[k] -= d[k];
        }
    }
    panic!("projection did not converge");
}

#[test]
fn four_links_spend_the_spare_freedom_on_the_smallest_change() {
    let arm = four_link();
    let eff = effects(&arm);
    let p = v(0.0, -7.0 * arm.g);
    for kind in [JacobianKind::Auto, JacobianKind::FiniteDifference] {
        for pose in poses(4) {
            let a0 = rad(&pose);
            let opts = CompensateOptions {
                jacobian: kind,
                ..Default::default()
            };
            let (res, ac) = run(&arm, &eff, &a0, p, &opts);
            assert_eq!(res.status, CompensateStatus::Ok);
            let change = |a: &[f64]| -> f64 {
                a.iter()
                    .zip(&a0)
                    .map(|(x, y)| (x - y) * (x - y))
                    .sum::<f64>()
                    .sqrt()
            };
            let best = change(&ac);
            assert!(best > 1e-5, "a change worth testing: {best}");
            // The null space of the exact Jacobian at the solution (one direction).
            let j = exact_jacobian(&arm, &eff, &ac, p);
            let jm = nalgebra::DMatrix::from_fn(3, 4, |i, k| j[i][k]);
            let eig = (jm.transpose() * &jm).symmetric_eigen();
            let k0 = eig.eigenvalues.imin();
            let null: Vec<f64> = (0..4).map(|k| eig.eigenvectors[(k, k0)]).collect();
            assert!((&jm * nalgebra::DVector::from_row_slice(&null)).norm() < 1e-6 * 500.0);
            // First-order condition: the change has no component along the null space.
            let d: Vec<f64> = ac.iter().zip(&a0).map(|(x, y)| x - y).collect();
            let along: f64 = d.iter().zip(&null).map(|(x, y)| x * y).sum();
            assert!(along.abs() < 1e-4 * best, "{kind:?}: {along} of {best}");
            // Moving along it, and back onto the conditions, only makes the change larger.
            for eps in [-1e-3, -1e-4, 1e-4, 1e-3] {
                let start: Vec<f64> = ac.iter().zip(&null).map(|(x, z)| x + eps * z).collect();
                let other = project(&arm, &eff, &start, &a0, p);
                let (m, last) = loaded(&arm, &eff, &other, p, true);
                assert!((m - nominal_point(&arm, &a0)).norm() < 1e-8);
                assert!((last - a0[3]).abs() < 1e-10);
                assert!(
                    change(&other) > best,
                    "{kind:?} eps={eps}: {} <= {best}",
                    change(&other)
                );
            }
        }
    }
}

#[test]
fn one_link_is_a_least_squares_fit_of_the_point() {
    let arm = one_link();
    let eff = effects(&arm);
    let p = v(0.0, -20.0 * arm.g);
    for pose in poses(1) {
        let a0 = rad(&pose);
        let (res, ac) = run(&arm, &eff, &a0, p, &CompensateOptions::default());
        assert_eq!(res.status, CompensateStatus::Ok);
        let target = nominal_point(&arm, &a0);
        let miss = |a: f64| (loaded(&arm, &eff, &[a], p, true).0 - target).norm();
        let best = miss(ac[0]);
        assert!((best - res.residual_mm).abs() < 1e-12);
        assert!(best < miss(a0[0]));
        // A point the boom cannot hold: what is left is radial, and any turn adds to it.
        assert!(best > 1e-3, "{best}");
        for d in [-1e-5, 1e-5] {
            assert!(miss(ac[0] + d) > best);
        }
    }
}

#[test]
fn a_pose_beyond_the_stroke_is_reported_not_returned() {
    let mut arm = example_arm();
    let eff = effects(&arm);
    let a0 = rad(&[90.0, 10.0, 0.0]);
    let mut fr = Frames::new(3);
    fr.fill(&arm, &a0);
    // Actuator 2 held at exactly its nominal length: any compensation leaves the stroke.
    let l2 = fr.length(1);
    arm.actuator_mut(1).unwrap().min_length = Some(l2 - 1e-9);
    arm.actuator_mut(1).unwrap().max_length = Some(l2 + 1e-9);
    let p = v(0.0, -5.0 * arm.g);
    let (res, _) = run(&arm, &eff, &a0, p, &CompensateOptions::default());
    assert_eq!(res.status, CompensateStatus::OutOfStroke);
    assert_eq!(res.actuator, 2);
    // In a batch the row is NaN, the others are fine: the same pose without a payload (and
    // without self-weight) needs no change and stays within the stroke.
    let alpha = [90.0, 10.0, 0.0, 90.0, 10.0, 0.0];
    let payload = [0.0, -5.0 * arm.g, 0.0, 0.0];
    let mut b = CompensateBuffers::new(2, 3);
    compensate_batch(
        &arm,
        &eff,
        BatchInput {
            alpha_deg: &alpha,
            payload_n: &payload,
        },
        CompensateOptions {
            self_weight: false,
            ..Default::default()
        },
        b.out(),
    )
    .unwrap();
    assert_eq!(b.status, vec![CompensateStatus::OutOfStroke.code(), 0]);
    assert!(b.alpha_deg[..3].iter().all(|x| x.is_nan()));
    assert!(b.length_mm[..3].iter().all(|x| x.is_nan()));
    assert!(b.alpha_deg[3..].iter().all(|x| x.is_finite()));
    assert_eq!(b.actuator, vec![2, 0]);
}

#[test]
fn near_singular_poses_are_reported() {
    let arm = example_arm();
    let eff = effects(&arm);
    let p = v(0.0, -5.0 * arm.g);
    // Actuator 1's line through O1: A1 on the far side of O1 from B0.
    let through = angle(arm.b0 - arm.o1) - angle(arm.links[0].a) + std::f64::consts::PI;
    for offset in [0.0, 1e-4, 5e-3] {
        let a0 = vec![through + offset, 10f64.to_radians(), 0.0];
        let (res, _) = run(&arm, &eff, &a0, p, &CompensateOptions::default());
        assert_eq!(res.status, CompensateStatus::NearSingular, "{offset}");
        assert_eq!(res.actuator, 1);
    }
    // Well away from it the same arm compensates.
    let a0 = vec![through + 0.5, 10f64.to_radians(), 0.0];
    let (res, _) = run(&arm, &eff, &a0, p, &CompensateOptions::default());
    assert_eq!(res.status, CompensateStatus::Ok);
}

#[test]
fn a_step_budget_too_small_is_no_convergence() {
    let arm = example_arm();
    let eff = effects(&arm);
    let opts = CompensateOptions {
        max_iter: 1,
        ..Default::default()
    };
    let (res, _) = run(&arm, &eff, &rad(&[90.0, 10.0, 0.0]), v(0.0, -60.0), &opts);
    assert_eq!(res.status, CompensateStatus::NoConvergence);
    assert!(res.residual_mm.is_finite() && res.residual_mm > 0.0);
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let arm = example_arm();
    let eff = EffectSet::empty();
    let call = |alpha: &[f64], payload: &[f64], opts: CompensateOptions| {
        let rows = payload.len() / 2;
        let mut b = CompensateBuffers::new(rows, 3);
        compensate_batch(
            &arm,
            &eff,
            BatchInput {
                alpha_deg: alpha,
                payload_n: payload,
            },
            opts,
            b.out(),
        )
    };
    let ok = CompensateOptions::default();
    assert!(matches!(
        call(&[90.0, 10.0], &[0.0, -10.0], ok),
        Err(ArmError::Shape { .. })
    ));
    assert!(matches!(
        call(
            &[90.0, 10.0, 0.0, 80.0, f64::NAN, 0.0],
            &[0.0, -1.0, 0.0, -1.0],
            ok
        ),
        Err(ArmError::NonFinite { row: 1, .. })
    ));
    assert!(matches!(
        call(&[90.0, 10.0, 0.0], &[0.0, f64::INFINITY], ok),
        Err(ArmError::NonFinite { row: 0, .. })
    ));
    for bad in [
        CompensateOptions { max_iter: 0, ..ok },
        CompensateOptions {
            tol_mm: f64::NAN,
            ..ok
        },
        CompensateOptions {
            min_moment_ratio: 1.5,
            ..ok
        },
    ] {
        assert!(matches!(
            call(&[90.0, 10.0, 0.0], &[0.0, -1.0], bad),
            Err(ArmError::InvalidOption(_))
        ));
    }
    // The quasi-Newton Jacobian would shift the answer of a 4-link (or 1-link) arm.
    let quasi = CompensateOptions {
        jacobian: JacobianKind::Rigid,
        ..ok
    };
    for arm in [four_link(), one_link()] {
        let mut c = Compensator::new(&arm);
        let a0 = vec![0.3; arm.n()];
        let e = c.compensate(&arm, &eff, &a0, V2::zeros(), &quasi, 0);
        assert!(matches!(e, Err(ArmError::InvalidOption(_))), "{e:?}");
    }
    // A wrong-length pose at the per-pose API.
    let mut c = Compensator::new(&arm);
    assert!(c
        .compensate(&arm, &eff, &[0.1, 0.2], V2::zeros(), &ok, 0)
        .is_err());
}

#[test]
fn the_parallel_batch_equals_pose_by_pose() {
    let arm = example_arm();
    let eff = effects(&arm);
    let rows = 1500;
    let mut alpha = Vec::with_capacity(3 * rows);
    let mut payload = Vec::with_capacity(2 * rows);
    for k in 0..rows {
        let t = k as f64 / rows as f64;
        alpha.extend([
            60.0 + 50.0 * t,
            30.0 * (7.0 * t).sin(),
            -10.0 + 20.0 * (3.0 * t).fract(),
        ]);
        payload.extend([0.0, -9.81 * 7.0 * (5.0 * t).fract()]);
    }
    let mut b = CompensateBuffers::new(rows, 3);
    let input = BatchInput {
        alpha_deg: &alpha,
        payload_n: &payload,
    };
    compensate_batch(&arm, &eff, input, CompensateOptions::default(), b.out()).unwrap();
    let mut c = Compensator::new(&arm);
    for k in (0..rows).step_by(97) {
        let a0 = rad(&alpha[3 * k..3 * k + 3]);
        let p = v(payload[2 * k], payload[2 * k + 1]);
        let res = c
            .compensate(&arm, &eff, &a0, p, &CompensateOptions::default(), k)
            .unwrap();
        assert_eq!(b.status[k], res.status.code());
        assert_eq!(b.iterations[k], res.iterations);
        if res.status == CompensateStatus::Ok {
            for j in 0..3 {
                let want = alpha[3 * k + j] + (c.alpha()[j] - a0[j]).to_degrees();
                assert_eq!(b.alpha_deg[3 * k + j], want);
                assert_eq!(b.length_mm[3 * k + j], c.length()[j]);
            }
        }
    }
    let ok = b.status.iter().filter(|s| **s == 0).count();
    assert!(ok > rows / 2, "{ok} of {rows} ok");
}
