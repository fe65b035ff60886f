//! The sweep against `Workspace::solve`, cell by cell: the block kernel (baseline and the
//! length-only effects) to 1e-10 relative, the per-cell path exactly; NaN/ok for singular and
//! unclosable cells; reductions against a naive reduction of the full output; independence
//! of chunk size and thread count; cancellation; bad options; the reachability mask.

#![allow(clippy::unwrap_used, clippy::needless_range_loop)] // test code: a failure should panic
mod common;
use arm_core::effects::{
    ActuatorCompliance, ActuatorFriction, ActuatorPlay, BaseCompliance, JointClearance,
    JointFriction, LinkBending, MountCompliance, Unloaded,
};
use arm_core::examples::example_arm;
use arm_core::kinematics::Frames;
use arm_core::sweep::{
    sweep, sweep_poses, CellFields, Cells, Grid, Poses, Reduce, ReduceOp, SweepOptions, SweepOut,
};
use arm_core::validity::{self, classify, Checks, Status};
use arm_core::{Actuator, Arm, ArmError, Effect, EffectSet, Link, SolveOptions, Workspace};
use common::{v, Rng};

/// The example arm (`arm_core::examples`) with `n` links (the third link's shape repeated
/// beyond three), every point jittered by up to 10 mm (O_1 by up to 5 mm), masses and
/// stiffnesses by up to ±30 %, optional strokes (none by default), no force limits.
fn arm(n: usize, rng: &mut Rng, strokes: Option<(f64, f64)>) -> Arm {
    let ex = example_arm();
    // The example's last link has no B pin (nothing follows it); where its shape is repeated
    // for a further link, it gets this one.
    let repeated_b = v(-100.0, 10.0);
    let mut links = Vec::new();
    let mut acts = Vec::new();
    for i in 0..n {
        let (shape, act) = (&ex.links[i.min(2)], ex.actuator(i.min(2)).unwrap());
        let b = if i < 2 { shape.b } else { repeated_b };
        let f = |r: &mut Rng| r.uniform(0.7, 1.3);
        links.push(Link {
            next: rng.jitter(shape.next, 10.0),
            a: rng.jitter(shape.a, 10.0),
            b: rng.jitter(b, 10.0),
            c: rng.jitter(shape.c, 10.0),
            mass_kg: shape.mass_kg * f(rng),
        });
        acts.push(Actuator {
            stiffness: act.stiffness * f(rng),
            mass_kg: act.mass_kg * f(rng),
            min_length: strokes.map(|s| s.0),
            max_length: strokes.map(|s| s.1),
            max_force: None,
        });
    }
    // The measurement point keeps its offset from the load point, (80, 40) mm behind and below.
    let behind = ex.links[2].next - ex.measure;
    let measure = rng.jitter(links[n - 1].next - behind, 10.0);
    Arm::new(
        ex.g,
        rng.jitter(ex.o1, 5.0),
        rng.jitter(ex.b0, 10.0),
        ex.pivot,
        links,
        acts,
        measure,
    )
    .unwrap()
}

/// `count` poses of an `n`-link arm (degrees), in the seed's ranges.
fn poses(n: usize, count: usize, rng: &mut Rng) -> Vec<f64> {
    let ranges = [(60.0, 110.0), (0.0, 30.0), (-10.0, 10.0), (-15.0, 15.0)];
    let mut a = Vec::with_capacity(n * count);
    for _ in 0..count {
        for i in 0..n {
            let (lo, hi) = ranges[i.min(3)];
            a.push(rng.uniform(lo, hi));
        }
    }
    a
}

/// Every output of a sweep, owned.
#[derive(Debug, Clone, PartialEq)]
struct Outs {
    force: Vec<f64>,
    dx: Vec<f64>,
    dy: Vec<f64>,
    dalpha: Vec<f64>,
    dl: Vec<f64>,
    idx: Option<[Vec<i64>; 5]>,
    ok: Vec<bool>,
    status: Vec<u8>,
    length: Vec<f64>,
    reachable: Vec<bool>,
    ex: Vec<f64>,
    ey: Vec<f64>,
}

impl Outs {
    fn bits(&self) -> Vec<u64> {
        let mut b: Vec<u64> = [&self.force, &self.dx, &self.dy, &self.dalpha, &self.dl]
            .iter()
            .flat_map(|v| v.iter().map(|x| x.to_bits()))
            .collect();
        b.extend(
            self.length
                .iter()
                .chain(&self.ex)
                .chain(&self.ey)
                .map(|x| x.to_bits()),
        );
        b
    }
}

fn run(
    arm: &Arm,
    effects: &EffectSet,
    alpha: &[f64],
    mass: &[f64],
    opts: SweepOptions,
    cancel: &(dyn Fn(usize) -> bool + Sync),
) -> Result<Outs, ArmError> {
    let poses = alpha.len() / arm.n();
    run_poses(
        arm,
        effects,
        Poses::Rows(alpha),
        poses,
        mass,
        opts,
        cancel,
        poses,
    )
}

/// A sweep of `poses` poses from `src`, with a `reachable` buffer of `reach_len` values.
#[allow(clippy::too_many_arguments)]
fn run_poses(
    arm: &Arm,
    effects: &EffectSet,
    src: Poses<'_>,
    poses: usize,
    mass: &[f64],
    opts: SweepOptions,
    cancel: &(dyn Fn(usize) -> bool + Sync),
    reach_len: usize,
) -> Result<Outs, ArmError> {
    let n = arm.n();
    let group = opts.reduce.map_or(1, |r| r.group);
    let rows = poses * mass.len() / group.max(1);
    let z = |k: usize| vec![0.0; k];
    let mut o = Outs {
        force: z(rows * n),
        dx: z(rows),
        dy: z(rows),
        dalpha: z(rows * n),
        dl: z(rows * n),
        idx: None,
        ok: vec![false; rows],
        status: vec![255; rows],
        length: z(poses * n),
        reachable: vec![false; reach_len],
        ex: z(poses),
        ey: z(poses),
    };
    let arg = opts.reduce.is_some_and(|r| r.op.is_arg());
    let mut idx = [
        vec![0i64; rows * n],
        vec![0i64; rows],
        vec![0i64; rows],
        vec![0i64; rows * n],
        vec![0i64; rows * n],
    ];
    {
        let cells = if arg {
            let [a, b, c, d, e] = &mut idx;
            Cells::Indices(CellFields {
                force_n: a,
                dx_mm: b,
                dy_mm: c,
                dalpha_deg: d,
                dl_mm: e,
            })
        } else {
            Cells::Values(CellFields {
                force_n: &mut o.force,
                dx_mm: &mut o.dx,
                dy_mm: &mut o.dy,
                dalpha_deg: &mut o.dalpha,
                dl_mm: &mut o.dl,
            })
        };
        let out = SweepOut {
            cells,
            ok: &mut o.ok,
            status: &mut o.status,
            length_mm: &mut o.length,
            reachable: &mut o.reachable,
            effector_x_mm: &mut o.ex,
            effector_y_mm: &mut o.ey,
        };
        sweep_poses(arm, effects, src, mass, opts, out, cancel)?;
    }
    if arg {
        o.idx = Some(idx);
    }
    Ok(o)
}

