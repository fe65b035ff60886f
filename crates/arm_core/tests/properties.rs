//! Physical properties of the core, on random perturbations of the example arm and random
//! poses: frame round trips, equilibrium of every body, zero load → zero deflection,
//! linearity of the elastic effects, clearance along the joint force, bounded play, base tilt,
//! reciprocity.

#![allow(clippy::unwrap_used, clippy::needless_range_loop)] // test code: a failure should panic
mod common;
use arm_core::effects::{
    ActuatorCompliance, ActuatorPlay, BaseCompliance, JointClearance, LinkBending, MountCompliance,
    Unloaded,
};
use arm_core::examples::example_arm;
use arm_core::geometry::{cross, rot};
use arm_core::kinematics::{angles_from_lengths, inverse_kinematics, Frames};
use arm_core::{Actuator, Arm, Effect, EffectSet, Link, SolveOptions, Workspace, V2};
use common::v;
use proptest::prelude::*;

/// The example arm of the contract (`arm_core::examples`), geometry scaled by `s` (about O_1,
/// the origin) and stiffness by `k`, with the chassis pivot at `pivot` and no stroke or force
/// limits (the solver does not read them; strokes would have to scale too).
fn arm(s: f64, k: f64, pivot: V2) -> Arm {
    let ex = example_arm();
    let links = ex
        .links
        .iter()
        .map(|l| Link {
            next: l.next * s,
            a: l.a * s,
            b: l.b * s,
            c: l.c * s,
            mass_kg: l.mass_kg,
        })
        .collect();
    let acts = (0..ex.n())
        .map(|i| ex.actuator(i).unwrap())
        .map(|a| Actuator {
            stiffness: a.stiffness * k,
            mass_kg: a.mass_kg,
            min_length: None,
            max_length: None,
            max_force: None,
        })
        .collect();
    Arm::new(ex.g, ex.o1, ex.b0 * s, pivot, links, acts, ex.measure * s).unwrap()
}

fn rad(a: [f64; 3]) -> Vec<f64> {
    a.iter().map(|d| d.to_radians()).collect()
}

fn elastic() -> Vec<Effect> {
    vec![
        Effect::ActuatorCompliance(ActuatorCompliance {
            actuator: 0,
            stiffness: 900.0,
        }),
        Effect::MountCompliance(MountCompliance {
            actuator: 1,
            stiffness: 700.0,
        }),
        Effect::LinkBending(LinkBending { link: 1, ei: 2e9 }),
        Effect::LinkBending(LinkBending { link: 2, ei: 1e9 }),
        Effect::BaseCompliance(BaseCompliance { stiffness: 5e7 }),
    ]
}

fn all_effects() -> Vec<Effect> {
    let mut e = elastic();
    e.push(Effect::JointClearance(JointClearance {
        joint: 2,
        clearance: 0.2,
        unloaded: Unloaded::Centred,
    }));
    e.push(Effect::JointClearance(JointClearance {
        joint: 0,
        clearance: 0.1,
        unloaded: Unloaded::Centred,
    }));
    e.push(Effect::ActuatorPlay(ActuatorPlay {
        actuator: 2,
        play: 0.15,
        unloaded: Unloaded::Centred,
    }));
    e
}

struct Out {
    d: V2,
    dalpha: Vec<f64>,
    ws: Workspace,
}

fn solve(arm: &Arm, eff: Vec<Effect>, alpha: &[f64], p: V2, self_weight: bool) -> Out {
    let set = EffectSet::new(arm, eff).unwrap();
    let mut ws = Workspace::new(arm);
    ws.solve(
        arm,
        &set,
        alpha,
        p,
        SolveOptions {
            self_weight,
            ..Default::default()
        },
        0,
    )
    .unwrap();
    let dalpha = ws.new_alpha.iter().zip(alpha).map(|(a, b)| a - b).collect();
    Out {
        d: ws.dmeasure,
        dalpha,
        ws,
    }
}

