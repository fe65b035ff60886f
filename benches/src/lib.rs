//! Shared set-up of the criterion benchmarks of arm_core (`benches/`): the example arm of
//! `examples/example_arm.toml` and reproducible poses.

use arm_core::{Actuator, Arm, Link, V2};

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

/// The example arm, with the numbers of `examples/example_arm.toml`.
pub fn example_arm() -> Arm {
    let link = |next: V2, a: V2, b: V2, c: V2, mass_kg: f64| Link {
        next,
        a,
        b,
        c,
        mass_kg,
    };
    let act = |stiffness: f64, mass_kg: f64, lo: f64, hi: f64, fmax: f64| Actuator {
        stiffness,
        mass_kg,
        min_length: Some(lo),
        max_length: Some(hi),
        max_force: Some(fmax),
    };
    ok(
        Arm::new(
            9.81,
            v(0.0, 0.0),
            v(250.0, -40.0),
            v(-200.0, -280.0),
            vec![
                link(
                    v(480.0, 0.0),
                    v(95.0, 55.0),
                    v(-40.0, -50.0),
                    v(220.0, -3.0),
                    3.0,
                ),
                link(
                    v(380.0, 0.0),
                    v(85.0, -55.0),
                    v(-110.0, 10.0),
                    v(170.0, -2.0),
                    2.2,
                ),
                // The last link has no B pin (no actuator follows); the core ignores it.
                link(
                    v(360.0, 0.0),
                    v(50.0, -40.0),
                    v(0.0, 0.0),
                    v(160.0, -2.0),
                    1.3,
                ),
            ],
            vec![
                act(3000.0, 1.5, 150.0, 420.0, 4000.0),
                act(2500.0, 1.2, 150.0, 380.0, 3000.0),
                act(2000.0, 0.9, 120.0, 330.0, 2500.0),
            ],
            v(280.0, -40.0),
        ),
        "example arm",
    )
}

/// `rows` reproducible poses (degrees, `rows × 3`): α uniform in [60, 110] × [0, 30] ×
/// [−10, 10], from a fixed-seed xorshift generator.
pub fn angles(rows: usize) -> Vec<f64> {
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut uniform = move |lo: f64, hi: f64| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        lo + (hi - lo) * ((state >> 11) as f64 / (1u64 << 53) as f64)
    };
    let mut alpha = Vec::with_capacity(3 * rows);
    for _ in 0..rows {
        alpha.push(uniform(60.0, 110.0));
        alpha.push(uniform(0.0, 30.0));
        alpha.push(uniform(-10.0, 10.0));
    }
    alpha
}
