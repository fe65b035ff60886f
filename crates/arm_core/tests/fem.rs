//! The FE model against the analytic core, and the FE model's own promises.
//!
//! * A linear FE solve and the analytic model's exact pose differ only at second order: their
//!   relative difference shrinks in proportion to the load, to ≤ 1e-5 at 1/1000 of the
//!   payload — with actuator springs only, with the base spring, with flexible links, with
//!   gap elements for clearance and play (the gaps scaled with the load).
//! * Both are statics on the undeformed geometry of a statically determinate arm, so their
//!   forces agree to rounding.
//! * K is symmetric positive definite once supported; a rigid motion costs nothing; an
//!   unsupported model or a mechanism is refused, naming what moves.
//! * Point loads sit on nodes and Hermite beams are exact for them: results do not move as the
//!   mesh is refined; the three linear solvers agree.

#![allow(clippy::unwrap_used, clippy::needless_range_loop)] // test code: a failure should panic
mod common;
use arm_core::effects::{
    ActuatorCompliance, ActuatorPlay, BaseCompliance, JointClearance, LinkBending, MountCompliance,
    Unloaded,
};
use arm_core::examples::{example_arm, seed2022_arm};
use arm_core::fem::forces::{link_forces, section_moment, Applied, PointForce};
use arm_core::fem::{
    fem_solve_batch, FemBatchBuffers, FemModel, FemOptions, FemWorkspace, LinearSolver, LinkSection,
};
use arm_core::geometry::{angle, V2};
use arm_core::kinematics::Frames;
use arm_core::{Arm, ArmError, BatchInput, Effect, EffectSet, SolveOptions, Workspace};
use common::{act, analytic, fem, link, rad, sci, v, Channels, SCALES};

/// The bundled seed2022 arm, pivot moved off O1 so that the base spring has a lever.
fn seed_arm() -> Arm {
    Arm {
        pivot: v(-150.0, -300.0),
        ..seed2022_arm()
    }
}

/// (arm, poses in degrees): the seed's configurations 1, 3, 5 and three example poses.
fn cases() -> Vec<(Arm, Vec<[f64; 3]>)> {
    vec![
        (
            seed_arm(),
            vec![[115.6, 15.4, 0.2], [89.9, 5.6, 0.1], [58.6, 6.0, 0.4]],
        ),
        (
            example_arm(),
            vec![[90.0, 10.0, 0.0], [70.0, 25.0, -8.0], [105.0, 2.0, 9.0]],
        ),
    ]
}

fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// The largest relative difference over the channel groups (dx,dy | dα | dl | dℓ), each
/// group's max-norm difference over the analytic group's max norm.
fn rel_diff(fe: &Channels, an: &Channels) -> f64 {
    let group = |a: &[f64], b: &[f64]| {
        let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
        max_abs(&d) / max_abs(b)
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

const PAYLOAD_N: f64 = 15.0; // the seed's FEM figures

/// Checks second-order agreement for a family of models: `make(s)` gives the effects at load
/// scale s (gaps scale with the load). Returns the worst relative difference at each scale.
fn second_order(
    name: &str,
    make: &dyn Fn(&Arm, f64) -> Vec<Effect>,
    sections: &dyn Fn(&Arm) -> Vec<LinkSection>,
) -> [f64; 4] {
    let mut worst = [0.0_f64; 4];
    for (arm, poses) in cases() {
        for pose in &poses {
            let alpha = rad(pose);
            let mut rel = [0.0; 4];
            for (j, &s) in SCALES.iter().enumerate() {
                let effects = EffectSet::new(&arm, make(&arm, s)).unwrap();
                let model =
                    FemModel::new(&arm, &effects, &sections(&arm), FemOptions::default()).unwrap();
                let p = v(0.0, -PAYLOAD_N * s);
                let an = analytic(&arm, &effects, &alpha, p, true);
                let fe = fem(&model, &alpha, p, true);
                rel[j] = rel_diff(&fe, &an);
                worst[j] = worst[j].max(rel[j]);
            }
            eprintln!("{name:24} {pose:?}: {}", sci(&rel));
            assert!(rel[3] <= 1e-5, "{name} {pose:?}: {rel:?}");
            // In proportion to the load: each tenfold cut divides the difference by ~10.
            for j in 1..4 {
                let ratio = rel[j - 1] / rel[j];
                assert!((6.0..16.0).contains(&ratio), "{name} {pose:?}: {rel:?}");
            }
        }
    }
    eprintln!("{name:24} worst: {}", sci(&worst));
    worst
}

fn no_sections(_: &Arm) -> Vec<LinkSection> {
    Vec::new()
}

#[test]
fn second_order_agreement_with_actuator_springs_only() {
    second_order("actuator springs", &|_, _| Vec::new(), &no_sections);
}

#[test]
fn second_order_agreement_with_mount_and_body_compliance() {
    second_order(
        "mount + body compliance",
        &|_, _| {
            vec![
                Effect::MountCompliance(MountCompliance {
                    actuator: 1,
                    stiffness: 800.0,
                }),
                Effect::ActuatorCompliance(ActuatorCompliance {
                    actuator: 2,
                    stiffness: 1200.0,
                }),
            ]
        },
        &no_sections,
    );
}

#[test]
fn second_order_agreement_with_the_base_spring() {
    second_order(
        "base spring",
        &|_, _| vec![Effect::BaseCompliance(BaseCompliance { stiffness: 2e8 })],
        &no_sections,
    );
}

#[test]
fn second_order_agreement_with_flexible_links() {
    second_order(
        "link_bending L1 + L2",
        &|_, _| {
            vec![
                Effect::LinkBending(LinkBending { link: 0, ei: 4e9 }),
                Effect::LinkBending(LinkBending { link: 1, ei: 2e9 }),
            ]
        },
        &no_sections,
    );
}

#[test]
fn gap_elements_reproduce_clearance_and_play() {
    // The gap sizes scale with the load, so the whole response does.
    second_order(
        "clearance O2 O3 + play",
        &|_, s| {
            vec![
                Effect::JointClearance(JointClearance {
                    joint: 1,
                    clearance: 0.15 * s,
                    unloaded: Unloaded::Centred,
                }),
                Effect::JointClearance(JointClearance {
                    joint: 2,
                    clearance: 0.1 * s,
                    unloaded: Unloaded::Centred,
                }),
                Effect::ActuatorPlay(ActuatorPlay {
                    actuator: 0,
                    play: 0.05 * s,
                    unloaded: Unloaded::Centred,
                }),
                Effect::ActuatorPlay(ActuatorPlay {
                    actuator: 2,
                    play: 0.08 * s,
                    unloaded: Unloaded::Centred,
                }),
            ]
        },
        &no_sections,
    );
}

#[test]
fn everything_at_once_agrees_at_second_order() {
    second_order(
        "all six kinds",
        &|_, s| {
            vec![
                Effect::ActuatorCompliance(ActuatorCompliance {
                    actuator: 0,
                    stiffness: 1500.0,
                }),
                Effect::MountCompliance(MountCompliance {
                    actuator: 1,
                    stiffness: 4000.0,
                }),
                Effect::ActuatorPlay(ActuatorPlay {
                    actuator: 2,
                    play: 0.05 * s,
                    unloaded: Unloaded::Centred,
                }),
                Effect::JointClearance(JointClearance {
                    joint: 2,
                    clearance: 0.15 * s,
                    unloaded: Unloaded::Centred,
                }),
                Effect::LinkBending(LinkBending { link: 1, ei: 2e10 }),
                Effect::BaseCompliance(BaseCompliance { stiffness: 5e8 }),
            ]
        },
        &no_sections,
    );
}

#[test]
fn gaps_close_on_the_side_of_the_loaded_force_and_are_bounded() {
    let arm = example_arm();
    let effects = EffectSet::new(
        &arm,
        vec![
            Effect::JointClearance(JointClearance {
                joint: 1,
                clearance: 0.2,
                unloaded: Unloaded::Centred,
            }),
            Effect::ActuatorPlay(ActuatorPlay {
                actuator: 2,
                play: 0.1,
                unloaded: Unloaded::Centred,
            }),
        ],
    )
    .unwrap();
    let model = FemModel::new(&arm, &effects, &[], FemOptions::default()).unwrap();
    let mut ws = FemWorkspace::new(&model);
    let alpha = rad(&[90.0, 10.0, 0.0]);
    for (p, sw) in [
        (v(0.0, -50.0), true),
        (v(0.0, -50.0), false),
        (v(30.0, 0.0), true),
    ] {
        ws.solve(&model, &alpha, p, sw, 0).unwrap();
        let u = -ws.reaction[1] / ws.reaction[1].norm();
        assert!((ws.gaps.offset[1] - 0.2 * u).norm() < 1e-12);
        assert_eq!(ws.gaps.play_dl[2], -0.1 * ws.force[2].signum());
        assert!(ws.iterations <= 3, "{} iterations", ws.iterations);
    }
    // No payload, no weights: nothing pushes the gaps, they stay centred, nothing moves.
    ws.solve(&model, &alpha, V2::zeros(), false, 0).unwrap();
    assert_eq!(ws.gaps.offset[1], V2::zeros());
    assert_eq!(ws.dmeasure, V2::zeros());
    // No payload but weights: the gaps close under self-weight (docs/model.md §4, Reading).
    ws.solve(&model, &alpha, V2::zeros(), true, 0).unwrap();
    let an = analytic(&arm, &effects, &alpha, V2::zeros(), true);
    assert!(ws.dmeasure.norm() > 0.05);
    // Second order in the gap (c/lever ~ 0.2/50): within a percent.
    assert!((ws.dmeasure - an.dxy).norm() < 1e-2 * an.dxy.norm());
}

#[test]
fn forces_equal_the_statics_of_the_analytic_model() {
    for (arm, poses) in cases() {
        let effects = EffectSet::new(
            &arm,
            vec![
                Effect::LinkBending(LinkBending { link: 1, ei: 2e9 }),
                Effect::BaseCompliance(BaseCompliance { stiffness: 5e8 }),
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
                ei: Some(7e9),
                ea: Some(3e7),
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
            let p = v(3.0, -60.0);
            let an = analytic(&arm, &effects, &alpha, p, true);
            let fe = fem(&model, &alpha, p, true);
            let fmax = max_abs(&an.load);
            for i in 0..arm.n() {
                assert!((fe.load[i] - an.load[i]).abs() < 1e-9 * fmax, "{pose:?}");
                assert!((fe.reaction[i] - an.reaction[i]).norm() < 1e-9 * fmax);
            }
        }
    }
}

#[test]
fn moments_from_elements_match_the_free_body() {
    let arm = seed_arm();
    let sections = vec![
        LinkSection {
            ei: Some(7e9),
            ea: Some(3e7),
        };
        3
    ];
    let opts = FemOptions {
        elements_per_link: 12,
        ..FemOptions::default()
    };
    let model = FemModel::new(&arm, &EffectSet::empty(), &sections, opts).unwrap();
    let mut ws = FemWorkspace::new(&model);
    let alpha = rad(&[115.6, 15.4, 0.2]);
    let p = v(0.0, -PAYLOAD_N);
    ws.solve(&model, &alpha, p, true, 0).unwrap();
    let k = model.options.moment_samples;
    let load = Applied {
        weights: true,
        payload: p,
    };
    let mut worst = 0.0_f64;
    let mut scale = 0.0_f64;
    for i in 0..arm.n() {
        let mut pf = [PointForce::default(); 5];
        link_forces(&arm, i, &ws.e, &ws.force, &ws.reaction, load, &mut pf);
        for j in 0..k {
            let x = model.moment_x[i * k + j];
            let m = section_moment(&ws.frames, i, &pf, x);
            worst = worst.max((ws.moment[i * k + j] - m).abs());
            scale = scale.max(m.abs());
        }
    }
    // Stiff elements' end forces difference large displacements: ~1e-6 of round-off.
    assert!(worst < 2e-5 * scale, "{worst} vs {scale}");
    // The payload's moment at the last link's joint: the tip load's lever, about O3.
    assert!(scale > 1e3);
}

#[test]
fn results_do_not_move_as_the_mesh_is_refined() {
    let arm = seed_arm();
    let sections = vec![
        LinkSection {
            ei: Some(7e9),
            ea: Some(3e7),
        };
        3
    ];
    let alpha = rad(&[115.6, 15.4, 0.2]);
    let p = v(0.0, -PAYLOAD_N);
    let mut reference: Option<Channels> = None;
    let mut dofs = Vec::new();
    for m in [1, 2, 4, 8, 16, 32] {
        let opts = FemOptions {
            elements_per_link: m,
            ..FemOptions::default()
        };
        let model = FemModel::new(&arm, &EffectSet::empty(), &sections, opts).unwrap();
        dofs.push(model.n_dof());
        let fe = fem(&model, &alpha, p, true);
        match &reference {
            None => reference = Some(fe),
            Some(r) => {
                // Nodally exact; only round-off grows as the elements shrink.
                let d = rel_diff(&fe, r);
                eprintln!(
                    "{m:3} elements per link, {:4} DOF: {d:.1e}",
                    dofs[dofs.len() - 1]
                );
                assert!(d < 1e-6, "{m} elements per link: {d:e}");
            }
        }
    }
    assert!(dofs.windows(2).all(|w| w[1] > w[0]), "{dofs:?}");
}

#[test]
fn the_three_linear_solvers_agree() {
    let arm = seed_arm();
    let sections = vec![
        LinkSection {
            ei: Some(7e9),
            ea: Some(3e7),
        };
        3
    ];
    let effects = EffectSet::new(
        &arm,
        vec![Effect::JointClearance(JointClearance {
            joint: 1,
            clearance: 0.1,
            unloaded: Unloaded::Centred,
        })],
    )
    .unwrap();
    let alpha = rad(&[89.9, 5.6, 0.1]);
    let p = v(0.0, -PAYLOAD_N);
    let run = |solver| {
        let opts = FemOptions {
            elements_per_link: 10,
            solver,
            ..FemOptions::default()
        };
        let model = FemModel::new(&arm, &effects, &sections, opts).unwrap();
        fem(&model, &alpha, p, true)
    };
    let sparse = run(LinearSolver::Sparse);
    for other in [LinearSolver::SparseFresh, LinearSolver::Dense] {
        let d = rel_diff(&run(other), &sparse);
        assert!(d < 1e-8, "{other:?}: {d:e}");
    }
}

/// Dense K of a model at a pose.
fn dense_k(model: &FemModel, alpha: &[f64]) -> (Vec<f64>, usize) {
    let mut ws = FemWorkspace::new(model);
    ws.assemble(model, alpha, 0).unwrap();
    (ws.stiffness_dense(model), model.n_dof())
}

/// Eigenvalues of D^{-1/2}·K·D^{-1/2} (unit diagonal), ascending.
fn scaled_eigenvalues(k: &[f64], n: usize) -> Vec<f64> {
    let d: Vec<f64> = (0..n).map(|i| 1.0 / k[i * n + i].sqrt()).collect();
    let m = faer::Mat::<f64>::from_fn(n, n, |i, j| k[i * n + j] * d[i] * d[j]);
    m.self_adjoint_eigenvalues(faer::Side::Lower).unwrap()
}

#[test]
fn stiffness_is_symmetric_positive_definite_once_supported() {
    let arm = seed_arm();
    let sections = vec![
        LinkSection {
            ei: Some(7e9),
            ea: Some(3e7),
        },
        LinkSection {
            ei: Some(5e9),
            ea: None,
        },
        LinkSection::default(),
    ];
    let alpha = rad(&[115.6, 15.4, 0.2]);
    let supported = EffectSet::new(
        &arm,
        vec![Effect::BaseCompliance(BaseCompliance { stiffness: 5e8 })],
    )
    .unwrap();
    let model = FemModel::new(&arm, &supported, &sections, FemOptions::default()).unwrap();
    let (k, n) = dense_k(&model, &alpha);
    for i in 0..n {
        for j in 0..n {
            assert_eq!(k[i * n + j], k[j * n + i]);
        }
    }
    let ev = scaled_eigenvalues(&k, n);
    assert!(ev[0] > 1e-9 * ev[n - 1], "{:e} .. {:e}", ev[0], ev[n - 1]);

    // Without the base spring's stiffness the whole arm turns about the pivot: one zero
    // eigenvalue, and that rigid motion costs nothing (K·u = 0).
    let free = EffectSet::new_unchecked(
        &arm,
        vec![Effect::BaseCompliance(BaseCompliance { stiffness: 0.0 })],
    )
    .unwrap();
    let model0 = FemModel::new(&arm, &free, &sections, FemOptions::default()).unwrap();
    let (k0, n0) = dense_k(&model0, &alpha);
    let ev0 = scaled_eigenvalues(&k0, n0);
    assert!(ev0[0].abs() < 1e-12 * ev0[n0 - 1], "{:e}", ev0[0]);
    assert!(ev0[1] > 1e-9 * ev0[n0 - 1]);
    let u = rigid_rotation(&model0, &alpha);
    let ku: Vec<f64> = (0..n0)
        .map(|i| (0..n0).map(|j| k0[i * n0 + j] * u[j]).sum())
        .collect();
    let scale = (0..n0).map(|i| k0[i * n0 + i]).fold(0.0, f64::max);
    assert!(max_abs(&ku) < 1e-9 * scale, "{:e}", max_abs(&ku));
    let mut ws = FemWorkspace::new(&model0);
    match ws.solve(&model0, &alpha, v(0.0, -15.0), true, 0) {
        Err(ArmError::Unsupported(msg)) => {
            assert!(msg.contains("chassis") && msg.contains("pivot"), "{msg}");
        }
        other => panic!("expected Unsupported, got {other:?}"),
    }
}

/// The DOF vector of a unit rigid rotation of chassis and arm about the pivot.
fn rigid_rotation(model: &FemModel, alpha: &[f64]) -> Vec<f64> {
    let arm = &model.arm;
    let mut fr = Frames::new(arm.n());
    fr.fill(arm, alpha);
    let mut u = vec![0.0; model.n_dof()];
    let perp = |p: V2| {
        let r = p - arm.pivot;
        v(-r.y, r.x)
    };
    if let Some(d) = model.mesh.base_dof {
        u[d] = 1.0;
    }
    for (i, lm) in model.mesh.links.iter().enumerate() {
        let (s, c) = (fr.sin[i], fr.cos[i]);
        for (k, d) in lm.dof.iter().enumerate() {
            let p = fr.joint[i] + v(c * lm.x[k], s * lm.x[k]);
            let t = perp(p);
            // Full: global (u_x, u_y); Bending: v along local y; Axial: u along local x.
            match (d[0] != usize::MAX, d[1] != usize::MAX) {
                (true, true) => {
                    u[d[0]] = t.x;
                    u[d[1]] = t.y;
                }
                (false, true) => u[d[1]] = -s * t.x + c * t.y,
                (true, false) => u[d[0]] = c * t.x + s * t.y,
                _ => {}
            }
            if d[2] != usize::MAX {
                u[d[2]] = 1.0;
            }
        }
    }
    u
}

#[test]
fn mechanisms_are_refused_naming_what_moves() {
    let arm = example_arm();
    // Actuator 2's line through joint O2: link 2 turns freely.
    let mut fr = Frames::new(3);
    fr.fill(&arm, &rad(&[90.0, 0.0, 0.0]));
    let d = fr.joint[1] - fr.b[1];
    let a2 = angle(d) - angle(arm.links[1].a);
    let alpha = [90f64.to_radians(), a2, 0.0];
    let model = FemModel::new(&arm, &EffectSet::empty(), &[], FemOptions::default()).unwrap();
    let mut ws = FemWorkspace::new(&model);
    match ws.solve(&model, &alpha, v(0.0, -10.0), true, 7) {
        Err(ArmError::Mechanism { row, what }) => {
            assert_eq!(row, 7);
            assert!(what.contains("link 2") && what.contains("O2"), "{what}");
        }
        other => panic!("expected Mechanism, got {other:?}"),
    }
    // The analytic core refuses the same pose.
    let mut an = Workspace::new(&arm);
    assert!(matches!(
        an.solve(
            &arm,
            &EffectSet::empty(),
            &alpha,
            v(0.0, -10.0),
            SolveOptions::default(),
            7
        ),
        Err(ArmError::Singular { actuator: 2, .. })
    ));
    // A flexible link 2 in the same pose: still link 2 about O2.
    let sections = vec![
        LinkSection::default(),
        LinkSection {
            ei: Some(3e9),
            ea: Some(2e7),
        },
        LinkSection::default(),
    ];
    let flex = FemModel::new(&arm, &EffectSet::empty(), &sections, FemOptions::default()).unwrap();
    let mut ws = FemWorkspace::new(&flex);
    match ws.solve(&flex, &alpha, v(0.0, -10.0), true, 0) {
        Err(ArmError::Mechanism { what, .. }) => {
            assert!(what.contains("link 2") && what.contains("O2"), "{what}");
        }
        other => panic!("expected Mechanism, got {other:?}"),
    }
    // An actuator of zero stiffness: its link turns freely.
    let good = rad(&[90.0, 10.0, 0.0]);
    let soft = EffectSet::new_unchecked(
        &arm,
        vec![Effect::ActuatorCompliance(ActuatorCompliance {
            actuator: 2,
            stiffness: 0.0,
        })],
    )
    .unwrap();
    let model = FemModel::new(&arm, &soft, &[], FemOptions::default()).unwrap();
    let mut ws = FemWorkspace::new(&model);
    match ws.solve(&model, &good, v(0.0, -10.0), true, 0) {
        Err(ArmError::Mechanism { what, .. }) => {
            assert!(what.contains("link 3") && what.contains("O3"), "{what}");
        }
        other => panic!("expected Mechanism, got {other:?}"),
    }
    // A link without bending stiffness: it deforms freely.
    let limp = vec![
        LinkSection {
            ei: Some(0.0),
            ea: Some(2e7),
        },
        LinkSection::default(),
        LinkSection::default(),
    ];
    let model = FemModel::new(&arm, &EffectSet::empty(), &limp, FemOptions::default()).unwrap();
    let mut ws = FemWorkspace::new(&model);
    match ws.solve(&model, &good, v(0.0, -10.0), true, 0) {
        Err(ArmError::Mechanism { what, .. }) => {
            assert!(
                what.contains("link 1") && what.contains("deforms"),
                "{what}"
            );
        }
        other => panic!("expected Mechanism, got {other:?}"),
    }
}

#[test]
fn bad_input_is_refused_with_a_clear_error() {
    let arm = example_arm();
    let bad = |sections: Vec<LinkSection>, opts: FemOptions| {
        FemModel::new(&arm, &EffectSet::empty(), &sections, opts)
            .unwrap_err()
            .to_string()
    };
    let neg = vec![
        LinkSection::default(),
        LinkSection {
            ei: Some(-1.0),
            ea: None,
        },
        LinkSection::default(),
    ];
    assert!(bad(neg, FemOptions::default()).contains("link[2].ei_n_mm2"));
    let nan = vec![
        LinkSection {
            ei: None,
            ea: Some(f64::NAN),
        };
        3
    ];
    assert!(bad(nan, FemOptions::default()).contains("link[1].ea_n"));
    assert!(bad(vec![LinkSection::default(); 2], FemOptions::default()).contains("sections"));
    let zero = FemOptions {
        elements_per_link: 0,
        ..FemOptions::default()
    };
    assert!(bad(vec![], zero).contains("elements_per_link"));
    // A link that bends needs pin A off its joint, to have a chord.
    let odd = Arm::new(
        9.81,
        v(0.0, 0.0),
        v(100.0, -50.0),
        v(0.0, 0.0),
        vec![link(
            v(300.0, 0.0),
            v(0.0, 40.0),
            v(0.0, 0.0),
            v(150.0, 0.0),
            1.0,
        )],
        vec![act(500.0, 0.5)],
        v(300.0, 0.0),
    )
    .unwrap();
    let bent = vec![LinkSection {
        ei: Some(1e9),
        ea: None,
    }];
    let e = FemModel::new(&odd, &EffectSet::empty(), &bent, FemOptions::default()).unwrap_err();
    assert!(e.to_string().contains("pin A lies at x = 0"), "{e}");
}

#[test]
fn batch_equals_one_pose_at_a_time_and_masks_failures() {
    let arm = example_arm();
    let effects = EffectSet::new(
        &arm,
        vec![Effect::JointClearance(JointClearance {
            joint: 2,
            clearance: 0.1,
            unloaded: Unloaded::Centred,
        })],
    )
    .unwrap();
    let sections = vec![
        LinkSection {
            ei: Some(5e9),
            ea: Some(2e7),
        };
        3
    ];
    let model = FemModel::new(&arm, &effects, &sections, FemOptions::default()).unwrap();
    // 300 poses (the parallel path), one singular.
    let rows = 300;
    let mut alpha = Vec::new();
    let mut payload = Vec::new();
    for r in 0..rows {
        let t = r as f64 / rows as f64;
        alpha.extend([70.0 + 30.0 * t, 25.0 * t, -5.0 + 10.0 * t]);
        payload.extend([0.0, -20.0 - 30.0 * t]);
    }
    let mut fr = Frames::new(3);
    fr.fill(&arm, &rad(&[90.0, 0.0, 0.0]));
    let a2 = angle(fr.joint[1] - fr.b[1]) - angle(arm.links[1].a);
    alpha[3 * 17..3 * 18].copy_from_slice(&[90.0, a2.to_degrees(), 0.0]);
    let (_, moments, nodes) = arm_core::fem::batch::extra_sizes(&model);
    let mut buf = FemBatchBuffers::new(&model, rows);
    let run = |buf: &mut FemBatchBuffers, nan: bool| {
        fem_solve_batch(
            &model,
            BatchInput {
                alpha_deg: &alpha,
                payload_n: &payload,
            },
            SolveOptions {
                self_weight: true,
                nan_on_failure: nan,
            },
            buf.out(),
        )
    };
    match run(&mut buf, false) {
        Err(ArmError::Mechanism { row: 17, .. }) => {}
        other => panic!("expected the mechanism of row 17, got {other:?}"),
    }
    run(&mut buf, true).unwrap();
    assert!(buf.base.dx_mm[17].is_nan() && buf.dmoment_nmm[17 * moments].is_nan());
    let mut ws = FemWorkspace::new(&model);
    for r in [0, 16, 18, 150, 299] {
        let a: Vec<f64> = alpha[3 * r..3 * r + 3]
            .iter()
            .map(|d| d.to_radians())
            .collect();
        ws.solve(&model, &a, v(0.0, payload[2 * r + 1]), true, r)
            .unwrap();
        assert_eq!(buf.base.dx_mm[r], ws.dmeasure.x);
        assert_eq!(buf.base.dy_mm[r], ws.dmeasure.y);
        assert_eq!(buf.base.force_n[3 * r + 2], ws.force[2]);
        assert_eq!(buf.dmoment_nmm[r * moments + 5], ws.dmoment[5]);
        assert_eq!(buf.node_disp[r * nodes + 7], ws.node_disp[3].y);
    }
}

#[test]
fn a_point_next_to_another_changes_nothing_however_close() {
    // A massless centre of mass a hair from the joint makes a beam element that short; its
    // relative station keeps the answer exact (no merging, no round-off blow-up).
    let arm_with = |cx: f64| {
        let mut arm = example_arm();
        arm.links[2].c = v(cx, 0.0);
        arm.links[2].mass_kg = 0.0;
        arm
    };
    let sections = vec![
        LinkSection {
            ei: Some(1e8),
            ea: None,
        },
        LinkSection {
            ei: Some(2e9),
            ea: Some(3e7),
        },
        LinkSection {
            ei: Some(1e8),
            ea: None,
        },
    ];
    let alpha = rad(&[90.0, 10.0, 0.0]);
    let p = v(2.0, -40.0);
    let reference = {
        let arm = arm_with(0.0);
        let m = FemModel::new(&arm, &EffectSet::empty(), &sections, FemOptions::default()).unwrap();
        fem(&m, &alpha, p, true)
    };
    for cx in [-1.0, -1e-3, -1e-5, -1e-7, 1e-6, 1e-2] {
        let arm = arm_with(cx);
        let m = FemModel::new(&arm, &EffectSet::empty(), &sections, FemOptions::default()).unwrap();
        let d = rel_diff(&fem(&m, &alpha, p, true), &reference);
        assert!(d < 1e-8, "C at x = {cx}: {d:e}");
    }
}