/// The force (N) that link j+1 presses onto body j (the chassis for j = 0) at joint O_{j+1}, in
/// the loaded state on the undeformed pose: −R_{j+1} of docs/model.md §1 (0-based `j`, as
/// `Forces::r[j]`). Worked out here without `arm_core::statics`: links j+1…n as one free body,
/// loaded by the payload at the load point, its weights (the links; half of actuator j+1 at its
/// pin A; both halves of every actuator inside it), actuator j+1's axial force along its line
/// and the joint force. Moments about the joint give the actuator force, the force balance the
/// joint force.
fn joint_press(arm: &Arm, alpha: &[f64], j: usize, p: V2, self_weight: bool) -> V2 {
    let n = arm.n();
    let mut fr = Frames::new(n);
    fr.fill(arm, alpha);
    let w = |mass: f64| {
        if self_weight {
            v(0.0, -mass * arm.g)
        } else {
            V2::zeros()
        }
    };
    let mut loads = vec![(fr.joint[n], p)];
    for k in j..n {
        loads.push((fr.c[k], w(arm.links[k].mass_kg)));
        loads.push((fr.a[k], w(0.5 * arm.actuator(k).unwrap().mass_kg)));
        if k > j {
            loads.push((fr.b[k], w(0.5 * arm.actuator(k).unwrap().mass_kg)));
        }
    }
    let o = fr.joint[j];
    let e = (fr.a[j] - fr.b[j]).normalize();
    let q: V2 = loads.iter().map(|l| l.1).sum();
    let t: f64 = loads.iter().map(|l| cross(l.0 - o, l.1)).sum();
    let f = -t / cross(fr.a[j] - o, e); // along e, compression +
    q + f * e // = −R_j, since R_j + q + f·e = 0
}

fn poses() -> impl Strategy<Value = [f64; 3]> {
    (60.0..110.0f64, 0.0..30.0f64, -10.0..10.0f64).prop_map(|(a, b, c)| [a, b, c])
}

