//! Rotary drives (docs/model.md §10) on random arms of 1–7 links with any mix of linear
//! actuators and rotary drives: equilibrium of every body with the drives' couples, a drive's
//! torque as minus the moment of everything beyond it, zero load → zero deflection, the
//! first-order equivalence of a drive of stiffness k·r² and an actuator of stiffness k with
//! moment arm r, the gear's effects as the turns they stand for, Maxwell–Betti with clamped
//! bending and the housing turning with the bent body, statuses, refusals, and every entry
//! point (solve, sequences, cycles, sweeps, Jacobian, compensation, kinematics) giving the
//! general path's numbers.
//!
//! Tolerances: equilibrium to 1e-9 of the loads' scale (rounding of sums of a few dozen
//! products); an effect against the extra turn it stands for to 1e-9 (the same closure with
//! the same numbers summed in another order); the first-order equivalence to 1e-3 of the
//! deflection at turns up to 2e-5 rad (the second-order terms are the turn times the ratio of
//! a lever to a moment arm, relative: 6e-5 at most on these arms, printed by the test); Maxwell–Betti to 1e-6
//! relative (third-order terms of a 0.01 N probe: ~1e-9).

#![allow(clippy::unwrap_used, clippy::needless_range_loop)] // test code: a failure should panic
mod common;
use arm_core::effects::{
    ActuatorCompliance, ActuatorPlay, BaseCompliance, DriveBacklash, DriveCompliance,
    DriveFriction, JointClearance, JointFriction, LinkBending, MountCompliance, Unloaded,
};
use arm_core::examples::example_arm;
use arm_core::geometry::cross;
use arm_core::kinematics::{angles_from_lengths, forward_batch, Frames};
use arm_core::sensitivity::{jacobian_batch, jacobian_batch_general, n_channels, step, Place};
use arm_core::{
    cycle_returns, solve_batch_general, solve_batch_status, solve_sequence, statics_batch,
    Actuator, Arm, ArmError, BatchBuffers, BatchInput, Drive, Effect, EffectSet, ExtraDeformations,
    Link, RotaryDrive, SequenceInput, StaticsBuffers, Status, V2,
};
use common::{opts, poses, Rng};
use proptest::prelude::*;

/// The example arm's links (the third one's shape repeated beyond three, with a B pin),
/// points jittered by 15 mm, masses and stiffnesses by ±40 %; joint i turned by a rotary
/// drive where `rotary[i]` (stiffness 10^6.5–10^8 N·mm/rad, a 0–3 kg motor and gearbox), its
/// unused pins left at zero as the Python side gives them.
fn arm(rotary: &[bool], rng: &mut Rng) -> Arm {
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
            Drive::Rotary(RotaryDrive {
                stiffness: 10f64.powf(rng.uniform(6.5, 8.0)),
                mass_kg: rng.uniform(0.0, 3.0),
                max_torque: None,
                min_angle: None,
                max_angle: None,
            })
        } else {
            Drive::Linear(Actuator {
                stiffness: act.stiffness * f(rng),
                mass_kg: act.mass_kg * f(rng),
                min_length: None,
                max_length: None,
                max_force: None,
            })
        });
    }
    let behind = ex.links[2].next - ex.measure;
    let measure = rng.jitter(links[n - 1].next - behind, 10.0);
    let pivot = rng.jitter(ex.o1, 80.0);
    let b0 = if rotary[0] {
        V2::zeros()
    } else {
        rng.jitter(ex.b0, 10.0)
    };
    Arm::with_drives(
        ex.g,
        rng.jitter(ex.o1, 5.0),
        b0,
        pivot,
        links,
        drives,
        measure,
    )
    .unwrap()
}

/// Kinds of drive from the bits of `bits` (bit i: joint i + 1 rotary), `n` joints.
fn kinds(n: usize, bits: u8) -> Vec<bool> {
    (0..n).map(|i| bits >> i & 1 == 1).collect()
}

fn input<'a>(alpha: &'a [f64], payload: &'a [f64]) -> BatchInput<'a> {
    BatchInput {
        alpha_deg: alpha,
        payload_n: payload,
    }
}

/// `solve_batch_status` (the routed entry point) with extra deformations.
fn solve(
    arm: &Arm,
    effects: Vec<Effect>,
    alpha: &[f64],
    payload: &[f64],
    extra: ExtraDeformations<'_>,
    self_weight: bool,
) -> (BatchBuffers, Vec<u8>) {
    let rows = payload.len() / 2;
    let set = EffectSet::new(arm, effects).unwrap();
    let mut b = BatchBuffers::new(rows, arm.n());
    let mut st = vec![255u8; rows];
    let inp = input(alpha, payload);
    solve_batch_status(arm, &set, inp, extra, opts(self_weight), b.out(), &mut st).unwrap();
    (b, st)
}

fn statics(arm: &Arm, alpha: &[f64], payload: &[f64], self_weight: bool) -> StaticsBuffers {
    let mut st = StaticsBuffers::new(payload.len() / 2, arm.n());
    statics_batch(arm, input(alpha, payload), self_weight, st.out()).unwrap();
    st
}

/// Largest |a − b| over two arrays, NaN equal to NaN (and NaN against a number: infinite).
fn gap(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| match (p.is_nan(), q.is_nan()) {
            (true, true) => 0.0,
            (false, false) => (p - q).abs(),
            _ => f64::INFINITY,
        })
        .fold(0.0, f64::max)
}

/// The largest |value| of an output (NaN skipped), at least 1 (in the output's unit).
fn size(a: &[f64]) -> f64 {
    a.iter()
        .filter(|v| !v.is_nan())
        .fold(1.0, |m, v| m.max(v.abs()))
}

/// Largest gap over every output of two solves, each against its tolerance (≤ 1 passes):
/// `tol` of the output's largest value (of at least 1 N, 1 N·m, 1 mm, 1°): two solves that
/// reach the same state by different sums keep round-off in proportion to the values (random
/// arms of up to 7 links carry forces of 10⁴ N; proptest found 3·10⁻⁸ N apart there).
fn worst(a: &BatchBuffers, b: &BatchBuffers, tol: f64) -> (f64, &'static str) {
    let rel = |x: &[f64], y: &[f64]| gap(x, y) / size(x).max(size(y));
    let rel_nmm = |x: &[f64], y: &[f64]| gap(x, y) / size(x).max(size(y)).max(1e3);
    let fields = [
        ("force_n", rel(&a.force_n, &b.force_n)),
        ("torque_nmm", rel_nmm(&a.torque_nmm, &b.torque_nmm)),
        ("dforce_n", rel(&a.dforce_n, &b.dforce_n)),
        ("dtorque_nmm", rel_nmm(&a.dtorque_nmm, &b.dtorque_nmm)),
        ("reaction_n", rel(&a.reaction_n, &b.reaction_n)),
        ("dx_mm", rel(&a.dx_mm, &b.dx_mm)),
        ("dy_mm", rel(&a.dy_mm, &b.dy_mm)),
        ("dalpha_deg", rel(&a.dalpha_deg, &b.dalpha_deg)),
        ("dl_mm", rel(&a.dl_mm, &b.dl_mm)),
        ("dlength_mm", rel(&a.dlength_mm, &b.dlength_mm)),
        ("length_mm", rel(&a.length_mm, &b.length_mm)),
    ];
    fields
        .into_iter()
        .map(|(name, d)| (d / tol, name))
        .fold(
            (0.0, ""),
            |m, x| if x.0 > m.0 || x.0.is_nan() { x } else { m },
        )
}

