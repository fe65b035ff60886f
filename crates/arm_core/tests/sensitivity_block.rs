//! The Jacobian of `fit`/`diagnose` on the block kernel (`jacobian_batch`) against the general
//! path pose by pose (`jacobian_batch_general`): random arms of 1–7 links (7 takes the general
//! path in both), random models and probes of every code 0–7, random poses and payloads, in
//! batches that run on one thread and in parallel chunks; and rows that fail, for every set or
//! for one stepped set only.
//!
//! Tolerances. Both paths solve the same model with different formulas (the kernel's cheap
//! degree trigonometry against libm), so their solves agree to rounding: measured < 1e-11 of
//! (1 mm + the row's largest channel). Channels y must agree to [`TOL`] = 1e-10 of that, and
//! so must every Jacobian entry times 2h, the difference of its two stepped solves that the
//! central difference divides by 2h (h is 1e-3 of the parameter's scale, as small as 1e-4 mm
//! for a gap, so the Jacobian itself agrees only to about 1e-7 relative where a probe moves
//! the arm by micrometres). A wrong set, step, channel or row differs by order one.

#![allow(clippy::unwrap_used, clippy::needless_range_loop)] // test code: a failure should panic
use arm_core::examples::example_arm;
use arm_core::sensitivity::{jacobian_batch, jacobian_batch_general, n_channels, step, Place};
use arm_core::{Actuator, Arm, ArmError, BatchInput, Link, SolveOptions, V2};
use proptest::prelude::Rng as _;
use proptest::test_runner::{RngAlgorithm, TestRng};

/// A deterministic generator (proptest's ChaCha, seeded).
struct Rng(TestRng);

impl Rng {
    fn new(seed: u64) -> Self {
        let mut bytes = [0u8; 32];
        bytes[..8].copy_from_slice(&seed.to_le_bytes());
        Self(TestRng::from_seed(RngAlgorithm::ChaCha, &bytes))
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.0.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
    fn pick(&mut self, n: usize) -> usize {
        (self.uniform(0.0, n as f64) as usize).min(n - 1)
    }
    fn near(&mut self, p: V2, d: f64) -> V2 {
        p + V2::new(self.uniform(-d, d), self.uniform(-d, d))
    }
}

/// The example arm's links, the third one's shape repeated beyond three (with a B pin), pins
/// moved by up to 10 mm, masses and stiffnesses by ±30 %, no limits.
fn arm(n: usize, rng: &mut Rng) -> Arm {
    let ex = example_arm();
    let (mut links, mut acts) = (Vec::new(), Vec::new());
    for i in 0..n {
        let (shape, act) = (&ex.links[i.min(2)], ex.actuator(i.min(2)).unwrap());
        let b = if i < 2 {
            shape.b
        } else {
            V2::new(-100.0, 10.0)
        };
        links.push(Link {
            next: rng.near(shape.next, 10.0),
            a: rng.near(shape.a, 10.0),
            b: rng.near(b, 10.0),
            c: rng.near(shape.c, 10.0),
            mass_kg: shape.mass_kg * rng.uniform(0.7, 1.3),
        });
        acts.push(Actuator {
            stiffness: act.stiffness * rng.uniform(0.7, 1.3),
            mass_kg: act.mass_kg * rng.uniform(0.7, 1.3),
            min_length: None,
            max_length: None,
            max_force: None,
        });
    }
    let measure = rng.near(links[n - 1].next - (ex.links[2].next - ex.measure), 10.0);
    let pivot = rng.near(ex.pivot, 50.0);
    Arm::new(
        ex.g,
        ex.o1,
        rng.near(ex.b0, 10.0),
        pivot,
        links,
        acts,
        measure,
    )
    .unwrap()
}

/// A θ of `code` in the ranges of the solve tests (1/k, gap, 1/EI, 1/k_base).
fn theta(code: i64, rng: &mut Rng) -> f64 {
    match code {
        0 => 1.0 / rng.uniform(300.0, 3000.0),
        1 => 1.0 / rng.uniform(300.0, 5000.0),
        2 | 3 | 6 | 7 => rng.uniform(0.0, 0.4),
        4 => 10f64.powf(-rng.uniform(8.5, 11.0)),
        _ => 10f64.powf(-rng.uniform(7.0, 9.0)),
    }
}

/// Play (2, 6) and clearance (3, 7) are one effect per place whatever the gap mode.
fn kind(code: i64) -> i64 {
    match code {
        6 => 2,
        7 => 3,
        c => c,
    }
}

fn place(code: i64, n: usize, rng: &mut Rng) -> Place {
    let index = if code == 5 { 0 } else { rng.pick(n) };
    Place { code, index }
}

/// A model of up to three effects and up to eight probes, of every code 0–7; a probe may be
/// in the model (differentiated at its θ), never the same place in the other gap mode.
fn model_and_probes(n: usize, rng: &mut Rng) -> (Vec<(Place, f64)>, Vec<Place>) {
    let mut model: Vec<(Place, f64)> = Vec::new();
    for _ in 0..rng.pick(4) {
        let code = rng.pick(8) as i64;
        let pl = place(code, n, rng);
        if !model
            .iter()
            .any(|(q, _)| kind(q.code) == kind(code) && q.index == pl.index)
        {
            model.push((pl, theta(code, rng)));
        }
    }
    let mut probes: Vec<Place> = Vec::new();
    for _ in 0..rng.pick(9) {
        let pl = if !model.is_empty() && rng.uniform(0.0, 1.0) < 0.25 {
            model[rng.pick(model.len())].0
        } else {
            place(rng.pick(8) as i64, n, rng)
        };
        let clash = |q: &Place| kind(q.code) == kind(pl.code) && q.index == pl.index && *q != pl;
        if !model.iter().any(|(q, _)| clash(q)) && !probes.contains(&pl) {
            probes.push(pl);
        }
    }
    (model, probes)
}

/// `rows` poses (deg) in the seed's ranges, payloads of 0–10 kg down or any force to 100 N.
fn poses(n: usize, rows: usize, rng: &mut Rng) -> (Vec<f64>, Vec<f64>) {
    let ranges = [(60.0, 110.0), (0.0, 30.0), (-10.0, 10.0), (-15.0, 15.0)];
    let (mut alpha, mut payload) = (Vec::new(), Vec::new());
    let any_direction = rng.uniform(0.0, 1.0) < 0.3;
    for _ in 0..rows {
        for i in 0..n {
            let (lo, hi) = ranges[i.min(3)];
            alpha.push(rng.uniform(lo, hi));
        }
        if any_direction {
            payload.extend([rng.uniform(-100.0, 100.0), rng.uniform(-100.0, 100.0)]);
        } else {
            payload.extend([0.0, -9.81 * rng.uniform(0.0, 10.0)]);
        }
    }
    (alpha, payload)
}

/// Agreement of the two paths' solves, relative to 1 mm + the row's largest channel (mm, deg):
/// see the module doc.
const TOL: f64 = 1e-10;

type Jac = Result<(Vec<f64>, Vec<f64>), ArmError>;

struct Case<'a> {
    arm: &'a Arm,
    model: &'a [(Place, f64)],
    probes: &'a [Place],
    alpha: &'a [f64],
    payload: &'a [f64],
}

