//! The block kernel on mixed arms (docs/model.md §10, docs/architecture.md): random arms of
//! 1–6 links with any mix of linear actuators and rotary drives, every effect that fits each
//! joint's kind (compliances, play and backlash in both gap modes, clearances, frictions,
//! bending clamped at drives, the chassis), drive limits (torque, angle range) and actuator
//! limits, against the general path: `solve_batch_status` against `solve_batch_general`, and
//! `solve_sequence` against `Workspace::solve_state` state by state with the sequence's
//! friction memory.
//!
//! Tolerances as tests/solve_fast.rs: 1e-9 relative on forces, reactions and torques, 1e-8 mm
//! on the measure point, 1e-9 mm on lengths and 1e-9 deg on angles; statuses equal. The two
//! paths compute the same model with different formulas (the kernel composes each drive's
//! small turn as a rotation from fdlibm's kernels, the general path adds angles and calls
//! libm's sin/cos on the absolute ones), so they agree to rounding, ≈ 1e-13 mm.

#![allow(clippy::unwrap_used, clippy::needless_range_loop)] // test code: a failure should panic
mod common;
use arm_core::effects::{
    ActuatorCompliance, ActuatorFriction, ActuatorPlay, BaseCompliance, DriveBacklash,
    DriveCompliance, DriveFriction, JointClearance, JointFriction, LinkBending, MountCompliance,
    SequenceMemory, Unloaded,
};
use arm_core::examples::example_arm;
use arm_core::solve::Workspace;
use arm_core::{
    solve_batch_general, solve_batch_status, solve_sequence, Actuator, Arm, BatchBuffers,
    BatchInput, Drive, Effect, EffectSet, ExtraDeformations, Link, RotaryDrive, SequenceInput, V2,
};
use common::{opts, outputs, outputs_mut, push_payload, Rng, OUTPUTS};
use proptest::prelude::*;

/// The example arm's shapes jittered (the third repeated beyond three), joint i turned by a
/// rotary drive where `rotary[i]`; with `limits`, strokes, force and torque limits and angle
/// ranges around the generated poses' values (some poses beyond them).
fn arm(rotary: &[bool], rng: &mut Rng, limits: bool) -> Arm {
    let ex = example_arm();
    let n = rotary.len();
    let mut links = Vec::new();
    let mut drives = Vec::new();
    for i in 0..n {
        let (shape, act) = (&ex.links[i.min(2)], ex.actuator(i.min(2)).unwrap());
        let b = if i < 2 {
            shape.b
        } else {
            V2::new(-100.0, 10.0)
        };
        let f = |r: &mut Rng| r.uniform(0.6, 1.4);
        let next_linear = i + 1 < n && !rotary[i + 1];
        links.push(Link {
            next: rng.jitter(shape.next, 15.0),
            a: if rotary[i] {
                V2::zeros()
            } else {
                rng.jitter(shape.a, 15.0)
            },
            b: if next_linear {
                rng.jitter(b, 15.0)
            } else {
                V2::zeros()
            },
            c: rng.jitter(shape.c, 15.0),
            mass_kg: shape.mass_kg * f(rng),
        });
        drives.push(if rotary[i] {
            // Relative angles of the generated poses: 60–110° at joint 1, within ±40° beyond.
            let mid = if i == 0 { 85.0 } else { 0.0 };
            Drive::Rotary(RotaryDrive {
                stiffness: 10f64.powf(rng.uniform(6.5, 8.0)),
                mass_kg: rng.uniform(0.0, 3.0),
                max_torque: limits.then(|| rng.uniform(1e3, 3e5)),
                min_angle: limits.then(|| (mid - rng.uniform(5.0, 40.0)).to_radians()),
                max_angle: limits.then(|| (mid + rng.uniform(5.0, 40.0)).to_radians()),
            })
        } else {
            Drive::Linear(Actuator {
                stiffness: act.stiffness * f(rng),
                mass_kg: act.mass_kg * f(rng),
                min_length: limits.then(|| rng.uniform(150.0, 350.0)),
                max_length: limits.then(|| rng.uniform(350.0, 700.0)),
                max_force: limits.then(|| rng.uniform(50.0, 3000.0)),
            })
        });
    }
    let behind = ex.links[2].next - ex.measure;
    let measure = rng.jitter(links[n - 1].next - behind, 10.0);
    let b0 = if rotary[0] {
        V2::zeros()
    } else {
        rng.jitter(ex.b0, 10.0)
    };
    let (o1, pivot) = (rng.jitter(ex.o1, 5.0), rng.jitter(ex.o1, 80.0));
    Arm::with_drives(ex.g, o1, b0, pivot, links, drives, measure).unwrap()
}

