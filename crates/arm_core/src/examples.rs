//! The example arm of docs/formats.md §1 and the seed paper's arm: fixtures for tests, benchmarks
//! and examples.
//!
//! The numbers are those of `examples/example_arm.toml` in the repository (the Python package
//! ships the same file as `python/eodarm/data/example_arm.toml`) and of the bundled
//! `python/eodarm/data/seed2022/arm.toml`; a unit test below reads the files and checks every
//! number against [`example_arm`] and [`seed2022_arm`], so they cannot drift apart.
//! Variants (other stiffnesses, scaled or jittered geometry, other strokes) start from
//! [`example_arm`] and change what they need.

use crate::arm::{Actuator, Arm, Link};
use crate::geometry::V2;

/// The example arm exactly as `examples/example_arm.toml` has it: three links, each driven by
/// a linear actuator, `g` = 9.81, chassis pivot (−200, −280), measurement point (280, −40) on
/// the last link, strokes and force limits of every actuator.
///
/// The last link has no `B` pin in the file (no actuator follows it); it is (0, 0) here, as in
/// the Python loader, and the core ignores it.
pub fn example_arm() -> Arm {
    let v = V2::new;
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
    let arm = Arm::new(
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
            link(
                v(360.0, 0.0),
                v(50.0, -40.0),
                v(0.0, 0.0),
                v(160.0, -2.0),
                1.3,
            ),
        ],
        vec![
            act(3000.0, 1.5, 250.0, 370.0, 4000.0),
            act(2500.0, 1.2, 410.0, 630.0, 3000.0),
            act(2000.0, 0.9, 440.0, 580.0, 2500.0),
        ],
        v(280.0, -40.0),
    );
    match arm {
        Ok(arm) => arm,
        // Constant, valid data: the unit test below builds it, so this cannot be reached.
        Err(e) => unreachable!("the example arm is invalid: {e}"),
    }
}

/// The bundled seed2022 arm exactly as `python/eodarm/data/seed2022/arm.toml` has it (the
/// calibrated chassis pin B0 of docs/seed-reproduction.md, 500 N/mm actuators, no limits).
pub fn seed2022_arm() -> Arm {
    let v = V2::new;
    let link = |next: V2, a: V2, b: V2, c: V2, mass_kg: f64| Link {
        next,
        a,
        b,
        c,
        mass_kg,
    };
    let act = |mass_kg: f64| Actuator {
        stiffness: 500.0,
        mass_kg,
        min_length: None,
        max_length: None,
        max_force: None,
    };
    let arm = Arm::new(
        9.81,
        v(0.0, 0.0),
        v(-556.6337993024575, -58.49698686910747),
        v(0.0, 0.0),
        vec![
            link(
                v(500.14900232336504, 0.0),
                v(80.93036037551532, 64.99178574528509),
                v(-50.00915220756769, -43.998687792484375),
                v(230.12, -2.4),
                3.0,
            ),
            link(
                v(399.8308128001342, 0.0),
                v(90.46632505844921, -50.96859868474406),
                v(-128.0305504150669, 0.12205831156718507),
                v(165.5, -1.3),
                2.5,
            ),
            link(
                v(299.24257106810234, -0.8133246639100824),
                v(44.76993763979948, -31.363949163798143),
                v(0.0, 0.0),
                v(230.12, -2.4),
                2.88,
            ),
        ],
        vec![act(1.5), act(1.2), act(1.0)],
        v(300.0, -44.0),
    );
    match arm {
        Ok(arm) => arm,
        // Constant, valid data: the unit test below builds it, so this cannot be reached.
        Err(e) => unreachable!("the seed2022 arm is invalid: {e}"),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure should panic
mod tests {
    use super::{example_arm, seed2022_arm};
    use crate::Arm;

    /// `(key, numbers)` of a flat arm file: `[base]` keys as `base.KEY`, the k-th `[[link]]`
    /// and `[[actuator]]` as `link[k].KEY`, `actuator[k].KEY`; strings are skipped.
    fn numbers(text: &str) -> Vec<(String, Vec<f64>)> {
        let (mut section, mut links, mut acts) = (String::new(), 0, 0);
        let mut out = Vec::new();
        for line in text.lines() {
            let line = line.split('#').next().unwrap().trim();
            if line == "[[link]]" {
                links += 1;
                section = format!("link[{links}].");
            } else if line == "[[actuator]]" {
                acts += 1;
                section = format!("actuator[{acts}].");
            } else if line.starts_with('[') {
                section = format!("{}.", line.trim_matches(|c| c == '[' || c == ']'));
            } else if let Some((key, value)) = line.split_once('=') {
                let value = value.trim();
                if value.starts_with('"') {
                    continue;
                }
                let nums = value
                    .trim_matches(|c| c == '[' || c == ']')
                    .split(',')
                    .map(|x| x.trim().parse::<f64>().unwrap())
                    .collect();
                out.push((format!("{section}{}", key.trim()), nums));
            }
        }
        out.sort_by(|a, b| a.0.cmp(&b.0));
        out
    }

    /// The same keys from a fixture (no `B` on the last link, as in the file; limits only
    /// where set).
    fn fixture(arm: &Arm) -> Vec<(String, Vec<f64>)> {
        let p = |v: crate::V2| vec![v.x, v.y];
        let mut out = vec![
            ("g".to_owned(), vec![arm.g]),
            ("base.O1".to_owned(), p(arm.o1)),
            ("base.B0".to_owned(), p(arm.b0)),
            ("base.pivot".to_owned(), p(arm.pivot)),
        ];
        let n = arm.n();
        for (i, l) in arm.links.iter().enumerate() {
            let k = format!("link[{}].", i + 1);
            out.push((format!("{k}next"), p(l.next)));
            out.push((format!("{k}A"), p(l.a)));
            if i + 1 < n {
                out.push((format!("{k}B"), p(l.b)));
            } else {
                assert_eq!(l.b, crate::V2::zeros());
                out.push((format!("{k}measure"), p(arm.measure)));
            }
            out.push((format!("{k}C"), p(l.c)));
            out.push((format!("{k}mass_kg"), vec![l.mass_kg]));
        }
        for (i, d) in arm.drives.iter().enumerate() {
            let Some(a) = d.linear() else { continue };
            let k = format!("actuator[{}].", i + 1);
            out.push((format!("{k}stiffness_n_per_mm"), vec![a.stiffness]));
            out.push((format!("{k}mass_kg"), vec![a.mass_kg]));
            for (key, limit) in [
                ("min_length_mm", a.min_length),
                ("max_length_mm", a.max_length),
                ("max_force_n", a.max_force),
            ] {
                if let Some(x) = limit {
                    out.push((format!("{k}{key}"), vec![x]));
                }
            }
        }
        out.sort_by(|a, b| a.0.cmp(&b.0));
        out
    }

    #[test]
    fn fixtures_are_the_arm_files() {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
        for (file, arm) in [
            ("examples/example_arm.toml", example_arm()),
            ("python/eodarm/data/example_arm.toml", example_arm()),
            ("python/eodarm/data/seed2022/arm.toml", seed2022_arm()),
        ] {
            let text = std::fs::read_to_string(format!("{root}/{file}")).expect(file);
            assert_eq!(numbers(&text), fixture(&arm), "{file}");
        }
    }
}