fn arms() -> impl Strategy<Value = Arm> {
    (0.8..1.25f64, 0.3..3.0f64, -300.0..100.0f64, -300.0..0.0f64)
        .prop_map(|(s, k, px, py)| arm(s, k, v(px, py)))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// T·T⁻¹ = I: local → global → local returns every point of every link.
    #[test]
    fn frame_round_trip(arm in arms(), pose in poses(), px in -500.0..500.0f64, py in -500.0..500.0f64) {
        let mut fr = Frames::new(arm.n());
        fr.fill(&arm, &rad(pose));
        let p = v(px, py);
        for i in 0..arm.n() {
            let g = fr.joint[i] + fr.to_global(i, p);
            let back = fr.to_local(i, g - fr.joint[i]);
            prop_assert!((back - p).norm() < 1e-10 * (1.0 + p.norm()));
            // the named points obey relation 1
            let a = fr.joint[i] + rot(pose[i].to_radians(), arm.links[i].a);
            prop_assert!((a - fr.a[i]).norm() < 1e-10);
        }
    }

    /// Every link is in equilibrium under weights, actuator forces, reactions and payload.
    #[test]
    fn every_body_in_equilibrium(arm in arms(), pose in poses(), m in 0.0..8.0f64) {
        let p = v(0.0, -m * arm.g);
        let out = solve(&arm, vec![], &rad(pose), p, true);
        let (fr, lines, f) = (&out.ws.frames, &out.ws.lines, &out.ws.loaded);
        let n = arm.n();
        let w = |mass: f64| v(0.0, -mass * arm.g);
        for i in 0..n {
            let mut loads = vec![
                (fr.c[i], w(arm.links[i].mass_kg)),
                (fr.a[i], w(0.5 * arm.actuator(i).unwrap().mass_kg)),
                (fr.a[i], f.f[i] * lines.e[i]),
                (fr.joint[i], f.r[i]),
            ];
            if i + 1 < n {
                loads.push((fr.b[i + 1], w(0.5 * arm.actuator(i + 1).unwrap().mass_kg)));
                loads.push((fr.b[i + 1], -f.f[i + 1] * lines.e[i + 1]));
                loads.push((fr.joint[i + 1], -f.r[i + 1]));
            } else {
                loads.push((fr.joint[n], p));
            }
            let sum: V2 = loads.iter().map(|l| l.1).sum();
            let moment: f64 = loads.iter().map(|l| cross(l.0, l.1)).sum();
            let scale: f64 = loads.iter().map(|l| l.1.norm()).sum::<f64>();
            prop_assert!(sum.norm() < 1e-10 * scale, "force residual {sum:?} on link {i}");
            prop_assert!(moment.abs() < 1e-10 * scale * 2000.0, "moment residual {moment} on link {i}");
        }
    }

    /// No payload, no deflection: the elastic effects with self-weight, every effect without.
    #[test]
    fn zero_payload_zero_deflection(arm in arms(), pose in poses()) {
        for (eff, sw) in [(elastic(), true), (all_effects(), false)] {
            let out = solve(&arm, eff, &rad(pose), V2::zeros(), sw);
            prop_assert!(out.d.norm() < 1e-9, "displacement {:?}", out.d);
            prop_assert!(out.dalpha.iter().all(|d| d.abs() < 1e-12), "{:?}", out.dalpha);
        }
    }

    /// Elastic effects are linear in the load to second order: the defect of
    /// d(2P) − 2·d(P) falls like P² (factor ~100 for P/10).
    #[test]
    fn elastic_deflection_linear_in_load(arm in arms(), pose in poses(), m in 1.0..4.0f64) {
        let defect = |m: f64| {
            let p = v(0.0, -m * arm.g);
            let d1 = solve(&arm, elastic(), &rad(pose), p, true).d;
            let d2 = solve(&arm, elastic(), &rad(pose), 2.0 * p, true).d;
            (d2 - 2.0 * d1).norm()
        };
        let (big, small) = (defect(m), defect(m / 10.0));
        let d = solve(&arm, elastic(), &rad(pose), v(0.0, -m * arm.g), true).d.norm();
        prop_assert!(big < 0.2 * d, "nonlinear defect {big} vs deflection {d}");
        prop_assert!(small < big / 30.0 + 1e-9, "defect {small} at m/10 vs {big} at m");
    }

    /// Clearance moves a joint by c along the force the link presses onto the body before it
    /// (docs/model.md §4: a global offset along −R of the loaded, undeformed statics); with
    /// rigid actuators the links beyond the joint follow as one rigid body. Play changes an
    /// actuator by at most its play. Neither grows with the load (stiff arm, no self-weight:
    /// only the gaps move it).
    #[test]
    fn clearance_and_play_bounded(arm in arms(), pose in poses(), m in 0.5..8.0f64, c in 0.0..0.5f64) {
        let stiff = |e: Effect| {
            let mut v: Vec<Effect> = (0..3)
                .map(|a| Effect::ActuatorCompliance(ActuatorCompliance { actuator: a, stiffness: 1e12 }))
                .collect();
            v.push(e);
            v
        };
        let (alpha, load) = (rad(pose), v(0.0, -m * arm.g));
        for j in 0..3 {
            let e = Effect::JointClearance(JointClearance { joint: j, clearance: c, unloaded: Unloaded::Centred });
            let a = solve(&arm, stiff(e.clone()), &alpha, load, false);
            let b = solve(&arm, stiff(e.clone()), &alpha, 3.0 * load, false);
            let sw = solve(&arm, stiff(e), &alpha, load, true);
            // The pin sits c from the bore centre, towards where the joint force of the loaded
            // state (with and without self-weight) pushes it; that force found independently.
            for (out, weights) in [(&a, false), (&sw, true)] {
                let press = joint_press(&arm, &alpha, j, load, weights);
                prop_assume!(press.norm() > 1e-6); // else no direction (never met in practice)
                let want = press * (c / press.norm());
                let off = out.ws.def.joint_offset[j];
                prop_assert!(
                    (off - want).norm() <= 1e-9 * c,
                    "O{}: offset {off:?}, expected {want:?} (self-weight {weights})", j + 1
                );
            }
            // Rigid actuators: the joint moves by the offset, the links before it stay, and the
            // links from it on turn by one angle about it, carrying the measurement point.
            let (fr, turn) = (&a.ws.frames, a.dalpha[j]);
            let lever = fr.measure - fr.joint[j];
            let rigid = a.ws.def.joint_offset[j] + rot(turn, lever) - lever;
            prop_assert!((a.d - rigid).norm() < 1e-6, "O{}: moved {:?}, rigid {rigid:?}", j + 1, a.d);
            for k in 0..3 {
                let want = if k < j { 0.0 } else { turn };
                prop_assert!((a.dalpha[k] - want).abs() < 1e-9, "O{}: dα{} {} vs {want}", j + 1, k + 1, a.dalpha[k]);
            }
            prop_assert!((a.d - b.d).norm() < 1e-6 * (1.0 + a.d.norm()), "clearance grew with load");
            let p = Effect::ActuatorPlay(ActuatorPlay { actuator: j, play: c, unloaded: Unloaded::Centred });
            let a = solve(&arm, stiff(p.clone()), &rad(pose), v(0.0, -m * arm.g), false);
            let b = solve(&arm, stiff(p), &rad(pose), v(0.0, -3.0 * m * arm.g), false);
            let dl = a.ws.new_length[j] - a.ws.lines.length[j];
            prop_assert!(dl.abs() <= c + 1e-6, "play length change {dl} > {c}");
            prop_assert!((a.d - b.d).norm() < 1e-6 * (1.0 + a.d.norm()), "play grew with load");
        }
    }

    /// The chassis tilts by ΔM/k and, with rigid actuators, every link turns with it.
    #[test]
    fn base_tilt_is_moment_over_stiffness(arm in arms(), pose in poses(), m in 0.5..8.0f64, k in 1e7..1e9f64) {
        let mut eff: Vec<Effect> = (0..3)
            .map(|a| Effect::ActuatorCompliance(ActuatorCompliance { actuator: a, stiffness: 1e13 }))
            .collect();
        eff.push(Effect::BaseCompliance(BaseCompliance { stiffness: k }));
        let p = v(0.0, -m * arm.g);
        let out = solve(&arm, eff, &rad(pose), p, true);
        let dm = cross(out.ws.frames.joint[3] - arm.pivot, p);
        for d in &out.dalpha {
            prop_assert!((d - dm / k).abs() < 1e-6 * (dm / k).abs() + 1e-12, "{d} vs {}", dm / k);
        }
    }

    /// Maxwell–Betti: the effector compliance of the elastic model is symmetric.
    #[test]
    fn compliance_is_symmetric(arm in arms(), pose in poses()) {
        // Measure at the load point itself.
        let mut arm = arm;
        arm.measure = arm.links[2].next;
        let h = 1.0; // N; small enough that second-order terms are ~1e-7 relative
        let col = |p: V2| {
            let plus = solve(&arm, elastic(), &rad(pose), p * h, false).d;
            let minus = solve(&arm, elastic(), &rad(pose), -p * h, false).d;
            (plus - minus) / (2.0 * h)
        };
        let cx = col(v(1.0, 0.0));
        let cy = col(v(0.0, 1.0));
        let scale = cx.x.abs().max(cy.y.abs());
        prop_assert!((cx.y - cy.x).abs() < 1e-6 * scale, "C_yx {} vs C_xy {}", cx.y, cy.x);
        prop_assert!(cx.x > 0.0 && cy.y > 0.0, "compliance must be positive definite on the diagonal");
    }

    /// Angles from lengths inverts the forward lengths; IK inverts forward kinematics.
    #[test]
    fn kinematic_inverses(arm in arms(), pose in poses()) {
        let alpha = rad(pose);
        let mut fr = Frames::new(3);
        fr.fill(&arm, &alpha);
        let lengths: Vec<f64> = (0..3).map(|i| fr.length(i)).collect();
        let reference: Vec<f64> = alpha.iter().map(|a| a + 0.05).collect();
        let mut back = vec![0.0; 3];
        angles_from_lengths(&arm, &lengths, &reference, 0, &mut back).unwrap();
        for (a, b) in alpha.iter().zip(&back) {
            prop_assert!((a - b).abs() < 1e-9);
        }
        let l = fr.joint[3];
        let elbow = if alpha[1] < alpha[0] { -1.0 } else { 1.0 };
        let mut ik = vec![0.0; 3];
        prop_assert!(inverse_kinematics(&arm, [l.x, l.y, alpha[2]], elbow, &mut ik).unwrap());
        for (a, b) in alpha.iter().zip(&ik) {
            prop_assert!((arm_core::geometry::wrap_pi(a - b)).abs() < 1e-9);
        }
    }
}

