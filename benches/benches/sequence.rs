//! Criterion benchmark of `arm_core::solve_sequence`: 1e5 sequences × 8 states (0 → 1.5 → 5 →
//! 6.5 → 5 → 1.5 → 0 → 3 kg) at poses scattered ±5° around (90, 10, 0)° on the example arm,
//! without effects and with one effect of every kind (both frictions included), the output
//! buffers allocated once and reused, so that this measures the solve and not the page
//! faults of fresh memory (`benches/bench_sequence.py` measures the Python call, allocation
//! included). Run with `cargo bench -p arm_benches --bench sequence`; see
//! `docs/benchmarks.md`.

use std::hint::black_box;
use std::time::Duration;

use arm_benches::{example_arm, ok, six_kinds, uniform};
use arm_core::effects::{ActuatorFriction, JointFriction};
use arm_core::{Arm, BatchBuffers, Effect, EffectSet, SequenceInput, SolveOptions};
use criterion::{criterion_group, criterion_main, Criterion, SamplingMode, Throughput};

/// Sequences per call and the payload masses (kg) of their states.
const SEQUENCES: usize = 100_000;
const MASSES: [f64; 8] = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0, 3.0];

/// The effects of `benches/bench_sequence.py`: one of every kind (link 1 bent, so that the
/// joint friction at O3 is not beside a bent link), both frictions included.
fn every_kind(arm: &Arm) -> EffectSet {
    let mut effects = six_kinds(0);
    effects.push(Effect::ActuatorFriction(ActuatorFriction {
        actuator: 0,
        friction: 40.0,
    }));
    effects.push(Effect::JointFriction(JointFriction {
        joint: 2,
        torque: 4000.0,
    }));
    ok(EffectSet::new(arm, effects), "effect set")
}

fn bench_sequences(c: &mut Criterion) {
    let arm = example_arm();
    let mut uniform = uniform();
    let alpha: Vec<f64> = (0..SEQUENCES)
        .flat_map(|_| [90.0, 10.0, 0.0])
        .map(|a| a + uniform(-5.0, 5.0))
        .collect();
    let payload: Vec<f64> = (0..SEQUENCES)
        .flat_map(|_| MASSES.iter().flat_map(|m| [0.0, -m * arm.g]))
        .collect();
    let input = SequenceInput {
        alpha_deg: &alpha,
        payload_n: &payload,
        states: MASSES.len(),
    };
    let rows = SEQUENCES * MASSES.len();
    let opts = SolveOptions::default();
    let mut group = c.benchmark_group("solve_sequence");
    group
        .sampling_mode(SamplingMode::Flat)
        .sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .throughput(Throughput::Elements(rows as u64));
    for (name, effects) in [
        ("baseline", EffectSet::empty()),
        ("every_kind", every_kind(&arm)),
    ] {
        // Output buffers allocated once and reused by every iteration.
        let mut buf = BatchBuffers::new(rows, arm.n());
        let mut status = vec![0u8; rows];
        // Every state must solve: a benchmark of error returns would measure nothing.
        ok(
            arm_core::solve_sequence(&arm, &effects, input, opts, buf.out(), &mut status),
            "sequence check",
        );
        assert!(buf.dy_mm.iter().all(|d| d.is_finite()));
        group.bench_function(name, |b| {
            b.iter(|| {
                let r = arm_core::solve_sequence(
                    &arm,
                    &effects,
                    black_box(input),
                    opts,
                    buf.out(),
                    &mut status,
                );
                black_box(r.is_ok())
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench_sequences);
criterion_main!(benches);