/// Each effect that fits joint i's kind with probability 1/2 (every one when `all`), random
/// gap modes; `frictions` adds the friction elements.
fn effects(arm: &Arm, rng: &mut Rng, all: bool, frictions: bool) -> Vec<Effect> {
    let mut e = Vec::new();
    let mode = |r: &mut Rng| {
        if r.coin() {
            Unloaded::Centred
        } else {
            Unloaded::TakenUp
        }
    };
    for i in 0..arm.n() {
        let maybe = |r: &mut Rng| all || r.coin();
        if arm.is_rotary(i) {
            if maybe(rng) {
                let stiffness = 10f64.powf(rng.uniform(6.5, 8.0));
                e.push(Effect::DriveCompliance(DriveCompliance {
                    joint: i,
                    stiffness,
                }));
            }
            if maybe(rng) {
                let (backlash_deg, unloaded) = (rng.uniform(0.0, 0.1), mode(rng));
                e.push(Effect::DriveBacklash(DriveBacklash {
                    joint: i,
                    backlash_deg,
                    unloaded,
                }));
            }
            if frictions && maybe(rng) {
                let torque = rng.uniform(0.0, 3000.0);
                e.push(Effect::DriveFriction(DriveFriction { joint: i, torque }));
            }
        } else {
            if maybe(rng) {
                let stiffness = rng.uniform(300.0, 3000.0);
                e.push(Effect::ActuatorCompliance(ActuatorCompliance {
                    actuator: i,
                    stiffness,
                }));
            }
            if maybe(rng) {
                let stiffness = rng.uniform(300.0, 5000.0);
                e.push(Effect::MountCompliance(MountCompliance {
                    actuator: i,
                    stiffness,
                }));
            }
            if maybe(rng) {
                let (play, unloaded) = (rng.uniform(0.0, 0.4), mode(rng));
                e.push(Effect::ActuatorPlay(ActuatorPlay {
                    actuator: i,
                    play,
                    unloaded,
                }));
            }
            if frictions && maybe(rng) {
                let friction = rng.uniform(0.0, 200.0);
                e.push(Effect::ActuatorFriction(ActuatorFriction {
                    actuator: i,
                    friction,
                }));
            }
        }
        if maybe(rng) {
            let (clearance, unloaded) = (rng.uniform(0.0, 0.3), mode(rng));
            e.push(Effect::JointClearance(JointClearance {
                joint: i,
                clearance,
                unloaded,
            }));
        }
        if frictions && maybe(rng) {
            let torque = rng.uniform(0.0, 3000.0);
            e.push(Effect::JointFriction(JointFriction { joint: i, torque }));
        }
        if maybe(rng) {
            let ei = 10f64.powf(rng.uniform(8.5, 11.0));
            e.push(Effect::LinkBending(LinkBending { link: i, ei }));
        }
    }
    if all || rng.coin() {
        let stiffness = 10f64.powf(rng.uniform(7.0, 9.0));
        e.push(Effect::BaseCompliance(BaseCompliance { stiffness }));
    }
    e
}

/// `rows` poses (deg): 60–110° at joint 1, ±30° relative beyond, and payloads up to 10 kg
/// down (some zero) or any force up to 100 N.
fn poses(n: usize, rows: usize, rng: &mut Rng, any_direction: bool) -> (Vec<f64>, Vec<f64>) {
    let mut alpha = Vec::with_capacity(n * rows);
    let mut payload = Vec::with_capacity(2 * rows);
    for r in 0..rows {
        let mut a = rng.uniform(60.0, 110.0);
        alpha.push(a);
        for _ in 1..n {
            a += rng.uniform(-30.0, 30.0);
            alpha.push(a);
        }
        push_payload(&mut payload, r, rng, any_direction);
    }
    (alpha, payload)
}