/// A load on a body: a force at a point, or a couple (`at` = None).
type Load = (Option<V2>, V2, f64);

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Every body is in equilibrium (forces and moments), the drives' couples included: link i
    /// carries its reaction R_i, −R_{i+1}, its weight, an actuator's force and half weight at
    /// each of its pins, a drive i's torque +T_i, a drive i+1's −T_{i+1} and its weight at
    /// O_{i+1}, and on the last link the payload.
    #[test]
    fn every_body_is_in_equilibrium(seed in any::<u64>(), n in 1usize..=7, bits in any::<u8>(), sw in any::<bool>()) {
        let mut rng = Rng(seed | 1);
        let rotary = kinds(n, bits);
        let arm = arm(&rotary, &mut rng);
        let (alpha, payload) = poses(n, 5, &mut rng, true);
        let st = statics(&arm, &alpha, &payload, sw);
        let mut fr = Frames::new(n);
        for p in 0..5 {
            let rad: Vec<f64> = alpha[p * n..(p + 1) * n].iter().map(|d| d.to_radians()).collect();
            fr.fill(&arm, &rad);
            let w = |m: f64| V2::new(0.0, if sw { -m * arm.g } else { 0.0 });
            let at = |a: &[f64], i: usize| V2::new(a[2 * (p * n + i)], a[2 * (p * n + i) + 1]);
            let pay = V2::new(payload[2 * p], payload[2 * p + 1]);
            for i in 0..n {
                let j = p * n + i;
                prop_assert_eq!(st.force_n[j].is_nan(), rotary[i]);
                prop_assert_eq!(st.torque_nmm[j].is_nan(), !rotary[i]);
                let mut loads: Vec<Load> = vec![
                    (Some(fr.joint[i]), at(&st.reaction_n, i), 0.0),
                    (Some(fr.c[i]), w(arm.links[i].mass_kg), 0.0),
                ];
                match &arm.drives[i] {
                    Drive::Linear(a) => {
                        let e = (fr.a[i] - fr.b[i]).normalize();
                        loads.push((Some(fr.a[i]), st.force_n[j] * e + w(0.5 * a.mass_kg), 0.0));
                    }
                    Drive::Rotary(_) => loads.push((None, V2::zeros(), st.torque_nmm[j])),
                }
                if i + 1 < n {
                    loads.push((Some(fr.joint[i + 1]), -at(&st.reaction_n, i + 1), 0.0));
                    match &arm.drives[i + 1] {
                        Drive::Linear(a) => {
                            let e = (fr.a[i + 1] - fr.b[i + 1]).normalize();
                            let f = -st.force_n[j + 1] * e + w(0.5 * a.mass_kg);
                            loads.push((Some(fr.b[i + 1]), f, 0.0));
                        }
                        Drive::Rotary(d) => {
                            loads.push((Some(fr.joint[i + 1]), w(d.mass_kg), 0.0));
                            loads.push((None, V2::zeros(), -st.torque_nmm[j + 1]));
                        }
                    }
                } else {
                    loads.push((Some(fr.joint[n]), pay, 0.0));
                }
                let mut force = V2::zeros();
                let mut moment = 0.0;
                let mut scale: f64 = 1.0;
                for (p_at, f, c) in &loads {
                    force += f;
                    moment += c + p_at.map_or(0.0, |q| cross(q, *f));
                    scale = scale.max(f.norm()).max(c.abs() / 1000.0);
                }
                prop_assert!(force.norm() < 1e-9 * scale, "link {}: net force {}", i + 1, force);
                prop_assert!(moment.abs() < 1e-9 * scale * 3000.0, "link {}: net moment {}", i + 1, moment);
            }
        }
    }

    /// A drive holds minus the moment about its joint of everything beyond it (the weights of
    /// the links and drives it carries and the payload); internal forces cancel.
    #[test]
    fn a_drive_holds_the_moment_of_what_it_carries(seed in any::<u64>(), n in 1usize..=7, bits in any::<u8>()) {
        let mut rng = Rng(seed | 1);
        let mut rotary = kinds(n, bits);
        rotary[rng.pick(n)] = true;
        let arm = arm(&rotary, &mut rng);
        let (alpha, payload) = poses(n, 5, &mut rng, true);
        let st = statics(&arm, &alpha, &payload, true);
        let mut fr = Frames::new(n);
        let w = |m: f64| V2::new(0.0, -m * arm.g);
        for p in 0..5 {
            let rad: Vec<f64> = alpha[p * n..(p + 1) * n].iter().map(|d| d.to_radians()).collect();
            fr.fill(&arm, &rad);
            let pay = V2::new(payload[2 * p], payload[2 * p + 1]);
            for i in (0..n).filter(|&i| rotary[i]) {
                let o = fr.joint[i];
                let mut m = cross(fr.joint[n] - o, pay);
                for k in i..n {
                    m += cross(fr.c[k] - o, w(arm.links[k].mass_kg));
                    if k > i {
                        match &arm.drives[k] {
                            Drive::Linear(a) => {
                                m += cross(fr.a[k] - o, w(0.5 * a.mass_kg));
                                m += cross(fr.b[k] - o, w(0.5 * a.mass_kg));
                            }
                            Drive::Rotary(d) => m += cross(fr.joint[k] - o, w(d.mass_kg)),
                        }
                    }
                }
                let t = st.torque_nmm[p * n + i];
                prop_assert!((t + m).abs() < 1e-9 * (1.0 + m.abs()), "joint {}: T {} vs moment {}", i + 1, t, m);
            }
        }
    }

    /// Zero payload: zero deflection, whatever the elastic and friction effects (and with the
    /// self-weight on: the loaded state is the unloaded one). No torque changes.
    #[test]
    fn zero_payload_moves_nothing(seed in any::<u64>(), n in 1usize..=7, bits in any::<u8>()) {
        let mut rng = Rng(seed | 1);
        let rotary = kinds(n, bits);
        let arm = arm(&rotary, &mut rng);
        let (alpha, _) = poses(n, 9, &mut rng, false);
        let payload = vec![0.0; 18];
        let mut effects = vec![Effect::BaseCompliance(BaseCompliance { stiffness: 3e7 })];
        for i in 0..n {
            effects.push(Effect::LinkBending(LinkBending { link: i, ei: 10f64.powf(rng.uniform(9.0, 11.0)) }));
            effects.push(Effect::JointFriction(JointFriction { joint: i, torque: rng.uniform(0.0, 3000.0) }));
            if rotary[i] {
                effects.push(Effect::DriveCompliance(DriveCompliance { joint: i, stiffness: 1e7 }));
                effects.push(Effect::DriveFriction(DriveFriction { joint: i, torque: 500.0 }));
            } else {
                effects.push(Effect::MountCompliance(MountCompliance { actuator: i, stiffness: 900.0 }));
            }
        }
        let (b, st) = solve(&arm, effects, &alpha, &payload, ExtraDeformations::none(), true);
        // Both states carry the self-weight: what is left is the round-off of two closures of
        // the same pose, in proportion to the arm's size (proptest found 2e-9 mm on a 6-link
        // arm): 1e-11 of the reach in mm (4e-8 mm on a 4 m arm, far below any deflection the
        // model is for), 1e-8° for the angles (1.7e-10 rad: under 1e-6 mm at 4 m).
        let reach: f64 = arm.links.iter().map(|l| l.next.norm()).sum();
        for v in b.dx_mm.iter().chain(&b.dy_mm) {
            prop_assert!(v.abs() < 1e-11 * reach.max(1e3), "moved by {} mm (reach {} mm)", v, reach);
        }
        for v in &b.dalpha_deg {
            prop_assert!(v.abs() < 1e-8, "turned by {} deg", v);
        }
        for (i, t) in b.dtorque_nmm.iter().enumerate() {
            let expected = if rotary[i % n] { *t == 0.0 } else { t.is_nan() };
            prop_assert!(expected, "dtorque {} at joint {}", t, i % n + 1);
        }
        prop_assert!(st.iter().all(|&s| s != Status::LargeDeflection.code()));
    }

    /// Every entry point gives a mixed arm the general path's numbers: `solve_batch_status`
    /// (the block kernel, or the general path where a joint friction sits beside a bent
    /// link) gives `solve_batch_general`'s numbers to rounding (1e-8 in each output's unit,
    /// torques in N·m; tests/kernel_mixed.rs has the kernel's own tolerances) and its
    /// statuses; a sequence of one state is that solve; a load cycle's return is the
    /// sequence's last state, bit for bit.
    #[test]
    fn every_entry_point_gives_the_general_paths_numbers(seed in any::<u64>(), n in 1usize..=7, bits in any::<u8>()) {
        let mut rng = Rng(seed | 1);
        let mut rotary = kinds(n, bits);
        rotary[rng.pick(n)] = true;
        let arm = arm(&rotary, &mut rng);
        let (alpha, payload) = poses(n, 20, &mut rng, false);
        let j = (0..n).find(|&i| rotary[i]).unwrap();
        let effects = vec![
            Effect::DriveBacklash(DriveBacklash { joint: j, backlash_deg: 0.05, unloaded: Unloaded::Centred }),
            Effect::DriveFriction(DriveFriction { joint: j, torque: 2000.0 }),
            Effect::JointFriction(JointFriction { joint: rng.pick(n), torque: 1500.0 }),
            Effect::JointClearance(JointClearance { joint: rng.pick(n), clearance: 0.1, unloaded: Unloaded::TakenUp }),
            Effect::LinkBending(LinkBending { link: rng.pick(n), ei: 1e10 }),
        ];
        let set = EffectSet::new(&arm, effects.clone()).unwrap();
        let (b, st) = solve(&arm, effects, &alpha, &payload, ExtraDeformations::none(), true);
        let mut g = BatchBuffers::new(20, n);
        let mut gs = vec![0u8; 20];
        solve_batch_general(&arm, &set, input(&alpha, &payload), ExtraDeformations::none(), opts(true), g.out(), &mut gs).unwrap();
        let (w, field) = worst(&b, &g, 1e-8);
        prop_assert!(w <= 1.0, "{} off by {} of 1e-8", field, w);
        prop_assert_eq!(&st, &gs);
        // A sequence of one state each.
        let mut q = BatchBuffers::new(20, n);
        let mut qs = vec![0u8; 20];
        let seq = SequenceInput { alpha_deg: &alpha, payload_n: &payload, states: 1 };
        solve_sequence(&arm, &set, seq, opts(true), q.out(), &mut qs).unwrap();
        let (w, field) = worst(&q, &b, 1e-8);
        prop_assert!(w <= 1.0, "sequence: {} off by {} of 1e-8", field, w);
        prop_assert_eq!(&qs, &st);
        // The cycle m → 0 of 3 masses per pose against the sequences' last states.
        let masses = [0.0, 2.5, 7.0];
        let poses = 4;
        let (mut dx, mut dy) = (vec![0.0; poses * 3], vec![0.0; poses * 3]);
        cycle_returns(&arm, &set, &alpha[..poses * n], &masses, true, &mut dx, &mut dy).unwrap();
        let mut sa = Vec::new();
        let mut sp = Vec::new();
        for p in 0..poses {
            for m in masses {
                sa.extend_from_slice(&alpha[p * n..(p + 1) * n]);
                sp.extend_from_slice(&[0.0, -m * arm.g, 0.0, 0.0]);
            }
        }
        let mut c = BatchBuffers::new(poses * 3 * 2, n);
        let mut cs = vec![0u8; poses * 3 * 2];
        let seq = SequenceInput { alpha_deg: &sa, payload_n: &sp, states: 2 };
        solve_sequence(&arm, &set, seq, opts(true), c.out(), &mut cs).unwrap();
        for k in 0..poses * 3 {
            prop_assert_eq!(dx[k].to_bits(), c.dx_mm[2 * k + 1].to_bits());
            prop_assert_eq!(dy[k].to_bits(), c.dy_mm[2 * k + 1].to_bits());
        }
    }

    /// The gear's effects are the turns they stand for: `drive_compliance` k′ is an extra turn
    /// −ΔT·(1/k′ − 1/k), `drive_backlash` b one of −b·sign(T) (taken up: minus the reference's),
    /// `drive_friction` L one of (ΔT − S)/k with S the deadband of ΔT; a `joint_friction` at a
    /// drive is the same turn with its limit (no moment arm) and leaves the reactions as they
    /// were; every other output stays.
    #[test]
    fn the_gears_effects_are_the_turns_they_stand_for(seed in any::<u64>(), n in 1usize..=7, bits in any::<u8>(), taken_up in any::<bool>()) {
        let mut rng = Rng(seed | 1);
        let mut rotary = kinds(n, bits);
        let j = rng.pick(n);
        rotary[j] = true;
        let arm = arm(&rotary, &mut rng);
        let rows = 12;
        let (alpha, payload) = poses(n, rows, &mut rng, true);
        let st = statics(&arm, &alpha, &payload, true);
        let k = arm.drives[j].stiffness();
        let (k2, b, lim) = (rng.uniform(0.3, 3.0) * k, rng.uniform(0.0, 0.2), rng.uniform(0.0, 3000.0));
        let side = |t: f64| if t >= 1e-6 { 1.0 } else if t <= -1e-6 { -1.0 } else { 0.0 };
        let deadband = |x: f64| x.signum() * (x.abs() - lim).max(0.0);
        let mode = if taken_up { Unloaded::TakenUp } else { Unloaded::Centred };
        let mut turns = vec![[0.0; 3]; rows];
        for p in 0..rows {
            let (t, t0) = (st.torque_nmm[p * n + j], st.torque0_nmm[p * n + j]);
            let dt = t - t0;
            let mut back = side(t);
            if taken_up {
                back -= side(t0);
            }
            turns[p] = [
                -dt * (1.0 / k2 - 1.0 / k),
                -b.to_radians() * back,
                (dt - deadband(dt)) / k,
            ];
        }
        let gear = [
            Effect::DriveCompliance(DriveCompliance { joint: j, stiffness: k2 }),
            Effect::DriveBacklash(DriveBacklash { joint: j, backlash_deg: b, unloaded: mode }),
            Effect::DriveFriction(DriveFriction { joint: j, torque: lim }),
            Effect::JointFriction(JointFriction { joint: j, torque: lim }),
        ];
        let none = ExtraDeformations::none();
        for (e, effect) in gear.into_iter().enumerate() {
            let (with, _) = solve(&arm, vec![effect], &alpha, &payload, none, true);
            let mut turn = vec![0.0; rows * n];
            for p in 0..rows {
                turn[p * n + j] = turns[p][e.min(2)];
            }
            let extra = ExtraDeformations { turn_rad: Some(&turn), ..Default::default() };
            let (mut turned, _) = solve(&arm, vec![], &alpha, &payload, extra, true);
            if e == 3 {
                // the torque through the drive is S (the joint holds the rest); the
                // reactions do not change
                for p in 0..rows {
                    let q = p * n + j;
                    let dt = turned.dtorque_nmm[q];
                    turned.dtorque_nmm[q] = deadband(dt);
                    turned.torque_nmm[q] += deadband(dt) - dt;
                }
            }
            let (w, field) = worst(&with, &turned, 1e-9);
            prop_assert!(w <= 1.0, "effect {}: {} off by {} of 1e-9", e, field, w);
        }
    }

    /// Maxwell–Betti: the compliance of the load point of an elastic mixed arm (drives' gears,
    /// actuators, bent links clamped at drives and pinned at actuators, the housings turning
    /// with the bent bodies, the chassis) is symmetric.
    #[test]
    fn the_compliance_of_a_mixed_arm_is_symmetric(seed in any::<u64>(), n in 1usize..=5, bits in any::<u8>()) {
        let mut rng = Rng(seed | 1);
        let rotary = kinds(n, bits);
        let mut arm = arm(&rotary, &mut rng);
        arm.measure = arm.links[n - 1].next;
        let mut effects = vec![Effect::BaseCompliance(BaseCompliance { stiffness: 10f64.powf(rng.uniform(7.0, 9.0)) })];
        for i in 0..n {
            effects.push(Effect::LinkBending(LinkBending { link: i, ei: 10f64.powf(rng.uniform(9.0, 10.5)) }));
        }
        let (alpha, _) = poses(n, 1, &mut rng, false);
        // Central differences ±h: the terms they leave are relative (h·C/ℓ)², so h is sized
        // from a first estimate of the compliance C for a load-point move of 0.005 mm, at
        // most 0.01 N (~1e-9 relative, and ~1e-10 of rounding); a fixed 0.01 N left 1.2e-6 on
        // a random arm of 15 mm/N (seed 9468772019212240940), shrinking as h² (1.2e-8 at
        // 0.001 N).
        let col = |p: V2, h: f64| {
            let pay = [p.x * h, p.y * h, -p.x * h, -p.y * h];
            let al = [alpha.clone(), alpha.clone()].concat();
            let (b, st) = solve(&arm, effects.clone(), &al, &pay, ExtraDeformations::none(), false);
            (V2::new(b.dx_mm[0] - b.dx_mm[1], b.dy_mm[0] - b.dy_mm[1]) / (2.0 * h), st)
        };
        let (cx, sx) = col(V2::new(1.0, 0.0), 0.01);
        let (cy, sy) = col(V2::new(0.0, 1.0), 0.01);
        // A pose near a singularity (an actuator almost along its link: status 2) is outside
        // the small-deflection model, where 0.01 N can already open a triangle (NaN): a
        // random arm there is not this property's case (seed 13378286124837718306).
        prop_assume!(sx.iter().chain(&sy).all(|&s| s == 0));
        let h = 0.005 / cx.x.abs().max(cy.y.abs()).max(0.5);
        let (cx, _) = col(V2::new(1.0, 0.0), h);
        let (cy, _) = col(V2::new(0.0, 1.0), h);
        let scale = cx.x.abs().max(cy.y.abs());
        prop_assert!((cx.y - cy.x).abs() < 1e-6 * scale, "C_yx {} vs C_xy {}", cx.y, cy.x);
        prop_assert!(cx.x > 0.0 && cy.y > 0.0);
    }

    /// The Jacobian of a mixed arm: the routed entry point gives the general path's numbers,
    /// and a drive's stiffness and backlash probes match a difference of two solves by hand.
    #[test]
    fn the_jacobian_of_a_mixed_arm(seed in any::<u64>(), n in 1usize..=7, bits in any::<u8>()) {
        let mut rng = Rng(seed | 1);
        let mut rotary = kinds(n, bits);
        let j = rng.pick(n);
        rotary[j] = true;
        let arm = arm(&rotary, &mut rng);
        let rows = 6;
        let (alpha, payload) = poses(n, rows, &mut rng, false);
        let k = arm.drives[j].stiffness();
        let model = [(Place { code: 10, index: j }, 1.0 / (2.0 * k))];
        let probes = [Place { code: 10, index: j }, Place { code: 11, index: j }, Place { code: 9, index: j }];
        let c = n_channels(n);
        let (mut y, mut jac) = (vec![0.0; rows * c], vec![0.0; rows * c * 3]);
        let (mut yg, mut jg) = (vec![0.0; rows * c], vec![0.0; rows * c * 3]);
        jacobian_batch(&arm, &model, &probes, input(&alpha, &payload), opts(true), &mut y, &mut jac).unwrap();
        jacobian_batch_general(&arm, &model, &probes, input(&alpha, &payload), opts(true), &mut yg, &mut jg).unwrap();
        prop_assert!(gap(&y, &yg) == 0.0 && gap(&jac, &jg) == 0.0);
        // dl of a rotary drive: no channel (NaN), in the prediction and its derivatives
        for r in 0..rows {
            prop_assert!(y[r * c + 2 + n + j].is_nan());
        }
        // ∂y/∂θ of the gear's compliance θ = 1/k: a difference of two solves 1 % apart, to
        // 1e-6 relative and to the rounding of dy (a few 1e-12 mm: a small payload moves
        // little) over this step and over the core's own, `step`'s h (0.2 % of θ here): a
        // row carrying 0.002 N came out 1e-5 apart from the converged difference, the core's
        // step dividing 2e-12 mm of rounding (seed 18044499002980599956)
        let h_core = step(&arm, &model, probes[0]).1;
        let (t0, dt) = (1.0 / (2.0 * k), 0.01 / (2.0 * k));
        let at = |t: f64| {
            let e = vec![Effect::DriveCompliance(DriveCompliance { joint: j, stiffness: 1.0 / t })];
            solve(&arm, e, &alpha, &payload, ExtraDeformations::none(), true).0
        };
        let (hi, lo) = (at(t0 + dt), at(t0 - dt));
        for r in 0..rows {
            let fd = (hi.dy_mm[r] - lo.dy_mm[r]) / (2.0 * dt);
            let an = jac[(r * c + 1) * 3];
            if an.is_nan() && fd.is_nan() {
                continue; // a pose that cannot close under its load, in both
            }
            let tol = 1e-6 * an.abs().max(fd.abs()) + 1e-12 / dt + 4e-12 / (2.0 * h_core);
            prop_assert!((fd - an).abs() <= tol, "row {}: {} vs {}", r, an, fd);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Memory in a load sequence reference → m → 0: a gear friction L slips on the way up
    /// (the spring takes S = ΔT − L) and, past 2L, back on the way down (S = L·sign ΔT): the
    /// arm comes back turned by −S/k at the drive, with a centred backlash along the
    /// self-weight's torque. Each state is the single solve with those turns added.
    #[test]
    fn a_gear_friction_remembers(seed in any::<u64>(), n in 1usize..=7, bits in any::<u8>()) {
        let mut rng = Rng(seed | 1);
        let mut rotary = kinds(n, bits);
        let j = rng.pick(n);
        rotary[j] = true;
        let arm = arm(&rotary, &mut rng);
        let (alpha, _) = poses(n, 1, &mut rng, false);
        let m = rng.uniform(2.0, 10.0);
        let st = statics(&arm, &alpha, &[0.0, -m * arm.g], true);
        let dt = st.torque_nmm[j] - st.torque0_nmm[j];
        let lim = dt.abs() * rng.uniform(0.05, 0.45);
        let k = arm.drives[j].stiffness();
        let back = Effect::DriveBacklash(DriveBacklash { joint: j, backlash_deg: 0.05, unloaded: Unloaded::Centred });
        let effects = vec![Effect::DriveFriction(DriveFriction { joint: j, torque: lim }), back.clone()];
        let set = EffectSet::new(&arm, effects).unwrap();
        let mut b = BatchBuffers::new(2, n);
        let mut status = vec![0u8; 2];
        let payload = [0.0, -m * arm.g, 0.0, 0.0];
        let seq = SequenceInput { alpha_deg: &alpha, payload_n: &payload, states: 2 };
        solve_sequence(&arm, &set, seq, opts(true), b.out(), &mut status).unwrap();
        prop_assume!(b.dy_mm.iter().all(|v| v.is_finite()));
        let up = dt - lim * dt.signum();
        let down = lim * dt.signum();
        for (state, (mass, held)) in [(m, dt - up), (0.0, -down)].into_iter().enumerate() {
            let mut turn = vec![0.0; n];
            turn[j] = held / k;
            let extra = ExtraDeformations { turn_rad: Some(&turn), ..Default::default() };
            let (one, _) = solve(&arm, vec![back.clone()], &alpha, &[0.0, -mass * arm.g], extra, true);
            for (got, want) in [(b.dx_mm[state], one.dx_mm[0]), (b.dy_mm[state], one.dy_mm[0])] {
                prop_assert!((got - want).abs() < 1e-9, "state {}: {} vs {}", state, got, want);
            }
            for i in 0..n {
                prop_assert!((b.dalpha_deg[state * n + i] - one.dalpha_deg[i]).abs() < 1e-9);
            }
            // the drive's torque is the whole torque (the friction is inside the drive)
            prop_assert!((b.dtorque_nmm[state * n + j] - one.dtorque_nmm[j]).abs() < 1e-6);
        }
    }
}

/// A drive of stiffness k·r² deflects the arm as a linear actuator of stiffness k with moment
/// arm r, to first order; their statics agree exactly (T = F·r).
#[test]
fn a_drive_of_stiffness_k_r2_is_an_actuator_of_stiffness_k_at_arm_r() {
    let mut rng = Rng(0x5eed_1234_9876_0001);
    let mut checked = 0;
    let mut worst: f64 = 0.0;
    for case in 0..200 {
        let n = 1 + case % 7;
        let rotary = vec![false; n];
        let mut linear = arm(&rotary, &mut rng);
        let j = rng.pick(n);
        linear.actuator_mut(j).unwrap().mass_kg = 0.0;
        let (alpha, _) = poses(n, 1, &mut rng, false);
        let payload = [0.0, -9.81 * rng.uniform(1.0, 10.0)];
        // Actuators stiff enough that no link turns by more than 1e-5 rad, where the second
        // order is a small fraction of the first.
        for i in 0..n {
            linear.actuator_mut(i).unwrap().stiffness *= 100.0;
        }
        let (a, _) = solve(
            &linear,
            vec![],
            &alpha,
            &payload,
            ExtraDeformations::none(),
            true,
        );
        if a.dy_mm[0].is_nan() {
            continue; // a pose the random arm cannot take (counted below)
        }
        let turn = a
            .dalpha_deg
            .iter()
            .fold(0.0f64, |m, d| m.max(d.abs()))
            .to_radians();
        for i in 0..n {
            linear.actuator_mut(i).unwrap().stiffness *= (turn / 1e-5).max(1.0);
        }
        let rad: Vec<f64> = alpha.iter().map(|d| d.to_radians()).collect();
        let mut fr = Frames::new(n);
        fr.fill(&linear, &rad);
        let e = (fr.a[j] - fr.b[j]).normalize();
        let r = cross(fr.a[j] - fr.joint[j], e);
        let k = linear.actuator(j).unwrap().stiffness;
        let mut drive = linear.clone();
        drive.drives[j] = Drive::Rotary(RotaryDrive {
            stiffness: k * r * r,
            mass_kg: 0.0,
            max_torque: None,
            min_angle: None,
            max_angle: None,
        });
        let (a, _) = solve(
            &linear,
            vec![],
            &alpha,
            &payload,
            ExtraDeformations::none(),
            true,
        );
        let (b, _) = solve(
            &drive,
            vec![],
            &alpha,
            &payload,
            ExtraDeformations::none(),
            true,
        );
        let t = b.torque_nmm[j];
        assert!(
            (t - a.force_n[j] * r).abs() < 1e-9 * t.abs().max(1.0),
            "{t} vs {}",
            a.force_n[j] * r
        );
        for i in (0..n).filter(|&i| i != j) {
            assert!((a.force_n[i] - b.force_n[i]).abs() < 1e-9 * (1.0 + a.force_n[i].abs()));
        }
        let turn = a
            .dalpha_deg
            .iter()
            .fold(0.0f64, |m, d| m.max(d.abs()))
            .to_radians();
        assert!(turn < 2e-5, "case {case}: turn {turn}");
        let d = V2::new(a.dx_mm[0], a.dy_mm[0]);
        let miss = V2::new(a.dx_mm[0] - b.dx_mm[0], a.dy_mm[0] - b.dy_mm[0]);
        worst = worst.max(miss.norm() / d.norm());
        assert!(miss.norm() <= 1e-3 * d.norm(), "case {case}: {miss} of {d}");
        for i in 0..n {
            let (x, y) = (a.dalpha_deg[i], b.dalpha_deg[i]);
            let scale = a.dalpha_deg.iter().fold(0.0f64, |m, d| m.max(d.abs()));
            assert!(
                (x - y).abs() <= 1e-3 * scale,
                "case {case} link {i}: {x} vs {y}"
            );
        }
        checked += 1;
    }
    assert!(checked > 180, "{checked} poses of 200");
    println!("largest relative miss of the measure point: {worst:.2e}");
}

/// A one-link arm turned by a rigid drive, link bending clamped at the flange: the tip of a
/// horizontal cantilever sags F·L³/(3EI) and the flange frame does not turn.
#[test]
fn a_link_turned_by_a_drive_is_a_cantilever() {
    let (l, ei, f) = (500.0, 2e10, 40.0);
    let arm = Arm::with_drives(
        9.81,
        V2::zeros(),
        V2::zeros(),
        V2::zeros(),
        vec![Link {
            next: V2::new(l, 0.0),
            a: V2::zeros(),
            b: V2::zeros(),
            c: V2::new(200.0, 0.0),
            mass_kg: 2.0,
        }],
        vec![Drive::Rotary(RotaryDrive {
            stiffness: 1e20,
            mass_kg: 0.0,
            max_torque: None,
            min_angle: None,
            max_angle: None,
        })],
        V2::new(l, 0.0),
    )
    .unwrap();
    let bend = vec![Effect::LinkBending(LinkBending { link: 0, ei })];
    let (b, _) = solve(
        &arm,
        bend,
        &[0.0],
        &[0.0, -f],
        ExtraDeformations::none(),
        true,
    );
    let want = -f * l.powi(3) / (3.0 * ei);
    assert!(
        (b.dy_mm[0] - want).abs() < 1e-6 * want.abs(),
        "{} vs {want}",
        b.dy_mm[0]
    );
    assert!(b.dalpha_deg[0].abs() < 1e-12, "{}", b.dalpha_deg[0]);
    assert_eq!(b.dtorque_nmm[0], f * l);
    assert!(b.dforce_n[0].is_nan() && b.dl_mm[0].is_nan() && b.length_mm[0].is_nan());
}

/// Statuses: a torque above `max_torque` is over force; a drive's angle outside its range
/// (unloaded, or loaded through its yield) is out of stroke; a drive is never near singular.
#[test]
fn statuses_of_a_drive() {
    let mut rng = Rng(77);
    let mut arm = arm(&[false, true, false], &mut rng);
    let alpha = [85.0, 15.0, 0.0];
    let payload = [0.0, -9.81 * 5.0];
    let (b, st) = solve(
        &arm,
        vec![],
        &alpha,
        &payload,
        ExtraDeformations::none(),
        true,
    );
    assert_eq!(st[0], Status::Ok.code());
    let t = b.torque_nmm[1];
    let q = (15.0f64 - 85.0).to_radians();
    let dq = (b.dalpha_deg[1] - b.dalpha_deg[0]).to_radians();
    assert!(dq != 0.0);
    let set = |arm: &mut Arm, d: RotaryDrive| arm.drives[1] = Drive::Rotary(d);
    let base = arm.drives[1].rotary().unwrap().clone();
    let cases = [
        (
            RotaryDrive {
                max_torque: Some(t.abs() * 0.999),
                ..base.clone()
            },
            Status::OverForce,
        ),
        (
            RotaryDrive {
                max_torque: Some(t.abs() * 1.001),
                ..base.clone()
            },
            Status::Ok,
        ),
        // unloaded q inside a range just around it, loaded beyond by its yield
        (
            RotaryDrive {
                min_angle: Some(q - 0.1),
                max_angle: Some(q + 0.1),
                ..base.clone()
            },
            Status::Ok,
        ),
        (
            RotaryDrive {
                min_angle: Some(q + 0.01),
                max_angle: Some(q + 0.5),
                ..base.clone()
            },
            Status::OutOfStroke,
        ),
        (
            RotaryDrive {
                min_angle: Some(q - 0.5),
                max_angle: Some(q - 0.01),
                ..base.clone()
            },
            Status::OutOfStroke,
        ),
        (
            RotaryDrive {
                min_angle: Some(q - dq.abs() / 2.0),
                max_angle: Some(q + dq.abs() / 2.0),
                ..base.clone()
            },
            Status::OutOfStroke,
        ),
        // one stop only, on the side the load turns the drive to: the yield crosses it
        if dq < 0.0 {
            (
                RotaryDrive {
                    min_angle: Some(q + dq / 2.0),
                    ..base.clone()
                },
                Status::OutOfStroke,
            )
        } else {
            (
                RotaryDrive {
                    max_angle: Some(q + dq / 2.0),
                    ..base.clone()
                },
                Status::OutOfStroke,
            )
        },
        // one stop only, just past q: q is taken within a turn of it (the other way round)
        (
            RotaryDrive {
                min_angle: Some(q + 0.01 * dq.signum()),
                ..base.clone()
            },
            Status::Ok,
        ),
        // the same range a turn away: q is taken modulo a turn
        (
            RotaryDrive {
                min_angle: Some(q - 0.1 + std::f64::consts::TAU),
                max_angle: Some(q + 0.1 + std::f64::consts::TAU),
                ..base.clone()
            },
            Status::Ok,
        ),
    ];
    for (d, want) in cases {
        set(&mut arm, d.clone());
        let (_, st) = solve(
            &arm,
            vec![],
            &alpha,
            &payload,
            ExtraDeformations::none(),
            true,
        );
        assert_eq!(st[0], want.code(), "{d:?}");
    }
    // a drive's pin A at its joint (it has none) is not a singular pose
    let (_, st) = solve(
        &arm,
        vec![],
        &alpha,
        &payload,
        ExtraDeformations::none(),
        true,
    );
    assert_ne!(st[0], Status::NearSingular.code());
}

/// Effects and extra deformations of the wrong kind of drive are refused in one line naming
/// the effect (or array), the joint and what applies there.
#[test]
fn the_wrong_kind_of_effect_is_refused() {
    let mut rng = Rng(5);
    let arm = arm(&[false, true], &mut rng);
    let cases: Vec<(Effect, &str)> = vec![
        (
            Effect::ActuatorCompliance(ActuatorCompliance {
                actuator: 1,
                stiffness: 1e3,
            }),
            "drive_compliance@O2",
        ),
        (
            Effect::MountCompliance(MountCompliance {
                actuator: 1,
                stiffness: 1e3,
            }),
            "drive_compliance@O2",
        ),
        (
            Effect::ActuatorPlay(ActuatorPlay {
                actuator: 1,
                play: 0.1,
                unloaded: Unloaded::Centred,
            }),
            "drive_backlash@O2",
        ),
        (
            Effect::DriveCompliance(DriveCompliance {
                joint: 0,
                stiffness: 1e7,
            }),
            "actuator_compliance@M1",
        ),
        (
            Effect::DriveBacklash(DriveBacklash {
                joint: 0,
                backlash_deg: 0.1,
                unloaded: Unloaded::Centred,
            }),
            "actuator_play@M1",
        ),
        (
            Effect::DriveFriction(DriveFriction {
                joint: 0,
                torque: 1.0,
            }),
            "actuator_friction@M1",
        ),
    ];
    for (e, instead) in cases {
        for err in [
            EffectSet::new(&arm, vec![e.clone()]),
            EffectSet::new_unchecked(&arm, vec![e.clone()]),
        ] {
            let msg = err.unwrap_err().to_string();
            assert!(
                msg.contains(instead) && msg.contains("joint") && !msg.contains('\n'),
                "{msg}"
            );
        }
    }
    let (alpha, payload) = ([80.0, 10.0], [0.0, -9.81]);
    let set = EffectSet::empty();
    let run = |extra: ExtraDeformations<'_>| {
        let mut b = BatchBuffers::new(1, 2);
        let mut st = [0u8];
        solve_batch_status(
            &arm,
            &set,
            input(&alpha, &payload),
            extra,
            opts(true),
            b.out(),
            &mut st,
        )
    };
    let msg = run(ExtraDeformations {
        seen_mm: Some(&[0.0, 0.1]),
        ..Default::default()
    })
    .unwrap_err()
    .to_string();
    assert!(
        msg.contains("extra_seen_mm") && msg.contains("joint 2") && msg.contains("row 0"),
        "{msg}"
    );
    let msg = run(ExtraDeformations {
        turn_rad: Some(&[1e-3, 0.0]),
        ..Default::default()
    })
    .unwrap_err()
    .to_string();
    assert!(
        msg.contains("extra_turn_rad") && msg.contains("joint 1"),
        "{msg}"
    );
    run(ExtraDeformations {
        turn_rad: Some(&[0.0, 1e-3]),
        ..Default::default()
    })
    .unwrap();
}

