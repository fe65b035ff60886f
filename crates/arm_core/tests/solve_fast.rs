//! The block kernel of `solve_batch` against the general path (`Workspace::solve` pose by
//! pose, `solve_batch_general`): random arms of 1–5 links, random poses and payloads, every
//! built-in effect kind alone and combined, both gap modes, with and without self-weight.
//!
//! Tolerances: 1e-9 mm on lengths, 1e-8 mm on the measure point's displacement (see
//! `worst`), 1e-9 deg on angles, 1e-9 relative on forces. The two paths compute the same
//! model with different formulas (cheap degree trigonometry and rotations composed without
//! cancellation against libm sin/cos, acos and atan2), so they agree to rounding, ≈ 1e-13 mm
//! on these arms; the tolerances leave room for the conditioning of poses near the edge of
//! the generated ranges.

#![allow(clippy::unwrap_used, clippy::needless_range_loop)] // test code: a failure should panic
mod common;
use arm_core::effects::{
    ActuatorCompliance, ActuatorPlay, BaseCompliance, JointClearance, LinkBending, MountCompliance,
    Unloaded,
};
use arm_core::examples::example_arm;
use arm_core::{
    solve_batch_general, solve_batch_status, Actuator, Arm, ArmError, BatchBuffers, BatchInput,
    Effect, EffectSet, ExtraDeformations, Link, SolveOptions, V2,
};
use common::{poses, Rng};
use proptest::prelude::*;

/// The example arm's links (the third one's shape repeated beyond three, with a B pin),
/// points jittered by 15 mm, masses and stiffnesses by ±40 %, the pivot moved off O_1;
/// `limits` sets strokes and force limits around the generated poses' values.
fn arm(n: usize, rng: &mut Rng, limits: bool) -> Arm {
    let ex = example_arm();
    let mut links = Vec::new();
    let mut acts = Vec::new();
    for i in 0..n {
        let (shape, act) = (&ex.links[i.min(2)], ex.actuator(i.min(2)).unwrap());
        let b = if i < 2 {
            shape.b
        } else {
            V2::new(-100.0, 10.0)
        };
        let f = |r: &mut Rng| r.uniform(0.6, 1.4);
        links.push(Link {
            next: rng.jitter(shape.next, 15.0),
            a: rng.jitter(shape.a, 15.0),
            b: rng.jitter(b, 15.0),
            c: rng.jitter(shape.c, 15.0),
            mass_kg: shape.mass_kg * f(rng),
        });
        acts.push(Actuator {
            stiffness: act.stiffness * f(rng),
            mass_kg: act.mass_kg * f(rng),
            min_length: limits.then(|| rng.uniform(150.0, 350.0)),
            max_length: limits.then(|| rng.uniform(350.0, 700.0)),
            max_force: limits.then(|| rng.uniform(50.0, 3000.0)),
        });
    }
    let behind = ex.links[2].next - ex.measure;
    let measure = rng.jitter(links[n - 1].next - behind, 10.0);
    let pivot = rng.jitter(ex.o1, 80.0);
    Arm::new(
        ex.g,
        rng.jitter(ex.o1, 5.0),
        rng.jitter(ex.b0, 10.0),
        pivot,
        links,
        acts,
        measure,
    )
    .unwrap()
}

