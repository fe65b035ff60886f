//! The FE model's rotary drives (docs/fem.md §5–§6): a torsional spring between the housing
//! (body i−1 at O_i) and the flange (link i at O_i), the link's beam clamped to the flange,
//! the drive's mass at O_i on body i−1, backlash as a gap in the spring's turn.
//!
//! * Against the analytic model on the bundled rotary and mixed arms (all three joints rotary;
//!   rotary, linear, linear), with rigid links and with each rotary effect — the drives'
//!   springs, `drive_compliance`, `base_compliance` (the housing of drive 1 turns with the
//!   chassis), `link_bending` (clamped; the housing of the next drive turns with the bent
//!   link's slope), `drive_backlash` and `joint_clearance` at rotary joints (gaps scaled with
//!   the load), and all at once: the relative difference shrinks in proportion to the load, to
//!   ≤ 1e-5 at 1/1000 of the payload (a linear model against an exact pose: second order).
//! * Torques, forces and pin forces equal the analytic statics to 1e-9 (both are statics of
//!   the undeformed pose of a statically determinate arm; rounding of a few dozen products).
//! * A link clamped to its drive bends as the textbook cantilever, on both sides of the
//!   flange: the tip moves by `P·L³/(3EI) + P·L²/k` to 1e-9 (Hermite beams are exact under
//!   nodal loads; the rest is rounding), and its moment is `P·(L − x)`.
//! * Large EI and EA tend to the rigid links, the difference ∝ 1/EI.
//! * Backlash closes on the side of the loaded torque; nothing loads it, it stays centred.
//! * What the FE model cannot do at a rotary joint is refused naming the effect.

#![allow(clippy::unwrap_used, clippy::needless_range_loop)] // test code: a failure should panic
mod common;
use arm_core::effects::{
    ActuatorPlay, BaseCompliance, DriveBacklash, DriveCompliance, DriveFriction, JointClearance,
    LinkBending, MountCompliance, Unloaded,
};
use arm_core::fem::{FemModel, FemOptions, FemWorkspace, LinkSection};
use arm_core::{Arm, ArmError, Drive, Effect, EffectSet, RotaryDrive, V2};
use common::{act, analytic, fem, link, rad, sci, v, Channels, SCALES};

fn rotary(stiffness: f64, mass_kg: f64) -> Drive {
    Drive::Rotary(RotaryDrive {
        stiffness,
        mass_kg,
        max_torque: None,
        min_angle: None,
        max_angle: None,
    })
}

fn linear(stiffness: f64, mass_kg: f64) -> Drive {
    Drive::Linear(act(stiffness, mass_kg))
}

/// `examples/rotary_arm.toml`: three rotary drives (unused pins at zero, as Python gives them).
fn rotary_arm() -> Arm {
    let z = V2::zeros();
    Arm::with_drives(
        9.81,
        z,
        z,
        v(-250.0, -320.0),
        vec![
            link(v(560.0, 0.0), z, z, v(250.0, 6.0), 4.2),
            link(v(480.0, 0.0), z, z, v(200.0, 4.0), 2.9),
            link(v(420.0, -20.0), z, z, v(190.0, -8.0), 2.4),
        ],
        vec![rotary(4.0e7, 3.6), rotary(1.5e7, 2.6), rotary(4.0e6, 1.4)],
        v(330.0, 25.0),
    )
    .unwrap()
}

/// `examples/mixed_arm.toml`: a rotary shoulder and two cylinders (pivot added for the base
/// spring).
fn mixed_arm() -> Arm {
    let z = V2::zeros();
    Arm::with_drives(
        9.81,
        z,
        z,
        v(-200.0, -300.0),
        vec![
            link(v(600.0, 0.0), z, v(300.0, 120.0), v(280.0, 10.0), 6.5),
            link(
                v(520.0, 0.0),
                v(-120.0, 80.0),
                v(200.0, 90.0),
                v(230.0, 8.0),
                4.0,
            ),
            link(v(400.0, 0.0), v(-90.0, 60.0), z, v(170.0, -5.0), 2.2),
        ],
        vec![
            rotary(8.0e7, 5.0),
            linear(12000.0, 2.0),
            linear(8000.0, 1.4),
        ],
        v(400.0, 0.0),
    )
    .unwrap()
}