/// Largest difference of two output sets, each field against its tolerance (≤ 1 passes);
/// NaN equals NaN only.
fn worst(a: &BatchBuffers, b: &BatchBuffers) -> (f64, &'static str) {
    let gap = |x: &[f64], y: &[f64], rel: bool| {
        x.iter()
            .zip(y)
            .map(|(p, q)| match (p.is_nan(), q.is_nan()) {
                (true, true) => 0.0,
                (false, false) if rel => (p - q).abs() / (1.0 + q.abs()),
                (false, false) => (p - q).abs(),
                _ => f64::INFINITY,
            })
            .fold(0.0, f64::max)
    };
    let fields = [
        ("force_n", gap(&a.force_n, &b.force_n, true), 1e-9),
        ("dforce_n", gap(&a.dforce_n, &b.dforce_n, true), 1e-9),
        ("torque_nmm", gap(&a.torque_nmm, &b.torque_nmm, true), 1e-9),
        (
            "dtorque_nmm",
            gap(&a.dtorque_nmm, &b.dtorque_nmm, true),
            1e-9,
        ),
        ("reaction_n", gap(&a.reaction_n, &b.reaction_n, true), 1e-9),
        ("dx_mm", gap(&a.dx_mm, &b.dx_mm, false), 1e-8),
        ("dy_mm", gap(&a.dy_mm, &b.dy_mm, false), 1e-8),
        ("dalpha_deg", gap(&a.dalpha_deg, &b.dalpha_deg, false), 1e-9),
        ("dl_mm", gap(&a.dl_mm, &b.dl_mm, false), 1e-9),
        ("dlength_mm", gap(&a.dlength_mm, &b.dlength_mm, false), 1e-9),
        ("length_mm", gap(&a.length_mm, &b.length_mm, false), 1e-9),
    ];
    fields
        .into_iter()
        .map(|(name, d, tol)| (d / tol, name))
        .fold(
            (0.0, ""),
            |m, x| if x.0 > m.0 || x.0.is_nan() { x } else { m },
        )
}

/// A value no output can hold. The Python binding hands the kernel numpy's uninitialised
/// arrays (`numpy.empty`), so every element of every output and status must be written,
/// whatever the arm, the effects and the rows that fail: the tests start from this value
/// (and status 255, no code) and look for it afterwards.
const UNWRITTEN: f64 = -7.25e300;

/// Buffers for `rows` poses of an `n`-link arm holding [`UNWRITTEN`] everywhere.
fn unwritten(rows: usize, n: usize) -> BatchBuffers {
    let mut b = BatchBuffers::new(rows, n);
    for v in outputs_mut(&mut b) {
        v.fill(UNWRITTEN);
    }
    b
}

/// The first output element (name, index) or status row still unwritten, if any.
fn first_unwritten(b: &BatchBuffers, status: &[u8]) -> Option<(&'static str, usize)> {
    OUTPUTS
        .into_iter()
        .zip(outputs(b))
        .find_map(|(name, v)| v.iter().position(|&x| x == UNWRITTEN).map(|j| (name, j)))
        .or_else(|| status.iter().position(|&s| s == 255).map(|r| ("status", r)))
}