impl Case<'_> {
    fn run(&self, opts: SolveOptions, general: bool) -> Jac {
        let rows = self.payload.len() / 2;
        let c = n_channels(self.arm.n());
        let (mut y, mut jac) = (vec![0.0; rows * c], vec![0.0; rows * c * self.probes.len()]);
        let input = BatchInput {
            alpha_deg: self.alpha,
            payload_n: self.payload,
        };
        let f = if general {
            jacobian_batch_general
        } else {
            jacobian_batch
        };
        f(
            self.arm,
            self.model,
            self.probes,
            input,
            opts,
            &mut y,
            &mut jac,
        )?;
        Ok((y, jac))
    }

    /// Both paths, with and without `nan_on_failure`; panics where they differ. Returns the
    /// rows that are NaN (with `nan_on_failure`).
    fn agree(&self, self_weight: bool) -> Vec<usize> {
        let c = n_channels(self.arm.n());
        let strict = SolveOptions {
            self_weight,
            nan_on_failure: false,
        };
        match (self.run(strict, false), self.run(strict, true)) {
            (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
            (Ok(a), Ok(b)) => close(self, &a, &b),
            (a, b) => panic!(
                "one path failed: block {:?}, general {:?}",
                a.err(),
                b.err()
            ),
        }
        let lenient = SolveOptions {
            nan_on_failure: true,
            ..strict
        };
        let a = self.run(lenient, false).unwrap();
        let b = self.run(lenient, true).unwrap();
        close(self, &a, &b);
        (0..a.0.len() / c)
            .filter(|&r| a.0[r * c].is_nan())
            .collect()
    }
}

/// NaN exactly where the reference has NaN, and then in the whole row; elsewhere y and every
/// Jacobian entry times 2h (the difference of its two stepped solves) to [`TOL`] of 1 mm plus
/// the row's largest channel.
fn close(case: &Case<'_>, a: &(Vec<f64>, Vec<f64>), b: &(Vec<f64>, Vec<f64>)) {
    let c = n_channels(case.arm.n());
    let p = case.probes.len();
    let two_h: Vec<f64> = (case.probes.iter())
        .map(|&q| 2.0 * step(case.arm, case.model, q).1)
        .collect();
    for r in 0..a.0.len() / c {
        let nan = b.0[r * c].is_nan();
        let (ya, yb) = (&a.0[r * c..(r + 1) * c], &b.0[r * c..(r + 1) * c]);
        let (ja, jb) = (
            &a.1[r * c * p..(r + 1) * c * p],
            &b.1[r * c * p..(r + 1) * c * p],
        );
        for (x, z) in ya.iter().zip(yb).chain(ja.iter().zip(jb)) {
            assert_eq!(x.is_nan(), nan, "row {r}: NaN in one path only");
            assert_eq!(z.is_nan(), nan, "row {r}: a partly NaN reference row");
        }
        if nan {
            continue;
        }
        let tol = TOL * (1.0 + yb.iter().fold(0.0, |m: f64, v| m.max(v.abs())));
        for k in 0..c {
            let (x, z) = (ya[k], yb[k]);
            assert!((x - z).abs() <= tol, "y row {r} channel {k}: {x} vs {z}");
            for j in 0..p {
                let (x, z) = (ja[k * p + j], jb[k * p + j]);
                let d = (x - z).abs() * two_h[j];
                assert!(
                    d <= tol,
                    "jac row {r} channel {k} probe {j}: {x} vs {z}, 2h·Δ = {d:e}"
                );
            }
        }
    }
}