/// (arm, poses in degrees, payload in N at scale 1).
fn cases() -> Vec<(Arm, Vec<[f64; 3]>, f64)> {
    vec![
        (
            rotary_arm(),
            vec![[45.0, 10.0, -20.0], [80.0, 30.0, 0.0], [20.0, -15.0, -40.0]],
            50.0,
        ),
        (
            mixed_arm(),
            vec![
                [60.0, -10.0, -60.0],
                [40.0, -30.0, -80.0],
                [75.0, 5.0, -40.0],
            ],
            200.0,
        ),
    ]
}

/// The largest relative difference over the channel groups (dx,dy | dα | dl | dℓ), each
/// group's max-norm difference over the analytic group's max norm; a channel must be NaN in
/// both models or in neither.
fn rel_diff(fe: &Channels, an: &Channels) -> f64 {
    let group = |a: &[f64], b: &[f64]| {
        let (mut d, mut m) = (0.0_f64, 0.0_f64);
        for (x, y) in a.iter().zip(b) {
            assert_eq!(x.is_nan(), y.is_nan(), "FE {a:?} vs analytic {b:?}");
            if !y.is_nan() {
                d = d.max((x - y).abs());
                m = m.max(y.abs());
            }
        }
        if m > 0.0 {
            d / m
        } else {
            d
        }
    };
    [
        group(&[fe.dxy.x, fe.dxy.y], &[an.dxy.x, an.dxy.y]),
        group(&fe.dalpha, &an.dalpha),
        group(&fe.dl, &an.dl),
        group(&fe.dlength, &an.dlength),
    ]
    .into_iter()
    .fold(0.0, f64::max)
}

/// Second-order agreement for a family of effects `make(arm, s)` at load scale s (gaps scale
/// with the load); effects a case's arm cannot take are left out by `make`. Returns the worst
/// relative difference at each scale.
fn second_order(name: &str, make: &dyn Fn(&Arm, f64) -> Vec<Effect>) -> [f64; 4] {
    let mut worst = [0.0_f64; 4];
    for (arm, poses, payload) in cases() {
        for pose in &poses {
            let alpha = rad(pose);
            let mut rel = [0.0; 4];
            for (j, &s) in SCALES.iter().enumerate() {
                let effects = EffectSet::new(&arm, make(&arm, s)).unwrap();
                let model = FemModel::new(&arm, &effects, &[], FemOptions::default()).unwrap();
                let p = v(0.0, -payload * s);
                rel[j] = rel_diff(
                    &fem(&model, &alpha, p, true),
                    &analytic(&arm, &effects, &alpha, p, true),
                );
                worst[j] = worst[j].max(rel[j]);
            }
            eprintln!("{name:28} {pose:?}: {}", sci(&rel));
            assert!(rel[3] <= 1e-5, "{name} {pose:?}: {rel:?}");
            for j in 1..4 {
                let ratio = rel[j - 1] / rel[j];
                assert!((6.0..16.0).contains(&ratio), "{name} {pose:?}: {rel:?}");
            }
        }
    }
    eprintln!("{name:28} worst: {}", sci(&worst));
    worst
}

#[test]
fn second_order_agreement_with_the_drives_springs_only() {
    second_order("drive springs", &|_, _| Vec::new());
}

#[test]
fn second_order_agreement_with_drive_compliance_and_the_base_spring() {
    second_order("drive_compliance + base", &|arm, _| {
        let mut e = vec![
            Effect::DriveCompliance(DriveCompliance {
                joint: 0,
                stiffness: 2.0e7,
            }),
            Effect::BaseCompliance(BaseCompliance { stiffness: 3e8 }),
        ];
        if arm.is_rotary(1) {
            e.push(Effect::DriveCompliance(DriveCompliance {
                joint: 1,
                stiffness: 6.0e6,
            }));
        } else {
            e.push(Effect::MountCompliance(MountCompliance {
                actuator: 1,
                stiffness: 9000.0,
            }));
        }
        e
    });
}

