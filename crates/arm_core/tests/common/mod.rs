//! Helpers shared by the integration tests (each test file includes this module with
//! `mod common;`): arm constructors, a seeded generator of random arm details and poses,
//! solve options, and both models' channels for the FE-against-analytic comparisons.

// Each test file is its own binary and uses only some of these helpers.
#![allow(dead_code)]

use arm_core::fem::{FemModel, FemWorkspace};
use arm_core::{Actuator, Arm, BatchBuffers, EffectSet, Link, SolveOptions, Workspace, V2};

/// The outputs of a batch by name, in `BatchBuffers`' order: the one list the tests walk
/// when they look at every output ([`outputs`], [`outputs_mut`]).
pub const OUTPUTS: [&str; 11] = [
    "force_n",
    "reaction_n",
    "dforce_n",
    "torque_nmm",
    "dtorque_nmm",
    "dx_mm",
    "dy_mm",
    "dalpha_deg",
    "dl_mm",
    "dlength_mm",
    "length_mm",
];

/// Every output of `b`, in [`OUTPUTS`]' order.
pub fn outputs(b: &BatchBuffers) -> [&[f64]; 11] {
    [
        &b.force_n,
        &b.reaction_n,
        &b.dforce_n,
        &b.torque_nmm,
        &b.dtorque_nmm,
        &b.dx_mm,
        &b.dy_mm,
        &b.dalpha_deg,
        &b.dl_mm,
        &b.dlength_mm,
        &b.length_mm,
    ]
}

/// Every output of `b`, to write, in [`OUTPUTS`]' order.
pub fn outputs_mut(b: &mut BatchBuffers) -> [&mut Vec<f64>; 11] {
    [
        &mut b.force_n,
        &mut b.reaction_n,
        &mut b.dforce_n,
        &mut b.torque_nmm,
        &mut b.dtorque_nmm,
        &mut b.dx_mm,
        &mut b.dy_mm,
        &mut b.dalpha_deg,
        &mut b.dl_mm,
        &mut b.dlength_mm,
        &mut b.length_mm,
    ]
}

pub fn v(x: f64, y: f64) -> V2 {
    V2::new(x, y)
}

/// A linear actuator of `stiffness` (N/mm) and `mass_kg`, without limits.
pub fn act(stiffness: f64, mass_kg: f64) -> Actuator {
    Actuator {
        stiffness,
        mass_kg,
        min_length: None,
        max_length: None,
        max_force: None,
    }
}

pub fn link(next: V2, a: V2, b: V2, c: V2, mass_kg: f64) -> Link {
    Link {
        next,
        a,
        b,
        c,
        mass_kg,
    }
}

/// A small deterministic generator (xorshift64) for random arms' details, seeded by proptest
/// or by the test.
pub struct Rng(pub u64);

impl Rng {
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }
    pub fn jitter(&mut self, p: V2, d: f64) -> V2 {
        p + V2::new(self.uniform(-d, d), self.uniform(-d, d))
    }
    pub fn pick(&mut self, n: usize) -> usize {
        (self.uniform(0.0, n as f64) as usize).min(n - 1)
    }
    pub fn coin(&mut self) -> bool {
        self.uniform(0.0, 1.0) < 0.5
    }
}

/// `rows` poses (deg) in the seed's ranges, and payloads: masses 0–10 kg straight down (some
/// exactly zero), or any force up to 100 N when `any_direction`.
pub fn poses(n: usize, rows: usize, rng: &mut Rng, any_direction: bool) -> (Vec<f64>, Vec<f64>) {
    let ranges = [(60.0, 110.0), (0.0, 30.0), (-10.0, 10.0), (-15.0, 15.0)];
    let mut alpha = Vec::with_capacity(n * rows);
    let mut payload = Vec::with_capacity(2 * rows);
    for r in 0..rows {
        for i in 0..n {
            let (lo, hi) = ranges[i.min(3)];
            alpha.push(rng.uniform(lo, hi));
        }
        push_payload(&mut payload, r, rng, any_direction);
    }
    (alpha, payload)
}

/// Row `r`'s payload (N, x then y) pushed onto `payload`: a mass of 0–10 kg straight down
/// (exactly zero on every seventh row), or any force up to 100 N when `any_direction`.
pub fn push_payload(payload: &mut Vec<f64>, r: usize, rng: &mut Rng, any_direction: bool) {
    if any_direction {
        payload.push(rng.uniform(-100.0, 100.0));
        payload.push(rng.uniform(-100.0, 100.0));
    } else {
        let m = if r.is_multiple_of(7) {
            0.0
        } else {
            rng.uniform(0.0, 10.0)
        };
        payload.push(0.0);
        payload.push(-9.81 * m);
    }
}

/// With NaN for a pose that cannot close under its load.
pub fn opts(self_weight: bool) -> SolveOptions {
    SolveOptions {
        self_weight,
        nan_on_failure: true,
    }
}

pub fn rad(deg: &[f64]) -> Vec<f64> {
    deg.iter().map(|d| d.to_radians()).collect()
}

/// Numbers as `1.23e-4`, space-separated (for the printed tables of relative differences).
pub fn sci(x: &[f64]) -> String {
    x.iter()
        .map(|v| format!("{v:.2e}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The load scales of the second-order comparisons of the FE and analytic models.
pub const SCALES: [f64; 4] = [1.0, 1e-1, 1e-2, 1e-3];

/// What the FE and the analytic model report for one pose; NaN where a channel does not
/// exist (a rotary joint's lengths). `load` is each drive's force (N) or torque (N·mm).
#[derive(Debug, Clone)]
pub struct Channels {
    pub dxy: V2,
    pub dalpha: Vec<f64>,
    pub dl: Vec<f64>,
    pub dlength: Vec<f64>,
    pub load: Vec<f64>,
    pub reaction: Vec<V2>,
}

/// The analytic model's channels (`Workspace::solve`).
pub fn analytic(arm: &Arm, effects: &EffectSet, alpha: &[f64], p: V2, sw: bool) -> Channels {
    let mut ws = Workspace::new(arm);
    let opts = SolveOptions {
        self_weight: sw,
        nan_on_failure: false,
    };
    ws.solve(arm, effects, alpha, p, opts, 0).unwrap();
    Channels {
        dxy: ws.dmeasure,
        dalpha: (0..arm.n()).map(|i| ws.new_alpha[i] - alpha[i]).collect(),
        dl: ws.body_dl.clone(),
        dlength: (0..arm.n())
            .map(|i| ws.new_length[i] - ws.lines.length[i])
            .collect(),
        load: ws.loaded.f.clone(),
        reaction: ws.loaded.r.clone(),
    }
}

/// The FE model's channels (`FemWorkspace::solve`).
pub fn fem(model: &FemModel, alpha: &[f64], p: V2, sw: bool) -> Channels {
    let mut ws = FemWorkspace::new(model);
    ws.solve(model, alpha, p, sw, 0).unwrap();
    Channels {
        dxy: ws.dmeasure,
        dalpha: ws.dalpha.clone(),
        dl: ws.body_dl.clone(),
        dlength: ws.dlength.clone(),
        load: ws.force.clone(),
        reaction: ws.reaction.clone(),
    }
}