fn never(_finished: usize) -> bool {
    false
}

fn opts(self_weight: bool) -> SweepOptions {
    SweepOptions {
        self_weight,
        ..Default::default()
    }
}

/// The status of a cell by the checks of `arm_core::validity` on the unloaded frames and the
/// solved workspace (`None`: the solve failed); also whether some checked quantity lies
/// within 1e-9 (relative) of its limit, where the sweep's own arithmetic may decide the
/// other way.
fn status_of(arm: &Arm, rad: &[f64], ws: Option<&Workspace>, mass: f64) -> (Status, bool) {
    let n = arm.n();
    let mut f = Frames::new(n);
    f.fill(arm, rad);
    let close = |x: f64, lim: f64| (x - lim).abs() <= 1e-9 * lim.abs().max(1e-9);
    let lengths: Vec<f64> = (0..n).map(|i| f.length(i)).collect();
    let mut border = false;
    let mut near = false;
    for i in 0..n {
        near |= validity::near_singular(f.joint[i], f.a[i], f.b[i]);
        let line = f.a[i] - f.b[i];
        let h = (line.x * (f.joint[i] - f.b[i]).y - line.y * (f.joint[i] - f.b[i]).x).abs()
            / line.norm();
        border |= close(h, validity::MIN_MOMENT_ARM * (f.a[i] - f.joint[i]).norm());
    }
    let pose = Checks {
        out_of_stroke: validity::out_of_stroke(arm, &lengths),
        near_singular: near,
        ..Checks::default()
    };
    if classify(pose) != Status::Ok {
        return (classify(pose), border);
    }
    let Some(ws) = ws else {
        return (Status::LargeDeflection, border);
    };
    let reach = validity::reach(arm);
    let mut turn = 0.0f64;
    let mut loaded_rad = rad.to_vec();
    for i in 0..n {
        let d = (ws.new_alpha[i] - rad[i]).to_degrees();
        turn = turn.max(d.abs());
        border |= close(d.abs(), validity::MAX_DALPHA_DEG);
        loaded_rad[i] = rad[i] + d.to_radians();
        if let Some(m) = arm.actuator(i).unwrap().max_force {
            border |= close(ws.loaded.f[i].abs(), m);
        }
    }
    let mut lf = Frames::new(n);
    lf.fill(arm, &loaded_rad);
    let (dx, dy) = (ws.dmeasure.x, ws.dmeasure.y);
    border |= close(dx.hypot(dy), validity::MAX_DEFLECTION_OF_REACH * reach);
    border |= close(dy, validity::MAX_RISE_OF_REACH * reach);
    let checks = Checks {
        branch_flip: (0..n).any(|i| f.side(i) * lf.side(i) < 0.0),
        over_force: validity::over_force(arm, &ws.loaded.f),
        large_deflection: validity::large_deflection(turn, dx, dy, mass * arm.g > 0.0, reach),
        ..pose
    };
    (classify(checks), border)
}

/// Compares every cell with `Workspace::solve`: its status with the validity checks on the
/// solve's results (exactly, except cells within 1e-9 of a limit, at most 1 % of them), and
/// the values of the cells that are ok; returns the worst error relative to each field's
/// scale (its largest magnitude over the batch).
fn compare(arm: &Arm, eff: &EffectSet, alpha: &[f64], mass: &[f64], sw: bool) -> f64 {
    let n = arm.n();
    let got = run(arm, eff, alpha, mass, opts(sw), &never).unwrap();
    let mut ws = Workspace::new(arm);
    let m = mass.len();
    let mut want = got.clone();
    let (mut ok_cells, mut borderline) = (0, 0);
    for (p, deg) in alpha.chunks(n).enumerate() {
        let rad: Vec<f64> = deg.iter().map(|d| d.to_radians()).collect();
        for (j, &mk) in mass.iter().enumerate() {
            let r = p * m + j;
            let so = SolveOptions {
                self_weight: sw,
                nan_on_failure: false,
            };
            let solved = ws.solve(arm, eff, &rad, v(0.0, -mk * arm.g), so, r).is_ok();
            let (status, border) = status_of(arm, &rad, solved.then_some(&ws), mk);
            borderline += usize::from(border);
            if !border {
                assert_eq!(got.status[r], status.code(), "status of row {r}");
            }
            assert_eq!(got.ok[r], got.status[r] == 0, "ok of row {r}");
            if !got.ok[r] {
                continue;
            }
            assert!(solved, "row {r} is ok but does not solve");
            ok_cells += 1;
            for i in 0..n {
                want.force[r * n + i] = ws.loaded.f[i];
                want.dalpha[r * n + i] = (ws.new_alpha[i] - rad[i]).to_degrees();
                want.dl[r * n + i] = ws.body_dl[i];
            }
            want.dx[r] = ws.dmeasure.x;
            want.dy[r] = ws.dmeasure.y;
        }
    }
    assert!(ok_cells > 0);
    assert!(
        borderline * 100 <= got.ok.len(),
        "{borderline} cells at a limit"
    );
    let mut worst = 0.0f64;
    for (g, w) in [
        (&got.force, &want.force),
        (&got.dx, &want.dx),
        (&got.dy, &want.dy),
        (&got.dalpha, &want.dalpha),
        (&got.dl, &want.dl),
    ] {
        let scale = w
            .iter()
            .filter(|x| x.is_finite())
            .fold(0.0f64, |a, x| a.max(x.abs()));
        for (a, b) in g.iter().zip(w) {
            if b.is_nan() {
                continue;
            }
            if a.is_nan() {
                worst = f64::INFINITY;
            }
            if scale > 0.0 {
                worst = worst.max((a - b).abs() / scale);
            }
        }
    }
    for (r, &ok) in got.ok.iter().enumerate() {
        if !ok {
            assert!(got.dx[r].is_nan() && got.force[r * n].is_nan(), "row {r}");
        }
    }
    worst
}

