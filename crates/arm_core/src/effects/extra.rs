//! Deformations given from outside the catalogue, per pose: what user-written effects
//! (docs/custom-effects.md) return. They add to the causes of the built-in effects, and the loaded pose
//! is then closed exactly with all of them (docs/model.md §4, "External deformations").

use super::Deformation;
use crate::arm::Arm;
use crate::error::{ArmError, Result};
use crate::geometry::V2;

/// Per-pose extra deformations of a batch of N poses of an n-link arm, row-major; every
/// array optional (absent: zero). All in the global frame.
#[derive(Debug, Clone, Copy, Default)]
pub struct ExtraDeformations<'a> {
    /// `extra_seen_mm`, N × n: pin-to-pin length change of each actuator that its sensor
    /// (`dlK_mm`) sees (mm); zero at joints turned by rotary drives.
    pub seen_mm: Option<&'a [f64]>,
    /// `extra_unseen_mm`, N × n: pin-to-pin length change its sensor does not see (mm); zero
    /// at joints turned by rotary drives.
    pub unseen_mm: Option<&'a [f64]>,
    /// `extra_turn_rad`, N × n: turn of link i against body i−1 at a rotary drive (rad,
    /// counter-clockwise +), added to the gear's; zero at joints turned by linear actuators
    /// (the actuator sets that angle).
    pub turn_rad: Option<&'a [f64]>,
    /// `extra_joint_mm`, N × n × 2: offset of link i's pin centre at O_i from its bore in
    /// body i−1 (mm), as `joint_clearance`'s offset.
    pub joint_mm: Option<&'a [f64]>,
    /// `extra_tilt_rad`, N: counter-clockwise tilt of the chassis about the base pivot (rad).
    pub tilt_rad: Option<&'a [f64]>,
    /// `extra_measure_mm`, N × 2: displacement of the measure point added after the pose is
    /// closed (mm).
    pub measure_mm: Option<&'a [f64]>,
}

impl<'a> ExtraDeformations<'a> {
    /// No extra deformation.
    pub fn none() -> Self {
        Self::default()
    }

    /// Whether every array is absent.
    pub fn is_none(&self) -> bool {
        self.seen_mm.is_none()
            && self.unseen_mm.is_none()
            && self.turn_rad.is_none()
            && self.joint_mm.is_none()
            && self.tilt_rad.is_none()
            && self.measure_mm.is_none()
    }

    /// The arrays with their names and values per pose, for an n-link arm.
    fn arrays(&self, n: usize) -> [(&'static str, Option<&'a [f64]>, usize); 6] {
        [
            ("extra_seen_mm", self.seen_mm, n),
            ("extra_unseen_mm", self.unseen_mm, n),
            ("extra_turn_rad", self.turn_rad, n),
            ("extra_joint_mm", self.joint_mm, 2 * n),
            ("extra_tilt_rad", self.tilt_rad, 1),
            ("extra_measure_mm", self.measure_mm, 2),
        ]
    }

    /// Checks the sizes against `rows` poses of an `n`-link arm and that every value is
    /// finite.
    ///
    /// # Errors
    /// [`ArmError::Shape`] naming the array, or [`ArmError::NonFinite`] naming the array and
    /// the first row with a NaN or infinite value.
    pub fn check(&self, rows: usize, n: usize) -> Result<()> {
        for (what, a, per_row) in self.arrays(n) {
            let Some(a) = a else { continue };
            if a.len() != rows * per_row {
                return Err(ArmError::Shape {
                    what,
                    expected: rows * per_row,
                    got: a.len(),
                });
            }
            if let Some(k) = a.iter().position(|v| !v.is_finite()) {
                return Err(ArmError::NonFinite {
                    row: k / per_row,
                    what,
                });
            }
        }
        Ok(())
    }

    /// Checks that every per-joint value fits its joint's drive: a length change only at a
    /// linear actuator, a turn only at a rotary drive (zero elsewhere).
    ///
    /// # Errors
    /// [`ArmError::OutOfRange`] naming the first row, the array and the joint.
    pub fn check_drives(&self, arm: &Arm) -> Result<()> {
        let n = arm.n();
        let lengths = [
            ("extra_seen_mm", self.seen_mm),
            ("extra_unseen_mm", self.unseen_mm),
        ];
        for (what, a, rotary) in lengths.into_iter().map(|(w, a)| (w, a, true)).chain([(
            "extra_turn_rad",
            self.turn_rad,
            false,
        )]) {
            let Some(a) = a else { continue };
            let bad = a
                .iter()
                .enumerate()
                .find(|(k, v)| **v != 0.0 && arm.is_rotary(k % n) == rotary);
            if let Some((k, _)) = bad {
                let joint = k % n + 1;
                let why = if rotary {
                    format!("joint {joint} is turned by a rotary drive, which has no length (use extra_turn_rad)")
                } else {
                    format!("joint {joint} is turned by a linear actuator, which sets its angle (use extra_seen_mm or extra_unseen_mm)")
                };
                return Err(ArmError::OutOfRange {
                    row: k / n,
                    what: format!("{what}: {why}"),
                });
            }
        }
        Ok(())
    }

    /// The rows `start .. start + count` (for a chunk of a batch).
    pub fn rows(&self, start: usize, count: usize, n: usize) -> Self {
        let cut = |a: Option<&'a [f64]>, per_row: usize| {
            a.and_then(|a| a.get(start * per_row..(start + count) * per_row))
        };
        Self {
            seen_mm: cut(self.seen_mm, n),
            unseen_mm: cut(self.unseen_mm, n),
            turn_rad: cut(self.turn_rad, n),
            joint_mm: cut(self.joint_mm, 2 * n),
            tilt_rad: cut(self.tilt_rad, 1),
            measure_mm: cut(self.measure_mm, 2),
        }
    }

    /// Adds row `row`'s deformations to `def` (sized for `n` links; a checked batch).
    pub fn add_to(&self, row: usize, def: &mut Deformation) {
        let n = def.extra_length.len();
        let at = |a: Option<&[f64]>, k: usize| a.and_then(|a| a.get(k).copied()).unwrap_or(0.0);
        for i in 0..n {
            def.seen_length[i] += at(self.seen_mm, row * n + i);
            def.extra_length[i] += at(self.unseen_mm, row * n + i);
            def.turn[i] += at(self.turn_rad, row * n + i);
            let j = 2 * (row * n + i);
            def.joint_offset[i] += V2::new(at(self.joint_mm, j), at(self.joint_mm, j + 1));
        }
        def.base_tilt += at(self.tilt_rad, row);
        def.measure_shift += V2::new(
            at(self.measure_mm, 2 * row),
            at(self.measure_mm, 2 * row + 1),
        );
    }
}
