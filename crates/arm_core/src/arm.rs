//! The arm description: base, links and actuators, validated once at construction.

use crate::error::{ArmError, Result};
use crate::geometry::V2;

/// One rigid link; every point is in the link's local frame (mm), origin at its joint O_i.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// Next joint O_{i+1} (for the last link: the load point).
    pub next: V2,
    /// Pin A_i of the link's own actuator.
    pub a: V2,
    /// Base pin B_i of the next actuator (ignored on the last link).
    pub b: V2,
    /// Centre of mass.
    pub c: V2,
    /// Link mass (kg).
    pub mass_kg: f64,
}

/// One linear actuator, a two-force member between B_{i−1} and A_i.
#[derive(Debug, Clone, PartialEq)]
pub struct Actuator {
    /// Axial stiffness of the actuator body (N/mm).
    pub stiffness: f64,
    /// Actuator mass (kg), split equally between its two pins.
    pub mass_kg: f64,
    /// Shortest allowed pin-to-pin length (mm).
    pub min_length: Option<f64>,
    /// Longest allowed pin-to-pin length (mm).
    pub max_length: Option<f64>,
    /// Largest allowed axial force magnitude (N).
    pub max_force: Option<f64>,
}

/// A planar arm of `n ≥ 1` links driven by `n` actuators.
#[derive(Debug, Clone, PartialEq)]
pub struct Arm {
    /// Gravity (m/s²); a mass in kg times `g` is a force in N.
    pub g: f64,
    /// Global position of joint O_1 (mm).
    pub o1: V2,
    /// Global position of actuator 1's chassis pin B_0 (mm).
    pub b0: V2,
    /// Global tilt point of the chassis for base compliance (mm).
    pub pivot: V2,
    /// Links in chain order.
    pub links: Vec<Link>,
    /// Actuators; actuator i drives link i.
    pub actuators: Vec<Actuator>,
    /// Measurement point in the last link's frame (mm).
    pub measure: V2,
}

impl Arm {
    /// Builds and validates an arm.
    ///
    /// # Errors
    /// [`ArmError::InvalidArm`] naming the arm-file key when a count differs, a value is not
    /// finite, a mass or stiffness is out of range, or pins coincide.
    pub fn new(
        g: f64,
        o1: V2,
        b0: V2,
        pivot: V2,
        links: Vec<Link>,
        actuators: Vec<Actuator>,
        measure: V2,
    ) -> Result<Self> {
        let bad = |key: String, reason: &str| ArmError::InvalidArm {
            key,
            reason: reason.to_owned(),
        };
        let n = links.len();
        if n == 0 {
            return Err(bad("link".into(), "need at least one link"));
        }
        if actuators.len() != n {
            return Err(bad(
                "actuator".into(),
                &format!("{} actuators for {} links", actuators.len(), n),
            ));
        }
        if !(g.is_finite() && g > 0.0) {
            return Err(bad("g".into(), "must be finite and > 0"));
        }
        for (key, p) in [("base.O1", o1), ("base.B0", b0), ("base.pivot", pivot)] {
            if !finite2(p) {
                return Err(bad(key.into(), "must be finite"));
            }
        }
        if (b0 - o1).norm() <= 1e-9 * (1.0 + o1.norm() + b0.norm()) {
            return Err(bad("base.B0".into(), "coincides with base.O1"));
        }
        if !finite2(measure) {
            return Err(bad(format!("link[{n}].measure"), "must be finite"));
        }
        for (i, l) in links.iter().enumerate() {
            let k = i + 1;
            for (name, p) in [("next", l.next), ("A", l.a), ("B", l.b), ("C", l.c)] {
                if !finite2(p) {
                    return Err(bad(format!("link[{k}].{name}"), "must be finite"));
                }
            }
            if !(l.mass_kg.is_finite() && l.mass_kg >= 0.0) {
                return Err(bad(format!("link[{k}].mass_kg"), "must be finite and >= 0"));
            }
            if l.next.norm() <= 1e-9 {
                return Err(bad(
                    format!("link[{k}].next"),
                    "coincides with the link's joint",
                ));
            }
            if l.a.norm() <= 1e-9 {
                return Err(bad(
                    format!("link[{k}].A"),
                    "coincides with the link's joint",
                ));
            }
            if i + 1 < n && (l.b - l.next).norm() <= 1e-9 * (1.0 + l.next.norm()) {
                return Err(bad(format!("link[{k}].B"), "coincides with the next joint"));
            }
        }
        for (i, a) in actuators.iter().enumerate() {
            let k = i + 1;
            if !(a.stiffness.is_finite() && a.stiffness > 0.0) {
                return Err(bad(
                    format!("actuator[{k}].stiffness_n_per_mm"),
                    "must be finite and > 0",
                ));
            }
            if !(a.mass_kg.is_finite() && a.mass_kg >= 0.0) {
                return Err(bad(
                    format!("actuator[{k}].mass_kg"),
                    "must be finite and >= 0",
                ));
            }
            for (name, v) in [
                ("min_length_mm", a.min_length),
                ("max_length_mm", a.max_length),
                ("max_force_n", a.max_force),
            ] {
                if let Some(v) = v {
                    if !(v.is_finite() && v > 0.0) {
                        return Err(bad(
                            format!("actuator[{k}].{name}"),
                            "must be finite and > 0",
                        ));
                    }
                }
            }
            if let (Some(lo), Some(hi)) = (a.min_length, a.max_length) {
                if lo > hi {
                    return Err(bad(
                        format!("actuator[{k}].min_length_mm"),
                        "exceeds max_length_mm",
                    ));
                }
            }
        }
        Ok(Self {
            g,
            o1,
            b0,
            pivot,
            links,
            actuators,
            measure,
        })
    }

    /// Number of links (and actuators).
    #[inline]
    pub fn n(&self) -> usize {
        self.links.len()
    }
}

#[inline]
fn finite2(p: V2) -> bool {
    p.x.is_finite() && p.y.is_finite()
}