fn length_only() -> Vec<(&'static str, Vec<Effect>)> {
    vec![
        ("baseline", vec![]),
        (
            "actuator_compliance",
            vec![Effect::ActuatorCompliance(ActuatorCompliance {
                actuator: 0,
                stiffness: 800.0,
            })],
        ),
        (
            "mount_compliance",
            vec![Effect::MountCompliance(MountCompliance {
                actuator: 1,
                stiffness: 1200.0,
            })],
        ),
        (
            "actuator_play",
            vec![Effect::ActuatorPlay(ActuatorPlay {
                actuator: 1,
                play: 0.2,
                unloaded: Unloaded::Centred,
            })],
        ),
        (
            "actuator_play taken up",
            vec![Effect::ActuatorPlay(ActuatorPlay {
                actuator: 0,
                play: 0.2,
                unloaded: Unloaded::TakenUp,
            })],
        ),
        (
            "all length-only",
            vec![
                Effect::ActuatorCompliance(ActuatorCompliance {
                    actuator: 1,
                    stiffness: 700.0,
                }),
                Effect::MountCompliance(MountCompliance {
                    actuator: 0,
                    stiffness: 900.0,
                }),
                Effect::MountCompliance(MountCompliance {
                    actuator: 1,
                    stiffness: 1500.0,
                }),
                Effect::ActuatorPlay(ActuatorPlay {
                    actuator: 0,
                    play: 0.1,
                    unloaded: Unloaded::Centred,
                }),
                Effect::ActuatorPlay(ActuatorPlay {
                    actuator: 1,
                    play: 0.3,
                    unloaded: Unloaded::TakenUp,
                }),
            ],
        ),
    ]
}

fn other_effects() -> Vec<(&'static str, Vec<Effect>)> {
    vec![
        (
            "joint_clearance",
            vec![Effect::JointClearance(JointClearance {
                joint: 1,
                clearance: 0.15,
                unloaded: Unloaded::Centred,
            })],
        ),
        (
            "joint_clearance taken up",
            vec![Effect::JointClearance(JointClearance {
                joint: 2,
                clearance: 0.15,
                unloaded: Unloaded::TakenUp,
            })],
        ),
        (
            "link_bending",
            vec![Effect::LinkBending(LinkBending { link: 0, ei: 2e9 })],
        ),
        (
            "base_compliance",
            vec![Effect::BaseCompliance(BaseCompliance { stiffness: 5e7 })],
        ),
        (
            "mixed",
            vec![
                Effect::BaseCompliance(BaseCompliance { stiffness: 5e8 }),
                Effect::ActuatorPlay(ActuatorPlay {
                    actuator: 0,
                    play: 0.05,
                    unloaded: Unloaded::Centred,
                }),
                Effect::JointClearance(JointClearance {
                    joint: 0,
                    clearance: 0.1,
                    unloaded: Unloaded::Centred,
                }),
            ],
        ),
        (
            // each cell a single loading from its reference: what a friction lets through
            "frictions",
            vec![
                Effect::ActuatorFriction(ActuatorFriction {
                    actuator: 1,
                    friction: 40.0,
                }),
                Effect::JointFriction(JointFriction {
                    joint: 2,
                    torque: 3000.0,
                }),
                Effect::LinkBending(LinkBending { link: 0, ei: 2e9 }),
            ],
        ),
    ]
}

const MASSES: [f64; 5] = [0.0, 0.5, 2.0, 5.0, 8.0];

/// The block kernel equals `Workspace::solve` to 1e-10 of each field's scale, for the
/// baseline and every length-only effect, with and without self-weight, for 1 to 4 links
/// and for a batch that is not a multiple of the block width.
#[test]
fn fast_path_equals_workspace_solve() {
    let mut rng = Rng(0x1234_5678_9ABC_DEF1);
    for n in 2..=4 {
        for trial in 0..4 {
            let arm = arm(n, &mut rng, None);
            let alpha = poses(n, 61 + trial, &mut rng);
            for (name, eff) in length_only() {
                let eff = EffectSet::new(&arm, eff).unwrap();
                for sw in [true, false] {
                    let worst = compare(&arm, &eff, &alpha, &MASSES, sw);
                    assert!(
                        worst < 1e-10,
                        "{name}, n = {n}, self_weight {sw}: {worst:e}"
                    );
                }
            }
        }
    }
    // One link (the length-only effects on actuator 1 only).
    let arm1 = arm(1, &mut rng, None);
    let alpha = poses(1, 40, &mut rng);
    let worst = compare(&arm1, &EffectSet::empty(), &alpha, &MASSES, true);
    assert!(worst < 1e-10, "one link: {worst:e}");
}

/// The fast path is also right where the turn is large enough for `atan2` (soft actuators,
/// heavy payload): the series and the fallback agree with the scalar core.
#[test]
fn fast_path_large_turns() {
    let mut rng = Rng(77);
    let arm = arm(3, &mut rng, None);
    let soft = EffectSet::new(
        &arm,
        (0..3)
            .map(|a| {
                Effect::ActuatorCompliance(ActuatorCompliance {
                    actuator: a,
                    stiffness: 30.0,
                })
            })
            .collect(),
    )
    .unwrap();
    let alpha = poses(3, 40, &mut rng);
    let mass = [1.0, 10.0, 30.0, 60.0];
    let worst = compare(&arm, &soft, &alpha, &mass, true);
    assert!(worst < 1e-10, "{worst:e}");
    // Some triangles turn by more than the series covers (1/16 rad ≈ 3.6°), some by less.
    let out = run(&arm, &soft, &alpha, &mass, opts(true), &never).unwrap();
    let big = out.dalpha.iter().filter(|d| d.abs() > 4.0).count();
    assert!(big > 10 && big < out.dalpha.len() - 10, "{big} large turns");
}

/// The per-cell path (clearance, bending, base tilt) agrees with `Workspace::solve`: through
/// `solve`'s block kernel on arms of up to six links, to its rounding (1e-10 of the field's
/// scale, as the sweep's kernel: another order of the same closure), and exactly on longer
/// arms, where it is `Workspace::solve` itself.
#[test]
fn fallback_path_equals_workspace_solve() {
    let mut rng = Rng(99);
    for (n, exact) in [(3, false), (7, true)] {
        let arm = arm(n, &mut rng, None);
        let alpha = poses(n, 29, &mut rng);
        for (name, eff) in other_effects() {
            let eff = EffectSet::new(&arm, eff).unwrap();
            for sw in [true, false] {
                let worst = compare(&arm, &eff, &alpha, &MASSES, sw);
                let tol = if exact { 0.0 } else { 1e-10 };
                assert!(worst <= tol, "{name}, n = {n}, self_weight {sw}: {worst:e}");
            }
        }
    }
}