/// The arm: pins are checked only where a linear actuator uses them; a drive's values are
/// checked naming their keys.
#[test]
fn an_arm_checks_the_pins_its_actuators_use() {
    let mut rng = Rng(11);
    let arm = arm(&[true, true, false], &mut rng);
    assert_eq!(arm.b0, V2::zeros());
    assert_eq!(arm.links[0].a, V2::zeros());
    let rebuild = |d: RotaryDrive| {
        let mut drives = arm.drives.clone();
        drives[1] = Drive::Rotary(d);
        Arm::with_drives(
            arm.g,
            arm.o1,
            arm.b0,
            arm.pivot,
            arm.links.clone(),
            drives,
            arm.measure,
        )
    };
    let base = arm.drives[1].rotary().unwrap().clone();
    for (d, key) in [
        (
            RotaryDrive {
                stiffness: 0.0,
                ..base.clone()
            },
            "actuator[2].stiffness_nmm_per_rad",
        ),
        (
            RotaryDrive {
                mass_kg: -1.0,
                ..base.clone()
            },
            "actuator[2].mass_kg",
        ),
        (
            RotaryDrive {
                max_torque: Some(f64::NAN),
                ..base.clone()
            },
            "actuator[2].max_torque_nmm",
        ),
        (
            RotaryDrive {
                min_angle: Some(1.0),
                max_angle: Some(0.5),
                ..base.clone()
            },
            "actuator[2].min_angle_deg",
        ),
    ] {
        let msg = rebuild(d).unwrap_err().to_string();
        assert!(msg.contains(key), "{msg}");
    }
    // link 2's own A is used (joint 3 linear needs link 2's B)
    let mut links = arm.links.clone();
    links[1].b = links[1].next;
    let msg = Arm::with_drives(
        arm.g,
        arm.o1,
        arm.b0,
        arm.pivot,
        links,
        arm.drives.clone(),
        arm.measure,
    )
    .unwrap_err()
    .to_string();
    assert!(msg.contains("link[2].B"), "{msg}");
}

