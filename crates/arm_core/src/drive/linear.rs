//! A linear actuator (docs/model.md §1): a two-force member between pin B_{i−1} on body i−1
//! and pin A_i on link i. Its load is the axial force F_i (N, compression +); its own spring
//! changes the pin-to-pin length by `−ΔF_i/k_i` (mm).

use crate::error::{ArmError, Result};

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

impl Actuator {
    /// Checks the values of actuator `k` (1-based), naming the arm-file key.
    ///
    /// # Errors
    /// [`ArmError::InvalidArm`].
    pub(crate) fn check(&self, k: usize) -> Result<()> {
        let bad = |name: &str, reason: &str| ArmError::InvalidArm {
            key: format!("actuator[{k}].{name}"),
            reason: reason.to_owned(),
        };
        if !(self.stiffness.is_finite() && self.stiffness > 0.0) {
            return Err(bad("stiffness_n_per_mm", "must be finite and > 0"));
        }
        if !(self.mass_kg.is_finite() && self.mass_kg >= 0.0) {
            return Err(bad("mass_kg", "must be finite and >= 0"));
        }
        for (name, v) in [
            ("min_length_mm", self.min_length),
            ("max_length_mm", self.max_length),
            ("max_force_n", self.max_force),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0) {
                    return Err(bad(name, "must be finite and > 0"));
                }
            }
        }
        if let (Some(lo), Some(hi)) = (self.min_length, self.max_length) {
            if lo > hi {
                return Err(bad("min_length_mm", "exceeds max_length_mm"));
            }
        }
        Ok(())
    }

    /// An unloaded pin-to-pin length (mm) outside `[min_length, max_length]`.
    pub fn out_of_stroke(&self, length: f64) -> bool {
        self.min_length.is_some_and(|lo| length < lo)
            || self.max_length.is_some_and(|hi| length > hi)
    }

    /// A loaded |force| (N) above `max_force`.
    pub fn over_force(&self, force: f64) -> bool {
        self.max_force.is_some_and(|m| force.abs() > m)
    }
}