/// The status of every cell equals the validity checks on `Workspace::solve`'s results
/// (`compare`), in both kernels (3 links: block kernel; 7 links or a joint clearance: per
/// cell), on arms with strokes and force limits, and each reason occurs.
#[test]
fn status_equals_the_checks_on_solve() {
    let mut rng = Rng(21);
    let mut seen = [0usize; 6];
    let clearance = other_effects().swap_remove(0).1;
    for (n, effects) in [(3, vec![]), (3, clearance), (7, vec![])] {
        let mut arm = arm(n, &mut rng, Some((300.0, 540.0)));
        let mut alpha = poses(n, 300, &mut rng);
        // Actuator 1 without a stroke, and near singular (not singular) in a reachable pose
        // turned as a whole (the other actuators' lengths stay).
        let first_actuator = arm.actuator_mut(0).unwrap();
        (first_actuator.min_length, first_actuator.max_length) = (None, None);
        let none = EffectSet::new(&arm, vec![]).unwrap();
        let first = run(&arm, &none, &alpha, &[1.0], opts(true), &never).unwrap();
        let p = first.reachable.iter().position(|&r| r).unwrap();
        let turn = singular_pose(&arm) + 1.0 - alpha[p * n];
        alpha[p * n..(p + 1) * n]
            .iter_mut()
            .for_each(|a| *a += turn);
        // A force limit on actuator 1 at the median |F1| of the poses under 8 kg.
        let mut ws = Workspace::new(&arm);
        let mut f1: Vec<f64> = alpha
            .chunks(n)
            .enumerate()
            .filter_map(|(r, deg)| {
                let rad: Vec<f64> = deg.iter().map(|d| d.to_radians()).collect();
                let so = SolveOptions::default();
                let ok = ws.solve(&arm, &none, &rad, v(0.0, -8.0 * arm.g), so, r);
                ok.is_ok().then(|| ws.loaded.f[0].abs())
            })
            .collect();
        f1.sort_by(f64::total_cmp);
        arm.actuator_mut(0).unwrap().max_force = Some(f1[f1.len() / 2]);
        let eff = EffectSet::new(&arm, effects).unwrap();
        let mass = [0.0, 2.0, 8.0, 60.0];
        let worst = compare(&arm, &eff, &alpha, &mass, true);
        assert!(worst < 1e-10, "n = {n}: {worst:e}");
        let out = run(&arm, &eff, &alpha, &mass, opts(true), &never).unwrap();
        for &c in &out.status {
            seen[usize::from(c)] += 1;
        }
    }
    // every reason but branch_flip, which neither kernel's closure produces
    for code in [0, 1, 2, 4, 5] {
        assert!(seen[code] > 0, "no cell of status {code}: {seen:?}");
    }
}

/// A pose whose first actuator passes through its joint.
fn singular_pose(arm: &Arm) -> f64 {
    let d = arm.b0 - arm.o1;
    let a = arm.links[0].a;
    (d.y.atan2(d.x) - a.y.atan2(a.x)).to_degrees()
}

/// Singular poses and triangles that cannot close give NaN, ok = false and a status
/// (near_singular, large_deflection), not an error, and the cells around them are unaffected.
#[test]
fn singular_and_unclosable_cells_are_nan() {
    let mut rng = Rng(5);
    let arm = arm(3, &mut rng, None);
    let mut alpha = poses(3, 20, &mut rng);
    alpha[3 * 7] = singular_pose(&arm);
    let soft = EffectSet::new(
        &arm,
        vec![Effect::ActuatorCompliance(ActuatorCompliance {
            actuator: 2,
            stiffness: 500.0,
        })],
    )
    .unwrap();
    let mass = [1.0, 1e5];
    let out = run(&arm, &soft, &alpha, &mass, opts(true), &never).unwrap();
    let (near, large) = (Status::NearSingular.code(), Status::LargeDeflection.code());
    for p in 0..20 {
        assert!(
            !out.ok[p * 2 + 1],
            "pose {p}: a 1e5 kg payload cannot close"
        );
        let why = if p == 7 { near } else { large };
        assert_eq!(out.status[p * 2 + 1], why, "pose {p}");
        assert!(out.dx[p * 2 + 1].is_nan() && out.dalpha[(p * 2 + 1) * 3].is_nan());
        assert_eq!(out.status[p * 2] == near, p == 7, "pose {p}");
        assert_eq!(out.ok[p * 2], out.status[p * 2] == 0, "pose {p}");
        assert_eq!(out.reachable[p], p != 7);
        assert!(
            out.length[p * 3].is_finite(),
            "lengths are written for every pose"
        );
    }
    assert!(out.force[7 * 2 * 3].is_nan() && out.dy[7 * 2].is_nan());
    let worst = compare(&arm, &soft, &alpha, &mass, true);
    assert!(worst < 1e-10);
}

/// Naive reduction of the full output, in row order.
fn naive(
    full: &Outs,
    n: usize,
    op: ReduceOp,
    group: usize,
) -> (Vec<Vec<f64>>, Vec<Vec<i64>>, Vec<bool>) {
    let cols: Vec<(&Vec<f64>, usize)> = vec![
        (&full.force, n),
        (&full.dx, 1),
        (&full.dy, 1),
        (&full.dalpha, n),
        (&full.dl, n),
    ];
    let rows = full.ok.len();
    let groups = rows / group;
    let mut vals = Vec::new();
    let mut idxs = Vec::new();
    for (buf, w) in cols {
        let mut vv = vec![f64::NAN; groups * w];
        let mut ii = vec![-1i64; groups * w];
        for g in 0..groups {
            for c in 0..w {
                for off in 0..group {
                    let x = buf[(g * group + off) * w + c];
                    if x.is_nan() {
                        continue;
                    }
                    let cur = vv[g * w + c];
                    let better = cur.is_nan()
                        || match op {
                            ReduceOp::Max | ReduceOp::ArgMax => x > cur,
                            ReduceOp::Min | ReduceOp::ArgMin => x < cur,
                        };
                    if better {
                        vv[g * w + c] = x;
                        ii[g * w + c] = off as i64;
                    }
                }
            }
        }
        vals.push(vv);
        idxs.push(ii);
    }
    let ok = (0..groups)
        .map(|g| full.ok[g * group..(g + 1) * group].iter().any(|&o| o))
        .collect();
    (vals, idxs, ok)
}