/// Every output of row `r` NaN.
fn nan_row(b: &mut BatchBuffers, r: usize, n: usize) {
    for v in [
        &mut b.force_n,
        &mut b.dforce_n,
        &mut b.torque_nmm,
        &mut b.dtorque_nmm,
        &mut b.dalpha_deg,
        &mut b.dl_mm,
        &mut b.dlength_mm,
        &mut b.length_mm,
    ] {
        v[r * n..(r + 1) * n].fill(f64::NAN);
    }
    b.reaction_n[2 * r * n..2 * (r + 1) * n].fill(f64::NAN);
    b.dx_mm[r] = f64::NAN;
    b.dy_mm[r] = f64::NAN;
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// One loading per pose: the kernel's outputs and statuses are the general path's.
    #[test]
    fn the_kernel_solves_mixed_arms_as_the_general_path(
        seed in any::<u64>(),
        n in 1usize..=6,
        bits in any::<u8>(),
        all in any::<bool>(),
        sw in any::<bool>(),
        any_direction in any::<bool>(),
        limits in any::<bool>(),
    ) {
        let mut rng = Rng(seed | 1);
        let rotary: Vec<bool> = (0..n).map(|i| bits >> i & 1 == 1).collect();
        let arm = arm(&rotary, &mut rng, limits);
        let set = EffectSet::new(&arm, effects(&arm, &mut rng, all, true)).unwrap();
        // 37 rows: two full blocks of 16 and a partial one.
        let (alpha, payload) = poses(n, 37, &mut rng, any_direction);
        let input = BatchInput { alpha_deg: &alpha, payload_n: &payload };
        let none = ExtraDeformations::none;
        let (mut fast, mut gen) = (unwritten(37, n), unwritten(37, n));
        let (mut st_fast, mut st_gen) = (vec![255u8; 37], vec![255u8; 37]);
        solve_batch_status(&arm, &set, input, none(), opts(sw), fast.out(), &mut st_fast).unwrap();
        solve_batch_general(&arm, &set, input, none(), opts(sw), gen.out(), &mut st_gen).unwrap();
        prop_assert_eq!(first_unwritten(&fast, &st_fast), None, "kernel, {:?}", set.effects());
        prop_assert_eq!(first_unwritten(&gen, &st_gen), None, "general, {:?}", set.effects());
        let (w, field) = worst(&fast, &gen);
        prop_assert!(w <= 1.0, "{} differs by {:e} × its tolerance, {:?}", field, w, set.effects());
        prop_assert_eq!(st_fast, st_gen, "status, {:?}", set.effects());
    }

    /// Load sequences with frictions: every state of the kernel's sequences is the general
    /// path's state with the same friction memory.
    #[test]
    fn the_kernels_sequences_of_mixed_arms_are_the_general_paths(
        seed in any::<u64>(),
        n in 1usize..=6,
        bits in any::<u8>(),
        sw in any::<bool>(),
    ) {
        let mut rng = Rng(seed | 1);
        let rotary: Vec<bool> = (0..n).map(|i| bits >> i & 1 == 1).collect();
        let arm = arm(&rotary, &mut rng, false);
        let set = EffectSet::new(&arm, effects(&arm, &mut rng, false, true)).unwrap();
        let (seqs, states) = (19, 5);
        let (alpha, _) = poses(n, seqs, &mut rng, false);
        let (_, payload) = poses(n, seqs * states, &mut rng, true);
        let mut fast = unwritten(seqs * states, n);
        let mut st_fast = vec![255u8; seqs * states];
        let seq = SequenceInput { alpha_deg: &alpha, payload_n: &payload, states };
        solve_sequence(&arm, &set, seq, opts(sw), fast.out(), &mut st_fast).unwrap();
        prop_assert_eq!(first_unwritten(&fast, &st_fast), None, "{:?}", set.effects());
        // The general path, state by state, with the sequence's memory.
        let mut ws = Workspace::new(&arm);
        let mut gen = BatchBuffers::new(seqs * states, n);
        let mut failed = Vec::new();
        for q in 0..seqs {
            let rad: Vec<f64> = alpha[q * n..(q + 1) * n].iter().map(|d| d.to_radians()).collect();
            let mut memory = SequenceMemory::new(n);
            for s in 0..states {
                let r = q * states + s;
                let p = V2::new(payload[2 * r], payload[2 * r + 1]);
                let none = ExtraDeformations::none();
                let solved = ws.solve_state(&arm, &set, &rad, p, opts(sw), r, (&none, 0), &mut memory);
                if solved.is_err() {
                    failed.push(r);
                    continue;
                }
                for i in 0..n {
                    let j = r * n + i;
                    let (load, dload) = (ws.loaded.f[i], ws.delta.f[i]);
                    let nan = f64::NAN;
                    if arm.is_rotary(i) {
                        (gen.force_n[j], gen.dforce_n[j]) = (nan, nan);
                        (gen.torque_nmm[j], gen.dtorque_nmm[j]) = (load, dload);
                    } else {
                        (gen.force_n[j], gen.dforce_n[j]) = (load, dload);
                        (gen.torque_nmm[j], gen.dtorque_nmm[j]) = (nan, nan);
                    }
                    gen.reaction_n[2 * j] = ws.loaded.r[i].x;
                    gen.reaction_n[2 * j + 1] = ws.loaded.r[i].y;
                    gen.dalpha_deg[j] = (ws.new_alpha[i] - rad[i]).to_degrees();
                    gen.dl_mm[j] = ws.body_dl[i];
                    gen.dlength_mm[j] = ws.new_length[i] - ws.lines.length[i];
                    gen.length_mm[j] = ws.lines.length[i];
                }
                gen.dx_mm[r] = ws.dmeasure.x;
                gen.dy_mm[r] = ws.dmeasure.y;
            }
        }
        // A state the general path cannot close is NaN in the kernel's output too.
        for &r in &failed {
            prop_assert!(fast.dx_mm[r].is_nan(), "row {}", r);
            for b in [&mut fast, &mut gen] {
                nan_row(b, r, n);
            }
        }
        let (w, field) = worst(&fast, &gen);
        prop_assert!(w <= 1.0, "{} differs by {:e} × its tolerance, {:?}", field, w, set.effects());
    }
}