/// Kinematics: a drive has no pins and no length (NaN); angles from lengths keeps a drive's
/// relative angle from the reference pose and inverts `forward`.
#[test]
fn kinematics_of_a_mixed_arm() {
    let mut rng = Rng(3);
    let rotary = [false, true, false, true];
    let arm = arm(&rotary, &mut rng);
    let n = 4;
    let (alpha, _) = poses(n, 3, &mut rng, false);
    let mut o = vec![0.0; 3 * (n + 1) * 2];
    let (mut a, mut b, mut c) = (
        vec![0.0; 3 * n * 2],
        vec![0.0; 3 * n * 2],
        vec![0.0; 3 * n * 2],
    );
    let (mut m, mut len) = (vec![0.0; 6], vec![0.0; 3 * n]);
    let out = arm_core::kinematics::ForwardOutput {
        o: &mut o,
        a: &mut a,
        b: &mut b,
        c: &mut c,
        measure: &mut m,
        length: &mut len,
    };
    forward_batch(&arm, &alpha, out).unwrap();
    for r in 0..3 {
        for i in 0..n {
            let k = r * n + i;
            assert_eq!(len[k].is_nan(), rotary[i]);
            assert_eq!(a[2 * k].is_nan(), rotary[i]);
            assert_eq!(b[2 * k + 1].is_nan(), rotary[i]);
        }
        // back from the lengths, from a reference pose 3° away in every angle
        let rad: Vec<f64> = alpha[r * n..(r + 1) * n]
            .iter()
            .map(|d| d.to_radians())
            .collect();
        // every angle 0.05 rad off: the drives' relative angles are the true ones
        let reference: Vec<f64> = rad.iter().map(|a| a + 0.05).collect();
        let mut back = vec![0.0; n];
        angles_from_lengths(&arm, &len[r * n..(r + 1) * n], &reference, r, &mut back).unwrap();
        for i in 0..n {
            assert!(
                (back[i] - rad[i]).abs() < 1e-9,
                "row {r} link {i}: {} vs {}",
                back[i],
                rad[i]
            );
        }
        // a finite length at a drive is refused, naming the joint
        let mut bad = len[r * n..(r + 1) * n].to_vec();
        bad[1] = 300.0;
        let err = angles_from_lengths(&arm, &bad, &reference, r, &mut back).unwrap_err();
        assert!(
            matches!(err, ArmError::OutOfRange { .. }) && err.to_string().contains("joint 2"),
            "{err}"
        );
    }
}