/// Reductions equal a naive reduction of the unreduced output, for groups within a pose,
/// over the payloads, over several poses, and straddling chunks; with NaN cells inside.
#[test]
fn reductions_equal_naive_reduction() {
    let mut rng = Rng(11);
    let arm = arm(3, &mut rng, None);
    let mut alpha = poses(3, 48, &mut rng);
    for p in [5, 6, 7, 20] {
        alpha[3 * p] = singular_pose(&arm); // a whole group of NaN for some groupings
    }
    let mass = [0.0, 1.0, 3.0, 2.0, 8.0, 0.5];
    for eff in [
        EffectSet::empty(),
        EffectSet::new(&arm, other_effects()[2].1.clone()).unwrap(),
    ] {
        let full = run(&arm, &eff, &alpha, &mass, opts(true), &never).unwrap();
        for group in [1, 2, 3, 6, 12, 18, 48, 288] {
            for op in [
                ReduceOp::Max,
                ReduceOp::Min,
                ReduceOp::ArgMax,
                ReduceOp::ArgMin,
            ] {
                let (vals, idxs, ok) = naive(&full, 3, op, group);
                // a group's status: the lowest code of its cells that are not ok, else 0
                let status: Vec<u8> = (full.status.chunks(group))
                    .map(|g| g.iter().copied().filter(|&c| c != 0).min().unwrap_or(0))
                    .collect();
                for chunk_rows in [None, Some(30), Some(100)] {
                    let o = SweepOptions {
                        reduce: Some(Reduce { op, group }),
                        chunk_rows,
                        threads: Some(2),
                        ..opts(true)
                    };
                    let red = run(&arm, &eff, &alpha, &mass, o, &never).unwrap();
                    assert_eq!(red.ok, ok, "ok, group {group}, {op:?}");
                    assert_eq!(red.status, status, "status, group {group}, {op:?}");
                    assert_eq!(red.length, full.length);
                    assert_eq!(red.reachable, full.reachable);
                    if op.is_arg() {
                        let got = red.idx.as_ref().unwrap();
                        for f in 0..5 {
                            assert_eq!(got[f], idxs[f], "field {f}, group {group}, {op:?}");
                        }
                    } else {
                        let got = [&red.force, &red.dx, &red.dy, &red.dalpha, &red.dl];
                        for f in 0..5 {
                            let same = got[f]
                                .iter()
                                .zip(&vals[f])
                                .all(|(a, b)| a == b || (a.is_nan() && b.is_nan()));
                            assert!(same, "field {f}, group {group}, {op:?}, {chunk_rows:?}");
                        }
                    }
                }
            }
        }
    }
}

/// Chunk size and thread count do not change a single bit.
#[test]
fn independent_of_chunks_and_threads() {
    let mut rng = Rng(3);
    let arm = arm(3, &mut rng, Some((150.0, 400.0)));
    let mut alpha = poses(3, 203, &mut rng);
    alpha[3 * 100] = singular_pose(&arm);
    let mass = [0.0, 2.5, 7.0];
    let eff_sets = [
        EffectSet::empty(),
        EffectSet::new(&arm, other_effects()[3].1.clone()).unwrap(),
    ];
    for eff in &eff_sets {
        for reduce in [
            None,
            Some(Reduce {
                op: ReduceOp::Max,
                group: 3,
            }),
            Some(Reduce {
                op: ReduceOp::ArgMin,
                group: 21,
            }),
        ] {
            let base = SweepOptions {
                reduce,
                threads: Some(1),
                ..opts(true)
            };
            let want = run(&arm, eff, &alpha, &mass, base, &never).unwrap();
            for threads in [Some(1), Some(2), Some(3), None] {
                for chunk_rows in [Some(1), Some(24), Some(50), Some(1000), None] {
                    let o = SweepOptions {
                        threads,
                        chunk_rows,
                        ..base
                    };
                    let got = run(&arm, eff, &alpha, &mass, o, &never).unwrap();
                    assert_eq!(got.bits(), want.bits(), "{threads:?} {chunk_rows:?}");
                    assert_eq!(got.ok, want.ok);
                    assert_eq!(got.idx, want.idx);
                    assert_eq!(got.reachable, want.reachable);
                }
            }
        }
    }
}

/// Every instruction set the CPU offers (AVX-512, AVX2, baseline SSE2) gives the same bits.
#[test]
fn instruction_sets_agree_bitwise() {
    let mut rng = Rng(13);
    for (n, effects) in [(3, vec![]), (2, length_only()[4].1.clone()), (4, vec![])] {
        let arm = arm(n, &mut rng, Some((300.0, 540.0)));
        let eff = EffectSet::new(&arm, effects).unwrap();
        let alpha = poses(n, 97, &mut rng);
        let mass = [0.0, 1.5, 6.0];
        let fast = run(&arm, &eff, &alpha, &mass, opts(true), &never).unwrap();
        let base = SweepOptions {
            baseline_simd: true,
            ..opts(true)
        };
        let slow = run(&arm, &eff, &alpha, &mass, base, &never).unwrap();
        assert_eq!(fast.bits(), slow.bits(), "n = {n}");
        assert_eq!(fast.ok, slow.ok);
        assert_eq!(fast.status, slow.status);
        assert_eq!(fast.reachable, slow.reachable);
    }
    // Large turns (the atan2 lanes) and angles beyond the fast reduction (libm lanes).
    let arm = arm(3, &mut rng, None);
    let soft = EffectSet::new(
        &arm,
        vec![Effect::ActuatorCompliance(ActuatorCompliance {
            actuator: 1,
            stiffness: 30.0,
        })],
    )
    .unwrap();
    let mut alpha = poses(3, 50, &mut rng);
    for p in (0..50).step_by(7) {
        alpha[3 * p] += 360.0 * 1e4; // 3.6e6 degrees: the same pose, many turns later
    }
    let mass = [3.0, 5.0, 8.0, 40.0];
    let fast = run(&arm, &soft, &alpha, &mass, opts(true), &never).unwrap();
    let base = SweepOptions {
        baseline_simd: true,
        ..opts(true)
    };
    let slow = run(&arm, &soft, &alpha, &mass, base, &never).unwrap();
    assert_eq!(fast.bits(), slow.bits(), "soft arm");
    assert_eq!(fast.status, slow.status, "soft arm");
    // turns beyond the series (asin 1/16 ≈ 3.6°) within the 10° limit, and beyond it
    let big = fast
        .dalpha
        .iter()
        .filter(|d| d.is_finite())
        .fold(0.0f64, |a, d| a.max(d.abs()));
    assert!(big > 4.0, "{big}");
    let large = Status::LargeDeflection.code();
    assert!(fast.status.contains(&large));
    let worst = compare(&arm, &soft, &alpha, &mass, true);
    // The scale is that of the ok cells (turns ≤ 10°); the scalar core's closure (acos of a
    // cosine) loses a few 1e-10 of a 9° turn, which 1e-9 allows.
    assert!(worst < 1e-9, "{worst:e}");
}