#[test]
fn second_order_agreement_with_links_clamped_to_their_drives() {
    // L1 clamped at O1; L2 clamped (rotary arm) or pinned (mixed arm); the housing of the
    // drive at O2 (rotary arm) turns with L1's slope there.
    second_order("link_bending L1 + L2", &|_, _| {
        vec![
            Effect::LinkBending(LinkBending { link: 0, ei: 2e10 }),
            Effect::LinkBending(LinkBending { link: 1, ei: 8e9 }),
        ]
    });
}

#[test]
fn gap_elements_reproduce_backlash_and_clearance_at_rotary_joints() {
    second_order("backlash + clearance", &|arm, s| {
        let mut e = vec![
            Effect::DriveBacklash(DriveBacklash {
                joint: 0,
                backlash_deg: 0.02 * s,
                unloaded: Unloaded::Centred,
            }),
            Effect::JointClearance(JointClearance {
                joint: 0,
                clearance: 0.1 * s,
                unloaded: Unloaded::Centred,
            }),
        ];
        if arm.is_rotary(2) {
            e.push(Effect::DriveBacklash(DriveBacklash {
                joint: 2,
                backlash_deg: 0.05 * s,
                unloaded: Unloaded::Centred,
            }));
        } else {
            e.push(Effect::ActuatorPlay(ActuatorPlay {
                actuator: 2,
                play: 0.05 * s,
                unloaded: Unloaded::Centred,
            }));
        }
        e
    });
}

#[test]
fn every_rotary_effect_at_once_agrees_at_second_order() {
    second_order("all at once", &|arm, s| {
        let mut e = vec![
            Effect::DriveCompliance(DriveCompliance {
                joint: 0,
                stiffness: 3.0e7,
            }),
            Effect::DriveBacklash(DriveBacklash {
                joint: 0,
                backlash_deg: 0.03 * s,
                unloaded: Unloaded::Centred,
            }),
            Effect::JointClearance(JointClearance {
                joint: 1,
                clearance: 0.1 * s,
                unloaded: Unloaded::Centred,
            }),
            Effect::LinkBending(LinkBending { link: 0, ei: 3e10 }),
            Effect::LinkBending(LinkBending { link: 2, ei: 5e9 }),
            Effect::BaseCompliance(BaseCompliance { stiffness: 5e8 }),
        ];
        if arm.is_rotary(1) {
            e.push(Effect::DriveBacklash(DriveBacklash {
                joint: 1,
                backlash_deg: 0.02 * s,
                unloaded: Unloaded::Centred,
            }));
        }
        e
    });
}

#[test]
fn torques_forces_and_pin_forces_equal_the_analytic_statics() {
    for (arm, poses, payload) in cases() {
        let effects = EffectSet::new(
            &arm,
            vec![
                Effect::LinkBending(LinkBending { link: 1, ei: 8e9 }),
                Effect::BaseCompliance(BaseCompliance { stiffness: 5e8 }),
                Effect::DriveBacklash(DriveBacklash {
                    joint: 0,
                    backlash_deg: 0.05,
                    unloaded: Unloaded::Centred,
                }),
                Effect::JointClearance(JointClearance {
                    joint: 2,
                    clearance: 0.1,
                    unloaded: Unloaded::Centred,
                }),
            ],
        )
        .unwrap();
        let sections = vec![
            LinkSection {
                ei: Some(6e10),
                ea: Some(4e7),
            },
            LinkSection::default(),
            LinkSection {
                ei: None,
                ea: Some(3e7),
            },
        ];
        let model = FemModel::new(&arm, &effects, &sections, FemOptions::default()).unwrap();
        for pose in &poses {
            let alpha = rad(pose);
            let p = v(5.0, -payload);
            let an = analytic(&arm, &effects, &alpha, p, true);
            let fe = fem(&model, &alpha, p, true);
            let fmax = an.reaction.iter().map(|r| r.norm()).fold(0.0, f64::max);
            let reach = 1500.0;
            for i in 0..arm.n() {
                // A torque is a force times a lever of the arm's size.
                let scale = if arm.is_rotary(i) { fmax * reach } else { fmax };
                let d = (fe.load[i] - an.load[i]).abs();
                assert!(d < 1e-9 * scale, "{pose:?} drive {}: {d:e}", i + 1);
                assert!((fe.reaction[i] - an.reaction[i]).norm() < 1e-9 * fmax);
            }
        }
    }
}