/// A sweep of a mixed arm: every cell is the single solve of its pose and payload (values and
/// status; not-ok cells NaN), a drive's force and `dl` are NaN, its length is NaN and its angle
/// range counts in the pose's reachability.
#[test]
fn a_sweep_of_a_mixed_arm_is_its_solves() {
    use arm_core::{sweep, CellFields, Cells, SweepOptions, SweepOut};
    let mut rng = Rng(0xfeed);
    for (case, rotary) in [
        vec![true],
        vec![false, true, false],
        vec![true, true, true, false],
        vec![true, false, true, false, true, false, true],
    ]
    .into_iter()
    .enumerate()
    {
        let n = rotary.len();
        let mut arm = arm(&rotary, &mut rng);
        let j = rotary.iter().position(|&r| r).unwrap();
        let (alpha, _) = poses(n, 12, &mut rng, false);
        // a range that cuts the poses of joint j roughly in half
        let q: Vec<f64> = (0..12)
            .map(|p| {
                let before = if j == 0 { 0.0 } else { alpha[p * n + j - 1] };
                (alpha[p * n + j] - before).to_radians()
            })
            .collect();
        let mut sorted = q.clone();
        sorted.sort_by(f64::total_cmp);
        if let Drive::Rotary(d) = &mut arm.drives[j] {
            d.min_angle = Some(sorted[6]);
            d.max_angle = Some(sorted[6] + 1.0);
        }
        let mass = [0.0, 3.0, 8.0];
        let effects = vec![
            Effect::DriveBacklash(DriveBacklash {
                joint: j,
                backlash_deg: 0.02,
                unloaded: Unloaded::TakenUp,
            }),
            Effect::LinkBending(LinkBending {
                link: n - 1,
                ei: 3e10,
            }),
        ];
        let set = EffectSet::new(&arm, effects.clone()).unwrap();
        let rows = 12 * 3;
        let (mut force, mut dx, mut dy) = (vec![0.0; rows * n], vec![0.0; rows], vec![0.0; rows]);
        let (mut dalpha, mut dl) = (vec![0.0; rows * n], vec![0.0; rows * n]);
        let (mut ok, mut status) = (vec![false; rows], vec![0u8; rows]);
        let (mut length, mut reachable) = (vec![0.0; 12 * n], vec![false; 12]);
        let (mut ex, mut ey) = (vec![0.0; 12], vec![0.0; 12]);
        let out = SweepOut {
            cells: Cells::Values(CellFields {
                force_n: &mut force,
                dx_mm: &mut dx,
                dy_mm: &mut dy,
                dalpha_deg: &mut dalpha,
                dl_mm: &mut dl,
            }),
            ok: &mut ok,
            status: &mut status,
            length_mm: &mut length,
            reachable: &mut reachable,
            effector_x_mm: &mut ex,
            effector_y_mm: &mut ey,
        };
        sweep(
            &arm,
            &set,
            &alpha,
            &mass,
            SweepOptions::default(),
            out,
            &|_| false,
        )
        .unwrap();
        let mut cell_alpha = Vec::new();
        let mut payload = Vec::new();
        for p in 0..12 {
            for m in mass {
                cell_alpha.extend_from_slice(&alpha[p * n..(p + 1) * n]);
                payload.extend_from_slice(&[0.0, -m * arm.g]);
            }
        }
        let (b, st) = solve(
            &arm,
            effects,
            &cell_alpha,
            &payload,
            ExtraDeformations::none(),
            true,
        );
        assert_eq!(status, st, "case {case}");
        let mut seen_out = 0;
        for r in 0..rows {
            let p = r / 3;
            let inside = q[p] >= sorted[6];
            assert_eq!(reachable[p], inside, "case {case} pose {p}");
            if !inside {
                assert_eq!(status[r], Status::OutOfStroke.code());
                seen_out += 1;
            }
            if status[r] != 0 {
                assert!(!ok[r] && dx[r].is_nan());
                continue;
            }
            assert_eq!(
                (dx[r], dy[r]),
                (b.dx_mm[r], b.dy_mm[r]),
                "case {case} row {r}"
            );
            for i in 0..n {
                let k = r * n + i;
                assert_eq!(dalpha[k], b.dalpha_deg[k]);
                assert_eq!(force[k].is_nan(), rotary[i]);
                assert_eq!(dl[k].is_nan(), rotary[i]);
                assert_eq!(length[p * n + i].is_nan(), rotary[i]);
            }
        }
        assert!(seen_out > 0, "case {case}");
    }
}