/// `cancel` returning true stops the sweep with `Cancelled`, on one thread and on several.
#[test]
fn cancel_returns_cancelled() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let mut rng = Rng(8);
    let arm = arm(3, &mut rng, None);
    let alpha = poses(3, 4000, &mut rng);
    for threads in [Some(1), Some(2), None] {
        // With one thread every chunk passes through `cancel`: true at its third call stops
        // there. With pool threads they may take every chunk while the calling thread waits
        // (no timing is assumed): true at the first call, which comes before any pool thread
        // starts, always stops the sweep. (It came when the calling thread took its first
        // chunk until a loop of this test under load found the pool threads had taken them
        // all, once in 40 runs: the sweep ran to the end.)
        let stop_at = if threads == Some(1) { 2 } else { 0 };
        let calls = AtomicUsize::new(0);
        let cancel = |_| calls.fetch_add(1, Ordering::Relaxed) >= stop_at;
        let o = SweepOptions {
            threads,
            chunk_rows: Some(64),
            ..opts(true)
        };
        let r = run(&arm, &EffectSet::empty(), &alpha, &[1.0], o, &cancel);
        assert_eq!(r.unwrap_err(), ArmError::Cancelled, "{threads:?}");
        assert_eq!(
            calls.load(Ordering::Relaxed),
            stop_at + 1,
            "stops at the first true"
        );
        // never cancelled: runs to the end
        let r = run(&arm, &EffectSet::empty(), &alpha, &[1.0], o, &never);
        assert!(r.is_ok());
    }
}

/// `cancel` is asked before any chunk starts, so that a sweep always reports once and an
/// interrupt that came early stops it however the threads share the chunks; it is asked
/// with 0 poses done, on one thread or several.
#[test]
fn cancel_is_asked_before_the_first_chunk() {
    let mut rng = Rng(9);
    let arm = arm(3, &mut rng, None);
    let alpha = poses(3, 4000, &mut rng);
    for threads in [Some(1), Some(2), None] {
        let asked = std::sync::Mutex::new(Vec::new());
        let cancel = |done| {
            asked.lock().map(|mut a| a.push(done)).ok();
            true
        };
        let o = SweepOptions {
            threads,
            chunk_rows: Some(64),
            ..opts(true)
        };
        let r = run(&arm, &EffectSet::empty(), &alpha, &[1.0], o, &cancel);
        assert_eq!(r.unwrap_err(), ArmError::Cancelled, "{threads:?}");
        let asked = asked.into_inner().unwrap_or_default();
        assert_eq!(
            asked,
            [0],
            "{threads:?}: stops at its first check, before any pose"
        );
    }
}

/// Bad options and inputs are errors that name what is wrong.
#[test]
fn bad_options_are_errors() {
    let mut rng = Rng(21);
    let arm = arm(3, &mut rng, None);
    let alpha = poses(3, 10, &mut rng);
    let eff = EffectSet::empty();
    let red = |group| SweepOptions {
        reduce: Some(Reduce {
            op: ReduceOp::Max,
            group,
        }),
        ..opts(true)
    };
    for group in [0, 3, 7, 40] {
        let e = run(&arm, &eff, &alpha, &[1.0, 2.0], red(group), &never).unwrap_err();
        assert!(
            matches!(e, ArmError::InvalidOption(_)),
            "group {group}: {e}"
        );
    }
    assert!(run(&arm, &eff, &alpha, &[1.0, 2.0], red(5), &never).is_ok());
    let e = run(
        &arm,
        &eff,
        &alpha,
        &[1.0],
        SweepOptions {
            threads: Some(0),
            ..opts(true)
        },
        &never,
    )
    .unwrap_err();
    assert!(matches!(e, ArmError::InvalidOption(_)));
    let e = run(&arm, &eff, &alpha, &[1.0, -2.0], opts(true), &never).unwrap_err();
    assert!(e.to_string().contains("mass_kg[1]"), "{e}");
    let e = run(&arm, &eff, &alpha, &[f64::NAN], opts(true), &never).unwrap_err();
    assert!(e.to_string().contains("mass_kg[0]"), "{e}");
    let e = run(&arm, &eff, &alpha[..29], &[1.0], opts(true), &never).unwrap_err();
    assert!(matches!(e, ArmError::Shape { .. }), "{e}");
    // The lowest non-finite pose is named, whatever the threads and chunks.
    let mut bad = poses(3, 3000, &mut rng);
    bad[3 * 2500 + 1] = f64::INFINITY;
    bad[3 * 1700] = f64::NAN;
    for threads in [Some(1), Some(2)] {
        let o = SweepOptions {
            threads,
            chunk_rows: Some(64),
            ..opts(true)
        };
        let e = run(&arm, &eff, &bad, &[1.0], o, &never).unwrap_err();
        assert_eq!(
            e,
            ArmError::NonFinite {
                row: 1700,
                what: "alpha_deg"
            }
        );
    }
    // An output buffer of the wrong size.
    let mut small = vec![0.0; 5];
    let (mut a, mut b, mut c, mut d) = (vec![0.0; 30], vec![0.0; 10], vec![0.0; 10], vec![0.0; 30]);
    let mut ok = vec![false; 10];
    let out = SweepOut {
        cells: Cells::Values(CellFields {
            force_n: &mut a,
            dx_mm: &mut small,
            dy_mm: &mut b,
            dalpha_deg: &mut c,
            dl_mm: &mut d,
        }),
        ok: &mut ok,
        status: &mut [],
        length_mm: &mut [],
        reachable: &mut [],
        effector_x_mm: &mut [],
        effector_y_mm: &mut [],
    };
    let e = sweep(&arm, &eff, &alpha, &[1.0], opts(true), out, &never).unwrap_err();
    assert!(matches!(e, ArmError::Shape { what: "dx_mm", .. }), "{e}");
}