#[test]
fn singular_pose_is_refused_with_row() {
    let arm = arm(1.0, 1.0, v(0.0, 0.0));
    // Put A_1 on the line O_1–B_0: α1 such that the direction of A_1 equals that of B_0.
    let a1 = arm.links[0].a;
    let al = arm.b0.y.atan2(arm.b0.x) - a1.y.atan2(a1.x);
    let mut ws = Workspace::new(&arm);
    let err = ws
        .solve(
            &arm,
            &EffectSet::empty(),
            &[al, 0.1, 0.0],
            v(0.0, -10.0),
            SolveOptions::default(),
            7,
        )
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "pose row 7: actuator 1 passes through joint O1 (singular pose)"
    );
}

#[test]
fn duplicate_and_misplaced_effects_are_refused() {
    let arm = arm(1.0, 1.0, v(0.0, 0.0));
    let e = Effect::JointClearance(JointClearance {
        joint: 1,
        clearance: 0.1,
        unloaded: Unloaded::Centred,
    });
    let err = EffectSet::new(&arm, vec![e.clone(), e]).unwrap_err();
    assert!(err.to_string().contains("joint_clearance@O2"));
    let far = Effect::LinkBending(LinkBending { link: 5, ei: 1e9 });
    assert!(EffectSet::new(&arm, vec![far])
        .unwrap_err()
        .to_string()
        .contains("only 3 links"));
    let neg = Effect::ActuatorPlay(ActuatorPlay {
        actuator: 0,
        play: -0.1,
        unloaded: Unloaded::Centred,
    });
    assert!(EffectSet::new(&arm, vec![neg]).is_err());
}

#[test]
fn invalid_arm_names_the_key() {
    let mut links = arm(1.0, 1.0, v(0.0, 0.0)).links;
    links[1].mass_kg = f64::NAN;
    let base = arm(1.0, 1.0, v(0.0, 0.0));
    let err = Arm::new(
        9.81,
        base.o1,
        base.b0,
        base.pivot,
        links,
        (0..base.n())
            .map(|i| base.actuator(i).unwrap().clone())
            .collect(),
        base.measure,
    )
    .unwrap_err();
    assert!(err.to_string().contains("link[2].mass_kg"), "{err}");
}