/// A one-link arm: the link from O1 to `tip` (local), turned by a drive of stiffness k, the
/// measure point at the tip, bending with EI.
fn cantilever(tip: V2, k: f64) -> Arm {
    let z = V2::zeros();
    Arm::with_drives(
        9.81,
        z,
        z,
        z,
        vec![link(tip, z, z, tip * 0.5, 0.0)],
        vec![rotary(k, 0.0)],
        tip,
    )
    .unwrap()
}

#[test]
fn a_link_clamped_to_its_drive_is_the_textbook_cantilever_on_either_side() {
    let (ei, k, f) = (2.0e9, 1.0e7, 100.0);
    for (len, alpha) in [(500.0, 0.0), (-400.0, 0.0), (500.0, 30.0_f64.to_radians())] {
        let arm = cantilever(v(len, 0.0), k);
        let effects =
            EffectSet::new(&arm, vec![Effect::LinkBending(LinkBending { link: 0, ei })]).unwrap();
        let opts = FemOptions {
            elements_per_link: 5,
            moment_samples: 11,
            ..FemOptions::default()
        };
        let model = FemModel::new(&arm, &effects, &[], opts).unwrap();
        let mut ws = FemWorkspace::new(&model);
        // A force P across the link at its tip (local −y).
        let across = v(alpha.sin(), -alpha.cos());
        ws.solve(&model, &[alpha], across * f, false, 0).unwrap();
        // Local y displacement of the tip: −P·(L³/3EI + L²/k) whatever the side (the moment
        // about O1 is −P·L, the drive turns by P·L/k... clockwise for L > 0).
        let local = v(alpha.cos(), alpha.sin());
        let normal = v(-alpha.sin(), alpha.cos());
        let l = len.abs();
        let bend = f * l.powi(3) / (3.0 * ei);
        let turn = f * len / k; // clockwise turn of the flange (rad)
        let want = -(bend + turn * len);
        let got = ws.dmeasure.dot(&normal);
        assert!(
            (got - want).abs() < 1e-9 * want.abs(),
            "{len}: {got} vs {want}"
        );
        assert!(ws.dmeasure.dot(&local).abs() < 1e-9 * want.abs());
        // The flange frame turns with the drive alone (the beam is clamped to it).
        assert!((ws.dalpha[0] + turn).abs() < 1e-12, "{}", ws.dalpha[0]);
        // The drive takes the payload's moment about O1: T = P·L (counter-clockwise for L > 0).
        assert!((ws.dforce[0] - f * len).abs() < 1e-9 * f * l);
        // M(x) = moment of the loads beyond x: −P·(L − x) on the loaded side, 0 on the other.
        let kk = model.options.moment_samples;
        for j in 0..kk {
            let x = model.moment_x[j];
            let want = if len > 0.0 {
                -f * (len - x)
            } else {
                // beyond x < 0 towards the joint: the drive's couple and the pin balance the
                // tip load, i.e. minus the moment of the tip load before x.
                f * (len - x)
            };
            assert!(
                (ws.dmoment[j] - want).abs() < 1e-6 * f * l,
                "{len} x {x}: {} vs {want}",
                ws.dmoment[j]
            );
        }
    }
}