/// `reachable` is "not singular and every length within its stroke"; lengths and the
/// load point are those of the forward kinematics.
#[test]
fn reachable_agrees_with_stroke_limits() {
    let mut rng = Rng(42);
    let (lo, hi) = (300.0, 540.0);
    for effects in [vec![], other_effects()[0].1.clone()] {
        let arm = arm(3, &mut rng, Some((lo, hi)));
        let eff = EffectSet::new(&arm, effects).unwrap();
        let mut alpha = poses(3, 300, &mut rng);
        alpha[3 * 17] = singular_pose(&arm);
        let out = run(&arm, &eff, &alpha, &[1.0], opts(true), &never).unwrap();
        let mut fr = Frames::new(3);
        let (mut inside, mut outside) = (0, 0);
        for p in 0..300 {
            let rad: Vec<f64> = alpha[3 * p..3 * p + 3]
                .iter()
                .map(|d| d.to_radians())
                .collect();
            fr.fill(&arm, &rad);
            let mut within = true;
            for i in 0..3 {
                let l = fr.length(i);
                assert!((out.length[3 * p + i] - l).abs() < 1e-12 * l);
                within &= (lo..=hi).contains(&l);
            }
            assert!((out.ex[p] - fr.joint[3].x).abs() < 1e-12 * 1e3);
            assert!((out.ey[p] - fr.joint[3].y).abs() < 1e-12 * 1e3);
            let want = within && p != 17;
            assert_eq!(out.reachable[p], want, "pose {p}");
            if want {
                inside += 1;
            } else {
                outside += 1;
            }
        }
        assert!(
            inside > 10 && outside > 10,
            "{inside} inside, {outside} outside"
        );
    }
}

/// The angles of a C-order grid (`axes` outermost first, dimension d setting link
/// `links[d]`), built the obvious way: by division of the flat index.
fn grid_rows(axes: &[Vec<f64>], links: &[usize], start: usize, count: usize) -> Vec<f64> {
    let n = axes.len();
    let mut a = vec![0.0; count * n];
    for p in 0..count {
        let mut f = start + p;
        for d in (0..n).rev() {
            a[p * n + links[d]] = axes[d][f % axes[d].len()];
            f /= axes[d].len();
        }
    }
    a
}

/// A grid source gives exactly (bit for bit) the sweep of its poses given as rows, for any
/// order of the dimensions, any sub-range of the grid, chunk size, thread count and
/// instruction set, on both kernels.
#[test]
fn grid_poses_equal_rows() {
    let mut rng = Rng(77);
    let mut sets = vec![("baseline", vec![])];
    sets.extend(other_effects().into_iter().take(1));
    for (name, effects) in sets {
        let arm = arm(3, &mut rng, Some((300.0, 540.0)));
        let eff = EffectSet::new(&arm, effects).unwrap();
        let axes = vec![
            vec![0.0, 12.5, 25.0, 30.0, 5.0],
            vec![60.0, 75.0, 90.0, 101.0, 110.0, 64.0, 99.0],
            vec![-10.0, 0.0, 3.5, 10.0, -7.0, 8.0],
        ];
        let links = [1usize, 0, 2];
        let views: Vec<&[f64]> = axes.iter().map(|a| a.as_slice()).collect();
        let size = 5 * 7 * 6;
        for (start, count) in [(0, size), (37, 101), (size - 17, 17)] {
            let rows = grid_rows(&axes, &links, start, count);
            let variants = [
                (None, None, false),
                (Some(32), Some(2), false),
                (Some(16), Some(1), true),
            ];
            for (chunk_rows, threads, baseline_simd) in variants {
                let o = SweepOptions {
                    chunk_rows,
                    threads,
                    baseline_simd,
                    ..opts(true)
                };
                let mass = [0.0, 3.0, 7.0];
                // The rows with the best instruction set; the grid (its sines and cosines
                // looked up in tables) also with baseline x86-64.
                let want = run(&arm, &eff, &rows, &mass, opts(true), &never).unwrap();
                let src = Poses::Grid(Grid {
                    axes: &views,
                    links: &links,
                    start,
                    count,
                });
                let got = run_poses(&arm, &eff, src, count, &mass, o, &never, count).unwrap();
                assert_eq!(
                    got.bits(),
                    want.bits(),
                    "{name} {start}+{count} {chunk_rows:?}"
                );
                assert_eq!(got.ok, want.ok);
                assert_eq!(got.reachable, want.reachable);
            }
        }
    }
}

/// `mask_unreachable` makes every cell of an unreachable pose NaN and not ok, leaves the
/// cells of reachable poses alone, and is honoured by the reductions (both kernels).
#[test]
fn mask_unreachable_masks_exactly_the_unreachable_poses() {
    let mut rng = Rng(5);
    let mut sets = vec![("baseline", vec![])];
    sets.extend(other_effects().into_iter().take(2));
    for (name, effects) in sets {
        let arm = arm(3, &mut rng, Some((300.0, 540.0)));
        let eff = EffectSet::new(&arm, effects).unwrap();
        let alpha = poses(3, 400, &mut rng);
        let mass = [1.0, 6.0];
        let plain = run(&arm, &eff, &alpha, &mass, opts(true), &never).unwrap();
        let masked_opts = SweepOptions {
            mask_unreachable: true,
            ..opts(true)
        };
        let masked = run(&arm, &eff, &alpha, &mass, masked_opts, &never).unwrap();
        let unreachable = plain.reachable.iter().filter(|r| !**r).count();
        assert!(
            unreachable > 20 && unreachable < 380,
            "{name}: {unreachable} of 400 unreachable; the test needs both kinds"
        );
        assert_eq!(masked.reachable, plain.reachable);
        for p in 0..400 {
            for j in 0..2 {
                let r = p * 2 + j;
                if plain.reachable[p] {
                    assert_eq!(masked.ok[r], plain.ok[r], "{name} pose {p}");
                    assert_eq!(masked.dy[r].to_bits(), plain.dy[r].to_bits());
                    assert_eq!(
                        masked.force[3 * r..3 * r + 3],
                        plain.force[3 * r..3 * r + 3]
                    );
                } else {
                    assert!(!masked.ok[r], "{name} pose {p}");
                    assert!(masked.dy[r].is_nan() && masked.force[3 * r].is_nan());
                }
            }
        }
        // A reduction over the masses skips the masked cells: equal to the naive reduction
        // of the masked full output.
        let red = SweepOptions {
            reduce: Some(Reduce {
                op: ReduceOp::Min,
                group: 2,
            }),
            ..masked_opts
        };
        let got = run(&arm, &eff, &alpha, &mass, red, &never).unwrap();
        for p in 0..400 {
            let want = masked.dy[2 * p].min(masked.dy[2 * p + 1]); // NaN only if both are
            assert_eq!(got.dy[p].to_bits(), want.to_bits(), "{name} pose {p}");
            assert_eq!(got.ok[p], masked.ok[2 * p] || masked.ok[2 * p + 1]);
        }
    }
}

