//! Shared set-up of the criterion benchmarks of arm_core (`benches/`): the example arm of
//! `examples/example_arm.toml` (from `arm_core::examples`) and reproducible poses.

use arm_core::effects::{
    ActuatorCompliance, ActuatorPlay, BaseCompliance, JointClearance, LinkBending, MountCompliance,
    Unloaded,
};
use arm_core::{Effect, V2};

/// Unwraps a core result; a benchmark set up wrongly should stop loudly, naming the step.
pub fn ok<T>(r: arm_core::Result<T>, what: &str) -> T {
    match r {
        Ok(v) => v,
        Err(e) => panic!("{what}: {e}"),
    }
}

/// A point or vector (mm).
pub fn v(x: f64, y: f64) -> V2 {
    V2::new(x, y)
}

/// The example arm of `examples/example_arm.toml`, the core's shared fixture.
pub use arm_core::examples::example_arm;

/// A reproducible stream of uniform numbers: `uniform(lo, hi)` from a fixed-seed xorshift
/// generator (the same sequence in every benchmark and every run).
pub fn uniform() -> impl FnMut(f64, f64) -> f64 {
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    move |lo: f64, hi: f64| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        lo + (hi - lo) * ((state >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// `rows` reproducible poses (degrees, `rows × 3`): α uniform in [60, 110] × [0, 30] ×
/// [−10, 10], from [`uniform`].
pub fn angles(rows: usize) -> Vec<f64> {
    let mut uniform = uniform();
    let mut alpha = Vec::with_capacity(3 * rows);
    for _ in 0..rows {
        alpha.push(uniform(60.0, 110.0));
        alpha.push(uniform(0.0, 30.0));
        alpha.push(uniform(-10.0, 10.0));
    }
    alpha
}

/// One effect of each of the six kinds of the catalogue without memory, with plausible values
/// for the example arm: `actuator_compliance@M1` (1500 N/mm), `mount_compliance@M2`
/// (4000 N/mm), `actuator_play@M3` (0.05 mm, centred), `joint_clearance@O3` (0.15 mm,
/// centred), `link_bending` of link `bent` (0-based; EI 2e10 N·mm²), `base_compliance`
/// (5e8 N·mm/rad).
pub fn six_kinds(bent: usize) -> Vec<Effect> {
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
            play: 0.05,
            unloaded: Unloaded::Centred,
        }),
        Effect::JointClearance(JointClearance {
            joint: 2,
            clearance: 0.15,
            unloaded: Unloaded::Centred,
        }),
        Effect::LinkBending(LinkBending {
            link: bent,
            ei: 2.0e10,
        }),
        Effect::BaseCompliance(BaseCompliance { stiffness: 5.0e8 }),
    ]
}
