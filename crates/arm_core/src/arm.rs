//! The arm description: base, links and the drive of each joint (a linear actuator or a
//! rotary drive, [`crate::drive`]), validated once at construction.

pub use crate::drive::{Actuator, Drive, RotaryDrive};
use crate::error::{ArmError, Result};
use crate::geometry::V2;

/// One rigid link; every point is in the link's local frame (mm), origin at its joint O_i.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// Next joint O_{i+1} (for the last link: the load point).
    pub next: V2,
    /// Pin A_i of the link's own actuator (ignored when a rotary drive turns the link).
    pub a: V2,
    /// Base pin B_i of the next actuator (ignored on the last link, and when a rotary drive
    /// turns the next link).
    pub b: V2,
    /// Centre of mass.
    pub c: V2,
    /// Link mass (kg).
    pub mass_kg: f64,
}

/// A planar arm of `n ≥ 1` links, each turned by its drive (any mix of linear actuators and
/// rotary drives).
#[derive(Debug, Clone, PartialEq)]
pub struct Arm {
    /// Gravity (m/s²); a mass in kg times `g` is a force in N.
    pub g: f64,
    /// Global position of joint O_1 (mm).
    pub o1: V2,
    /// Global position of actuator 1's chassis pin B_0 (mm); ignored when a rotary drive
    /// turns link 1.
    pub b0: V2,
    /// Global tilt point of the chassis for base compliance (mm).
    pub pivot: V2,
    /// Links in chain order.
    pub links: Vec<Link>,
    /// The drives; drive i turns link i.
    pub drives: Vec<Drive>,
    /// Measurement point in the last link's frame (mm).
    pub measure: V2,
}

impl Arm {
    /// Builds and validates an arm whose every joint is turned by a linear actuator.
    ///
    /// # Errors
    /// As [`Self::with_drives`].
    pub fn new(
        g: f64,
        o1: V2,
        b0: V2,
        pivot: V2,
        links: Vec<Link>,
        actuators: Vec<Actuator>,
        measure: V2,
    ) -> Result<Self> {
        let drives = actuators.into_iter().map(Drive::Linear).collect();
        Self::with_drives(g, o1, b0, pivot, links, drives, measure)
    }

    /// Builds and validates an arm with any mix of drives. A pin is checked only where a
    /// linear actuator uses it: `A` of a link whose own joint is linear, `B` of a link whose
    /// next joint is linear, `b0` when joint 1 is linear (the others are ignored).
    ///
    /// # Errors
    /// [`ArmError::InvalidArm`] naming the arm-file key when a count differs, a value is not
    /// finite, a mass, stiffness or limit is out of range, or pins coincide.
    pub fn with_drives(
        g: f64,
        o1: V2,
        b0: V2,
        pivot: V2,
        links: Vec<Link>,
        drives: Vec<Drive>,
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
        if drives.len() != n {
            return Err(bad(
                "actuator".into(),
                &format!("{} actuators for {} links", drives.len(), n),
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
        let linear = |i: usize| !drives[i].is_rotary();
        if linear(0) && (b0 - o1).norm() <= 1e-9 * (1.0 + o1.norm() + b0.norm()) {
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
            if linear(i) && l.a.norm() <= 1e-9 {
                return Err(bad(
                    format!("link[{k}].A"),
                    "coincides with the link's joint",
                ));
            }
            if i + 1 < n && linear(i + 1) && (l.b - l.next).norm() <= 1e-9 * (1.0 + l.next.norm()) {
                return Err(bad(format!("link[{k}].B"), "coincides with the next joint"));
            }
        }
        for (i, d) in drives.iter().enumerate() {
            match d {
                Drive::Linear(a) => a.check(i + 1)?,
                Drive::Rotary(r) => r.check(i + 1)?,
            }
        }
        Ok(Self {
            g,
            o1,
            b0,
            pivot,
            links,
            drives,
            measure,
        })
    }

    /// Number of links (and drives).
    #[inline]
    pub fn n(&self) -> usize {
        self.links.len()
    }

    /// The number of poses in `alpha_deg`, `n` angles (degrees) per pose.
    ///
    /// # Errors
    /// [`ArmError::Shape`] when its length is not a multiple of `n`.
    pub(crate) fn pose_rows(&self, alpha_deg: &[f64]) -> Result<usize> {
        let n = self.n();
        if !alpha_deg.len().is_multiple_of(n) {
            return Err(ArmError::Shape {
                what: "alpha_deg",
                expected: (alpha_deg.len() / n + 1) * n,
                got: alpha_deg.len(),
            });
        }
        Ok(alpha_deg.len() / n)
    }

    /// Whether a rotary drive turns link `i` (0-based).
    #[inline]
    pub fn is_rotary(&self, i: usize) -> bool {
        self.drives[i].is_rotary()
    }

    /// Whether any joint is turned by a rotary drive.
    pub fn any_rotary(&self) -> bool {
        self.drives.iter().any(Drive::is_rotary)
    }

    /// The linear actuator of joint `i` (0-based), if it has one.
    #[inline]
    pub fn actuator(&self, i: usize) -> Option<&Actuator> {
        self.drives[i].linear()
    }

    /// The linear actuator of joint `i` (0-based), mutably, if it has one (the arm is not
    /// validated again: keep its values valid).
    pub fn actuator_mut(&mut self, i: usize) -> Option<&mut Actuator> {
        self.drives[i].linear_mut()
    }
}

#[inline]
fn finite2(p: V2) -> bool {
    p.x.is_finite() && p.y.is_finite()
}