/// With a reduction over whole poses and a `reachable` buffer of one value per group,
/// `reachable` is "some pose of the group is reachable", whatever the chunking.
#[test]
fn reachable_reduced_over_pose_groups() {
    let mut rng = Rng(11);
    let arm = arm(3, &mut rng, Some((300.0, 540.0)));
    // Groups of 7 poses (never aligned with chunks of 16) and of 50 (longer than a chunk).
    for (poses_n, block) in [(7 * 45, 7), (50 * 7, 50)] {
        reachable_groups(&arm, &mut rng, poses_n, block);
    }
}

fn reachable_groups(arm: &Arm, rng: &mut Rng, poses_n: usize, block: usize) {
    let eff = EffectSet::empty();
    let random = poses(3, poses_n, rng);
    let mass = [2.0, 5.0];
    let first = run(arm, &eff, &random, &mass, opts(true), &never).unwrap();
    // Unreachable poses first, so that there are groups of each kind and mixed ones.
    let mut order: Vec<usize> = (0..poses_n).collect();
    order.sort_by_key(|&p| (first.reachable[p], p % 3));
    let alpha: Vec<f64> = order
        .iter()
        .flat_map(|&p| random[3 * p..3 * p + 3].to_vec())
        .collect();
    let per_pose = run(arm, &eff, &alpha, &mass, opts(true), &never).unwrap();
    let some = per_pose.reachable.iter().filter(|r| **r).count();
    assert!(some > 20 && some < poses_n - 20, "{some} reachable");
    let want: Vec<bool> = per_pose
        .reachable
        .chunks(block)
        .map(|g| g.iter().any(|r| *r))
        .collect();
    assert!(want.iter().any(|r| !r) && want.iter().any(|r| *r));
    for (chunk_rows, threads) in [(None, None), (Some(32), Some(2)), (Some(16), Some(1))] {
        let o = SweepOptions {
            reduce: Some(Reduce {
                op: ReduceOp::Max,
                group: block * 2,
            }),
            chunk_rows,
            threads,
            ..opts(true)
        };
        let src = Poses::Rows(&alpha);
        let got = run_poses(arm, &eff, src, poses_n, &mass, o, &never, poses_n / block).unwrap();
        assert_eq!(got.reachable, want, "{block} {chunk_rows:?} {threads:?}");
        // Per-pose reachability is still available with a per-pose buffer.
        let got = run_poses(arm, &eff, src, poses_n, &mass, o, &never, poses_n).unwrap();
        assert_eq!(got.reachable, per_pose.reachable);
    }
}

/// The count passed to `cancel` is the poses finished so far: never decreasing, never more
/// than the sweep has, and, with one thread, exactly the chunks before the call (0 first).
#[test]
fn cancel_sees_the_progress() {
    use std::sync::Mutex;
    let mut rng = Rng(3);
    let arm = arm(3, &mut rng, None);
    let alpha = poses(3, 1000, &mut rng);
    for threads in [Some(1), Some(2)] {
        let seen = Mutex::new(Vec::new());
        let cancel = |k: usize| {
            seen.lock().unwrap().push(k);
            false
        };
        let o = SweepOptions {
            threads,
            chunk_rows: Some(64),
            ..opts(true)
        };
        run(&arm, &EffectSet::empty(), &alpha, &[1.0], o, &cancel).unwrap();
        let seen = seen.into_inner().unwrap();
        assert!(!seen.is_empty());
        assert!(seen.windows(2).all(|w| w[0] <= w[1]), "{seen:?}");
        assert!(seen.iter().all(|&k| k < 1000), "{seen:?}");
        if threads == Some(1) {
            let want: Vec<usize> = (0..seen.len()).map(|c| c * 64).collect();
            assert_eq!(seen, want);
        }
    }
}

/// A grid that does not fit the arm is refused with a message naming the fault.
#[test]
fn bad_grids_are_errors() {
    let mut rng = Rng(9);
    let arm = arm(3, &mut rng, None);
    let eff = EffectSet::empty();
    let (a, b, c) = (vec![60.0, 70.0], vec![0.0, 10.0], vec![0.0]);
    let nan = vec![0.0, f64::NAN];
    let empty: Vec<f64> = vec![];
    type Case<'a> = (Vec<&'a [f64]>, Vec<usize>, usize, usize, &'a str);
    let cases: Vec<Case> = vec![
        (vec![&a, &b], vec![0, 1], 0, 4, "2 axes"),
        (vec![&a, &b, &c], vec![0, 1, 1], 0, 4, "links[2] = 1"),
        (vec![&a, &b, &c], vec![0, 1, 3], 0, 4, "links[2] = 3"),
        (vec![&a, &empty, &c], vec![0, 1, 2], 0, 0, "axis 1 is empty"),
        (
            vec![&a, &nan, &c],
            vec![0, 1, 2],
            0,
            4,
            "axis 1 value 1 is not finite",
        ),
        (
            vec![&a, &b, &c],
            vec![0, 1, 2],
            2,
            3,
            "outside the grid's 4 poses",
        ),
    ];
    for (axes, links, start, count, want) in cases {
        let src = Poses::Grid(Grid {
            axes: &axes,
            links: &links,
            start,
            count,
        });
        let e = run_poses(&arm, &eff, src, count, &[1.0], opts(true), &never, count).unwrap_err();
        assert!(
            matches!(&e, ArmError::InvalidOption(m) if m.contains(want)),
            "{want}: {e}"
        );
    }
}

/// With no payload masses there are no cells: a sweep (reduced or not) still writes every
/// per-pose output, the same as with masses.
#[test]
fn no_masses_still_gives_the_poses() {
    let mut rng = Rng(21);
    let arm = arm(3, &mut rng, Some((300.0, 540.0)));
    let eff = EffectSet::empty();
    let alpha = poses(3, 100, &mut rng);
    let want = run(&arm, &eff, &alpha, &[1.0], opts(true), &never).unwrap();
    for reduce in [
        None,
        Some(Reduce {
            op: ReduceOp::Max,
            group: 4,
        }),
    ] {
        let o = SweepOptions {
            reduce,
            chunk_rows: Some(32),
            ..opts(true)
        };
        let got = run(&arm, &eff, &alpha, &[], o, &never).unwrap();
        assert!(got.force.is_empty() && got.ok.is_empty(), "{reduce:?}");
        assert_eq!(got.length, want.length, "{reduce:?}");
        assert_eq!(got.reachable, want.reachable, "{reduce:?}");
        assert_eq!((&got.ex, &got.ey), (&want.ex, &want.ey), "{reduce:?}");
    }
}