/// A random set of effects: each kind with probability 1/2 (at a random place, random gap
/// mode), every kind when `all`.
fn effects(n: usize, rng: &mut Rng, all: bool) -> Vec<Effect> {
    let mode = |r: &mut Rng| {
        if r.uniform(0.0, 1.0) < 0.5 {
            Unloaded::Centred
        } else {
            Unloaded::TakenUp
        }
    };
    let mut e = Vec::new();
    let maybe = |r: &mut Rng| all || r.uniform(0.0, 1.0) < 0.5;
    if maybe(rng) {
        e.push(Effect::ActuatorCompliance(ActuatorCompliance {
            actuator: rng.pick(n),
            stiffness: rng.uniform(300.0, 3000.0),
        }));
    }
    if maybe(rng) {
        e.push(Effect::MountCompliance(MountCompliance {
            actuator: rng.pick(n),
            stiffness: rng.uniform(300.0, 5000.0),
        }));
    }
    if maybe(rng) {
        e.push(Effect::ActuatorPlay(ActuatorPlay {
            actuator: rng.pick(n),
            play: rng.uniform(0.0, 0.4),
            unloaded: mode(rng),
        }));
    }
    if maybe(rng) {
        e.push(Effect::JointClearance(JointClearance {
            joint: rng.pick(n),
            clearance: rng.uniform(0.0, 0.4),
            unloaded: mode(rng),
        }));
        // A second joint with clearance now and then.
        if n > 1 && rng.uniform(0.0, 1.0) < 0.5 {
            let j = rng.pick(n);
            if !e
                .iter()
                .any(|x| matches!(x, Effect::JointClearance(c) if c.joint == j))
            {
                e.push(Effect::JointClearance(JointClearance {
                    joint: j,
                    clearance: rng.uniform(0.0, 0.3),
                    unloaded: mode(rng),
                }));
            }
        }
    }
    if maybe(rng) {
        for link in 0..n {
            if all || rng.uniform(0.0, 1.0) < 0.5 {
                e.push(Effect::LinkBending(LinkBending {
                    link,
                    ei: 10f64.powf(rng.uniform(8.5, 11.0)),
                }));
            }
        }
    }
    if maybe(rng) {
        e.push(Effect::BaseCompliance(BaseCompliance {
            stiffness: 10f64.powf(rng.uniform(7.0, 9.0)),
        }));
    }
    e
}

fn run(
    arm: &Arm,
    set: &EffectSet,
    alpha: &[f64],
    payload: &[f64],
    opts: SolveOptions,
    general: bool,
) -> Result<(BatchBuffers, Vec<u8>), ArmError> {
    let rows = payload.len() / 2;
    let mut b = BatchBuffers::new(rows, arm.n());
    let mut st = vec![255u8; rows];
    let input = BatchInput {
        alpha_deg: alpha,
        payload_n: payload,
    };
    let none = ExtraDeformations::none();
    if general {
        solve_batch_general(arm, set, input, none, opts, b.out(), &mut st)?;
    } else {
        solve_batch_status(arm, set, input, none, opts, b.out(), &mut st)?;
    }
    Ok((b, st))
}

/// Largest difference of two output sets, each field against its tolerance (≤ 1 passes).
fn worst(a: &BatchBuffers, b: &BatchBuffers) -> (f64, &'static str) {
    let abs = |x: &[f64], y: &[f64]| {
        x.iter()
            .zip(y)
            .map(|(p, q)| {
                if p.is_nan() && q.is_nan() {
                    0.0
                } else {
                    (p - q).abs()
                }
            })
            .fold(0.0, f64::max)
    };
    let rel = |x: &[f64], y: &[f64]| {
        x.iter()
            .zip(y)
            .map(|(p, q)| (p - q).abs() / (1.0 + q.abs()))
            .fold(0.0, f64::max)
    };
    // The measure point's displacement gets 1e-8 mm: a clearance c offsets a pin along the
    // direction of a force change, and where that change is tiny (a payload near zero on a
    // soft five-link arm) its direction is known only to rounding over |ΔF|, which c turns into
    // ~1e-9 mm (proptest found dy 1.05e-9 mm apart at a sag of 1e-9 mm). Still 1e-5 µm.
    let fields = [
        ("force_n", rel(&a.force_n, &b.force_n), 1e-9),
        ("reaction_n", rel(&a.reaction_n, &b.reaction_n), 1e-9),
        ("dforce_n", rel(&a.dforce_n, &b.dforce_n), 1e-9),
        ("dx_mm", abs(&a.dx_mm, &b.dx_mm), 1e-8),
        ("dy_mm", abs(&a.dy_mm, &b.dy_mm), 1e-8),
        ("dalpha_deg", abs(&a.dalpha_deg, &b.dalpha_deg), 1e-9),
        ("dl_mm", abs(&a.dl_mm, &b.dl_mm), 1e-9),
        ("dlength_mm", abs(&a.dlength_mm, &b.dlength_mm), 1e-9),
        ("length_mm", abs(&a.length_mm, &b.length_mm), 1e-9),
    ];
    fields
        .into_iter()
        .map(|(name, d, tol)| (d / tol, name))
        .fold(
            (0.0, ""),
            |m, x| if x.0 > m.0 || x.0.is_nan() { x } else { m },
        )
}