/// Random arms of 1–7 links, models, probes and poses; 40 rows (parallel chunks when there
/// are ≥ 13 effect sets) or 3 rows (one partial block).
#[test]
fn block_jacobian_equals_the_general_one() {
    let mut rng = Rng::new(0x0123_4567_89AB_CDEF);
    let mut nan_rows = 0;
    for case in 0..280 {
        let n = 1 + case % 7;
        let arm = arm(n, &mut rng);
        let (model, probes) = model_and_probes(n, &mut rng);
        let rows = if case % 5 == 0 { 3 } else { 40 };
        let (alpha, payload) = poses(n, rows, &mut rng);
        let case = Case {
            arm: &arm,
            model: &model,
            probes: &probes,
            alpha: &alpha,
            payload: &payload,
        };
        nan_rows += case.agree(rng.uniform(0.0, 1.0) < 0.8).len();
    }
    // The generated poses are solvable nearly everywhere; the failing ones are below.
    assert!(nan_rows < 280 * 40 / 20, "{nan_rows} rows failed");
}

/// The example arm with a soft mount in actuator 2, and a payload pulling its link along the
/// actuator until the triangle of actuator 3 cannot close (about 2 kN): `boundary` is a
/// downward payload just below the limit of the model, where the model solves and the
/// model with the mount's θ + h (softer) does not.
fn example_case() -> (Arm, Vec<(Place, f64)>, Vec<Place>, f64) {
    let arm = example_arm();
    let mount = Place { code: 1, index: 1 };
    let model = vec![(mount, 1.0 / 300.0)];
    let probes = vec![
        Place { code: 0, index: 0 },
        Place { code: 3, index: 2 },
        mount,
        Place { code: 5, index: 0 },
    ];
    let alpha = [80.0, 10.0, 0.0];
    let solves = |f: f64| {
        let case = Case {
            arm: &arm,
            model: &model,
            probes: &[],
            alpha: &alpha,
            payload: &[0.0, -f],
        };
        let lenient = SolveOptions {
            self_weight: true,
            nan_on_failure: true,
        };
        !case.run(lenient, true).unwrap().0[0].is_nan()
    };
    let (mut lo, mut hi) = (0.0, 1e9);
    assert!(solves(lo) && !solves(hi));
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if solves(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (arm, model, probes, lo * (1.0 - 1e-7))
}

/// Rows that fail: a singular pose and an impossible payload (every set fails), and a row at
/// the limit where only one stepped set fails. NaN rows in the same places with
/// `nan_on_failure`, else the error of the lowest failing row, as in the general path, on one
/// thread and across parallel chunks.
#[test]
fn failing_rows_fail_as_in_the_general_path() {
    let (arm, model, probes, boundary) = example_case();
    let one = |f: f64, probes: &[Place]| {
        let case = Case {
            arm: &arm,
            model: &model,
            probes,
            alpha: &[80.0, 10.0, 0.0],
            payload: &[0.0, -f],
        };
        case.agree(true).len()
    };
    // The boundary row solves for the model and fails only with the probes' stepped sets.
    assert_eq!(one(boundary, &[]), 0);
    assert_eq!(one(boundary, &probes), 1);

    let mut rng = Rng::new(77);
    for rows in [20, 3000] {
        let (mut alpha, mut payload) = poses(3, rows, &mut rng);
        let mut set_row = |r: usize, a: [f64; 3], f: f64| {
            alpha[3 * r..3 * r + 3].copy_from_slice(&a);
            payload[2 * r..2 * r + 2].copy_from_slice(&[0.0, -f]);
        };
        // A_1 on the line from B_0 through O_1: singular.
        let away = arm.o1 - arm.b0;
        let a1 = arm.links[0].a;
        let singular = (away.y.atan2(away.x) - a1.y.atan2(a1.x)).to_degrees();
        let last = rows - 1;
        set_row(rows / 2, [singular, 10.0, 0.0], 10.0);
        set_row(last, [80.0, 10.0, 0.0], 1e9);
        set_row(rows / 3, [80.0, 10.0, 0.0], boundary);
        let case = Case {
            arm: &arm,
            model: &model,
            probes: &probes,
            alpha: &alpha,
            payload: &payload,
        };
        assert_eq!(case.agree(true), vec![rows / 3, rows / 2, last]);
        let strict = SolveOptions::default();
        let err = case.run(strict, false).unwrap_err().to_string();
        assert!(err.contains(&format!("row {}", rows / 3)), "{err}");
    }
}