#[test]
fn stiff_sections_tend_to_the_rigid_links_in_proportion_to_their_compliance() {
    for (arm, poses, payload) in cases() {
        let alpha = rad(&poses[0]);
        let p = v(0.0, -payload);
        let rigid = fem(
            &FemModel::new(&arm, &EffectSet::empty(), &[], FemOptions::default()).unwrap(),
            &alpha,
            p,
            true,
        );
        let mut diffs = Vec::new();
        for ei in [1e12, 1e13, 1e14] {
            let sections = vec![
                LinkSection {
                    ei: Some(ei),
                    ea: Some(ei / 1e3),
                };
                3
            ];
            let model =
                FemModel::new(&arm, &EffectSet::empty(), &sections, FemOptions::default()).unwrap();
            diffs.push(rel_diff(&fem(&model, &alpha, p, true), &rigid));
        }
        eprintln!("{}: {}", arm.drives[1].kind(), sci(&diffs));
        assert!(diffs[2] < 1e-3, "{diffs:?}");
        for w in diffs.windows(2) {
            assert!((6.0..16.0).contains(&(w[0] / w[1])), "{diffs:?}");
        }
    }
}

#[test]
fn backlash_closes_on_the_side_of_the_loaded_torque() {
    let arm = rotary_arm();
    let b = 0.05;
    let effects = EffectSet::new(
        &arm,
        vec![Effect::DriveBacklash(DriveBacklash {
            joint: 1,
            backlash_deg: b,
            unloaded: Unloaded::Centred,
        })],
    )
    .unwrap();
    let model = FemModel::new(&arm, &effects, &[], FemOptions::default()).unwrap();
    let mut ws = FemWorkspace::new(&model);
    let alpha = rad(&[45.0, 10.0, -20.0]);
    for (p, sw) in [
        (v(0.0, -50.0), true),
        (v(0.0, 80.0), false),
        (v(0.0, -50.0), false),
    ] {
        ws.solve(&model, &alpha, p, sw, 0).unwrap();
        let side = ws.force[1].signum();
        assert_eq!(ws.gaps.play_dl[1], -b.to_radians() * side);
        assert!(ws.iterations <= 3, "{} iterations", ws.iterations);
    }
    // Nothing loads the drive: the backlash stays centred, nothing moves.
    ws.solve(&model, &alpha, V2::zeros(), false, 0).unwrap();
    assert_eq!(ws.gaps.play_dl[1], 0.0);
    assert_eq!(ws.dmeasure, V2::zeros());
}

#[test]
fn what_the_fe_model_cannot_do_at_a_rotary_joint_is_refused_naming_it() {
    let arm = rotary_arm();
    let refused = |e: Effect, want: &str| {
        let effects = EffectSet::new(&arm, vec![e]).unwrap();
        let err = FemModel::new(&arm, &effects, &[], FemOptions::default()).unwrap_err();
        let msg = err.to_string();
        assert!(matches!(err, ArmError::InvalidEffect { .. }), "{msg}");
        assert!(msg.contains(want), "{msg}");
        assert!(msg.len() < 300 && !msg.contains('\n'), "{msg}");
    };
    refused(
        Effect::DriveBacklash(DriveBacklash {
            joint: 1,
            backlash_deg: 0.1,
            unloaded: Unloaded::TakenUp,
        }),
        "drive_backlash@O2 (taken up)",
    );
    refused(
        Effect::DriveFriction(DriveFriction {
            joint: 2,
            torque: 500.0,
        }),
        "drive_friction@O3",
    );
    // A drive that holds nothing (stiffness 0 through a fit's step): a mechanism, named.
    let effects = EffectSet::new_unchecked(
        &arm,
        vec![Effect::DriveCompliance(DriveCompliance {
            joint: 1,
            stiffness: 0.0,
        })],
    )
    .unwrap();
    let model = FemModel::new(&arm, &effects, &[], FemOptions::default()).unwrap();
    let mut ws = FemWorkspace::new(&model);
    let err = ws
        .solve(&model, &rad(&[45.0, 10.0, -20.0]), v(0.0, -50.0), true, 4)
        .unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("drive 2 does not hold it"), "{msg}");
    assert!(msg.contains("row 4") || msg.contains('4'), "{msg}");
}