fn check(seed: u64, n: usize, all: bool, sw: bool, any_direction: bool, limits: bool) {
    let mut rng = Rng(seed | 1);
    let arm = arm(n, &mut rng, limits);
    let set = EffectSet::new(&arm, effects(n, &mut rng, all)).unwrap();
    // 37 rows: two full blocks of 16 and a partial one.
    let (alpha, payload) = poses(n, 37, &mut rng, any_direction);
    let opts = SolveOptions {
        self_weight: sw,
        nan_on_failure: true,
    };
    let (fast, st_fast) = run(&arm, &set, &alpha, &payload, opts, false).unwrap();
    let (gen, st_gen) = run(&arm, &set, &alpha, &payload, opts, true).unwrap();
    let (w, field) = worst(&fast, &gen);
    assert!(
        w <= 1.0,
        "{field} differs by {w:e} × its tolerance, effects {:?}",
        set.effects()
    );
    assert_eq!(st_fast, st_gen, "status, effects {:?}", set.effects());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn kernel_equals_the_general_path(
        seed in any::<u64>(),
        n in 1usize..=5,
        all in any::<bool>(),
        sw in any::<bool>(),
        any_direction in any::<bool>(),
        limits in any::<bool>(),
    ) {
        check(seed, n, all, sw, any_direction, limits);
    }
}

/// Large batches go through rayon's chunks; the outputs do not depend on it.
#[test]
fn a_parallel_batch_equals_the_general_path() {
    let mut rng = Rng(0x5EED_1234_ABCD_0001);
    let arm = arm(3, &mut rng, true);
    let set = EffectSet::new(&arm, effects(3, &mut rng, true)).unwrap();
    let (alpha, payload) = poses(3, 5000, &mut rng, false);
    let opts = SolveOptions::default();
    let (fast, st_fast) = run(&arm, &set, &alpha, &payload, opts, false).unwrap();
    let (gen, st_gen) = run(&arm, &set, &alpha, &payload, opts, true).unwrap();
    let (w, field) = worst(&fast, &gen);
    assert!(w <= 1.0, "{field} differs by {w:e} × its tolerance");
    assert_eq!(st_fast, st_gen);
}

/// A singular pose (actuator 1 through its joint) and a triangle that cannot close: the
/// same error naming the same row as the general path, or NaN rows with `nan_on_failure`,
/// and the status of what is known of them.
#[test]
fn failing_poses_fail_as_in_the_general_path() {
    let arm = example_arm();
    let set = EffectSet::empty();
    let mut rng = Rng(99);
    let (mut alpha, mut payload) = poses(3, 20, &mut rng, false);
    // Row 5: link 1 turned so that A_1 lies on the line from B_0 through O_1.
    let (o1, b0, a1) = (arm.o1, arm.b0, arm.links[0].a);
    let away = o1 - b0;
    alpha[15] = (away.y.atan2(away.x) - a1.y.atan2(a1.x)).to_degrees();
    // Row 11: a payload so large that actuator 3 cannot stretch far enough.
    payload[2 * 11 + 1] = -1e9;
    let strict = SolveOptions {
        self_weight: true,
        nan_on_failure: false,
    };
    let e_fast = run(&arm, &set, &alpha, &payload, strict, false).unwrap_err();
    let e_gen = run(&arm, &set, &alpha, &payload, strict, true).unwrap_err();
    assert_eq!(e_fast.to_string(), e_gen.to_string());
    assert!(e_fast.to_string().contains("row 5"), "{e_fast}");
    let lenient = SolveOptions {
        nan_on_failure: true,
        ..strict
    };
    let (fast, st) = run(&arm, &set, &alpha, &payload, lenient, false).unwrap();
    let (gen, st_gen) = run(&arm, &set, &alpha, &payload, lenient, true).unwrap();
    assert!(worst(&fast, &gen).0 <= 1.0);
    assert!(fast.dx_mm[5].is_nan() && fast.dx_mm[11].is_nan());
    assert!(fast.dx_mm[4].is_finite() && fast.dx_mm[12].is_finite());
    assert_eq!(st, st_gen);
    // A pin on the line through its joint is near singular; an unclosed triangle has NaN
    // angles, a deflection too large to trust.
    assert_eq!(st[5], arm_core::Status::NearSingular.code());
    assert_eq!(st[11], arm_core::Status::LargeDeflection.code());
}

/// The case proptest found: a five-link arm with every effect, one pose nearly unloaded.
#[test]
fn a_nearly_unloaded_pose_with_a_clearance_agrees_to_its_conditioning() {
    check(6758891565372335672, 5, true, false, false, false);
}