/// Compensating a mixed arm: the commanded pose puts the loaded measure point on the nominal
/// one; a drive has no length (NaN).
#[test]
fn compensating_a_mixed_arm() {
    use arm_core::{compensate_batch, CompensateBuffers, CompensateOptions, CompensateStatus};
    let mut rng = Rng(0xc0ffee);
    for rotary in [
        vec![true, true],
        vec![false, true, false],
        vec![true, false, true, true],
    ] {
        let n = rotary.len();
        let arm = arm(&rotary, &mut rng);
        let (alpha, payload) = poses(n, 8, &mut rng, false);
        let set = EffectSet::new(
            &arm,
            vec![Effect::LinkBending(LinkBending {
                link: n - 1,
                ei: 2e10,
            })],
        )
        .unwrap();
        let mut b = CompensateBuffers::new(8, n);
        compensate_batch(
            &arm,
            &set,
            input(&alpha, &payload),
            CompensateOptions::default(),
            b.out(),
        )
        .unwrap();
        for p in 0..8 {
            assert_eq!(
                b.status[p],
                CompensateStatus::Ok.code(),
                "{rotary:?} pose {p}"
            );
            assert!(b.residual_mm[p] < 1e-6, "{}", b.residual_mm[p]);
            for i in 0..n {
                assert_eq!(b.length_mm[p * n + i].is_nan(), rotary[i]);
            }
            // the loaded commanded pose's measure point is the nominal unloaded one
            let cmd = &b.alpha_deg[p * n..(p + 1) * n];
            let (s, _) = solve(
                &arm,
                vec![Effect::LinkBending(LinkBending {
                    link: n - 1,
                    ei: 2e10,
                })],
                cmd,
                &payload[2 * p..2 * p + 2],
                ExtraDeformations::none(),
                true,
            );
            let (mut f0, mut f1) = (Frames::new(n), Frames::new(n));
            let rad = |a: &[f64]| a.iter().map(|d| d.to_radians()).collect::<Vec<_>>();
            f0.fill(&arm, &rad(&alpha[p * n..(p + 1) * n]));
            f1.fill(&arm, &rad(cmd));
            let miss = f1.measure + V2::new(s.dx_mm[0], s.dy_mm[0]) - f0.measure;
            assert!(miss.norm() < 1e-6, "{rotary:?} pose {p}: {miss}");
        }
    }
}
