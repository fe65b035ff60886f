//! A rotary drive (docs/model.md §10): a motor and gearbox at joint O_i, its housing fixed to
//! body i−1 (the chassis for i = 1), its output turning link i. It holds the relative angle
//! `q_i = α_i − α_{i−1}` (α_0 = 0); its load is the torque T_i (N·mm) on link i about O_i,
//! counter-clockwise +, and −T_i on body i−1. Its gear's torsional spring yields
//! `Δq_i = −ΔT_i/k_i` (rad). Its mass acts at O_i on body i−1.

use std::f64::consts::PI;

use crate::error::{ArmError, Result};
use crate::geometry::wrap_pi;

/// How far (rad) a drive's angle may pass its limit and still be within its range: 10⁻⁹°
/// (`1e-9_f64.to_radians()`, written so that the numpy reference's `np.radians(1e-9)` is
/// the same number). A loaded angle computed on its limit lands within rounding of it, on
/// either side; the numpy reference (`eodarm.model.validity.out_of_angle`) checks with the
/// same numbers in the same order, so that both give such a pose the same status. Far below
/// any angle a drive or an encoder resolves.
pub const ANGLE_TOL_RAD: f64 = 1e-9 * (PI / 180.0);

/// One rotary drive at joint O_i.
#[derive(Debug, Clone, PartialEq)]
pub struct RotaryDrive {
    /// Torsional stiffness at the output, motor held (N·mm/rad).
    pub stiffness: f64,
    /// Motor and gearbox mass (kg), acting at O_i on body i−1.
    pub mass_kg: f64,
    /// Largest allowed torque magnitude (N·mm).
    pub max_torque: Option<f64>,
    /// Smallest allowed relative angle q_i (rad).
    pub min_angle: Option<f64>,
    /// Largest allowed relative angle q_i (rad).
    pub max_angle: Option<f64>,
}

impl RotaryDrive {
    /// Checks the values of drive `k` (1-based), naming the arm-file key.
    ///
    /// # Errors
    /// [`ArmError::InvalidArm`].
    pub(crate) fn check(&self, k: usize) -> Result<()> {
        let bad = |name: &str, reason: &str| ArmError::InvalidArm {
            key: format!("actuator[{k}].{name}"),
            reason: reason.to_owned(),
        };
        if !(self.stiffness.is_finite() && self.stiffness > 0.0) {
            return Err(bad("stiffness_nmm_per_rad", "must be finite and > 0"));
        }
        if !(self.mass_kg.is_finite() && self.mass_kg >= 0.0) {
            return Err(bad("mass_kg", "must be finite and >= 0"));
        }
        if let Some(t) = self.max_torque {
            if !(t.is_finite() && t > 0.0) {
                return Err(bad("max_torque_nmm", "must be finite and > 0"));
            }
        }
        for (name, v) in [
            ("min_angle_deg", self.min_angle),
            ("max_angle_deg", self.max_angle),
        ] {
            if v.is_some_and(|v| !v.is_finite()) {
                return Err(bad(name, "must be finite"));
            }
        }
        if let (Some(lo), Some(hi)) = (self.min_angle, self.max_angle) {
            if lo > hi {
                return Err(bad("min_angle_deg", "exceeds max_angle_deg"));
            }
        }
        Ok(())
    }

    /// The drive's angle (rad) for the relative angle `q` (rad) of a pose: of the angles
    /// equal to `q` modulo a turn, the one nearest the middle of the drive's range (`[lo,
    /// lo + 2π)` with only a lower limit, `(hi − 2π, hi]` with only an upper one, `[−π, π)`
    /// without limits). Where any of them lies within a range of at most a turn, this one does.
    pub fn angle_of(&self, q: f64) -> f64 {
        let mid = self.mid_angle();
        mid + wrap_pi(q - mid)
    }

    /// The middle of the angles [`Self::angle_of`] gives (rad): of the range, or a half turn
    /// above a lone lower limit, below a lone upper one, zero without limits.
    pub fn mid_angle(&self) -> f64 {
        match (self.min_angle, self.max_angle) {
            (Some(lo), Some(hi)) => 0.5 * (lo + hi),
            (Some(lo), None) => lo + PI,
            (None, Some(hi)) => hi - PI,
            (None, None) => 0.0,
        }
    }

    /// A drive angle (rad, from [`Self::angle_of`], plus any deflection) outside
    /// `[min_angle, max_angle]` by more than [`ANGLE_TOL_RAD`] (an angle on its limit, as
    /// rounding leaves it, is inside).
    pub fn out_of_range(&self, angle: f64) -> bool {
        let (lo, hi) = self.bounds();
        angle < lo || angle > hi
    }

    /// The lowest and highest angles inside the range (rad), [`ANGLE_TOL_RAD`] included:
    /// ±∞ where there is no limit (what [`Self::out_of_range`] compares with, branch-free).
    pub fn bounds(&self) -> (f64, f64) {
        (
            self.min_angle
                .map_or(f64::NEG_INFINITY, |lo| lo - ANGLE_TOL_RAD),
            self.max_angle
                .map_or(f64::INFINITY, |hi| hi + ANGLE_TOL_RAD),
        )
    }

    /// A loaded |torque| (N·mm) above `max_torque`.
    pub fn over_torque(&self, torque: f64) -> bool {
        self.max_torque.is_some_and(|m| torque.abs() > m)
    }
}
