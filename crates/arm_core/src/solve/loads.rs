//! The payloads of a batch as its callers give them, and their checks: force rows, or
//! masses whose weight acts downward. Shared by `solve` (a batch is sequences of one state)
//! and the load sequences (`sequence.rs`), whose parallel work items each check their own
//! rows and make their own forces (docs/architecture.md, "The inputs on their way in").

use crate::arm::Arm;
use crate::error::{ArmError, Result};

/// The payloads of N sequences of S states (S = 1 for `solve`).
#[derive(Debug, Clone, Copy)]
pub(crate) enum Loads<'a> {
    /// The payload force at the load point (N, global), 2 per state: `N × S × 2`.
    Forces(&'a [f64]),
    /// Payload masses (kg), one per state (`N × S`), or with `shared` the S that every
    /// sequence goes through; the force of a mass m is (0, −m·g).
    Masses { kg: &'a [f64], shared: bool },
}

impl<'a> Loads<'a> {
    /// Sequences `first..first + m` of `s` states each.
    pub(crate) fn rows(self, first: usize, m: usize, s: usize) -> Self {
        match self {
            Self::Forces(f) => Self::Forces(&f[2 * s * first..2 * s * (first + m)]),
            Self::Masses { kg, shared: false } => Self::Masses {
                kg: &kg[s * first..s * (first + m)],
                shared: false,
            },
            shared @ Self::Masses { shared: true, .. } => shared,
        }
    }

    /// The force rows of these `m` sequences: the rows themselves, or written into `buf`
    /// from the masses with `g`.
    pub(crate) fn forces<'b>(self, m: usize, g: f64, buf: &'b mut Vec<f64>) -> &'b [f64]
    where
        'a: 'b,
    {
        match self {
            Self::Forces(f) => f,
            Self::Masses { kg, shared } => {
                // x = 0 and y = −k·g per mass, `m` times over the shared states (one plain
                // loop over the rows, which LLVM vectorises, not an iterator of pairs)
                let times = if shared { m } else { 1 };
                buf.clear();
                buf.resize(2 * kg.len() * times, 0.0);
                for rows in buf.chunks_exact_mut(2 * kg.len().max(1)) {
                    for (xy, &k) in rows.chunks_exact_mut(2).zip(kg) {
                        xy[1] = -k * g;
                    }
                }
                buf
            }
        }
    }
}

/// The number of sequences (poses for `solve`) from the shapes of the angles (the arm's `n`
/// per sequence) and of the loads (`s` states each).
pub(crate) fn check_shapes(
    arm: &Arm,
    alpha_deg: &[f64],
    loads: Loads<'_>,
    s: usize,
) -> Result<usize> {
    let seqs = arm.pose_rows(alpha_deg)?;
    let (what, expected, got) = match loads {
        Loads::Forces(f) => ("payload_n", 2 * s * seqs, f.len()),
        Loads::Masses { kg, shared: true } => ("mass_kg", s, kg.len()),
        Loads::Masses { kg, shared: false } => ("mass_kg", s * seqs, kg.len()),
    };
    if got != expected {
        return Err(ArmError::Shape {
            what,
            expected,
            got,
        });
    }
    Ok(seqs)
}

/// No value is NaN or ±∞: one branch-free pass, vectorised for the best instruction set of
/// this CPU (`pulp`). A value's exponent bits `e` are all ones exactly when `e + 2⁵²`
/// carries into the sign bit, so the pass is integer ANDs, adds and ORs (no 64-bit compare,
/// which SSE2 lacks).
fn all_finite(v: &[f64]) -> bool {
    struct Op<'a>(&'a [f64]);
    impl pulp::WithSimd for Op<'_> {
        type Output = bool;
        #[inline(always)]
        fn with_simd<S: pulp::Simd>(self, _simd: S) -> bool {
            let exp = f64::INFINITY.to_bits();
            let carry = |x: &f64| (x.to_bits() & exp) + (1 << 52);
            self.0.iter().fold(0u64, |bad, x| bad | carry(x)) >> 63 == 0
        }
    }
    pulp::Arch::new().dispatch(Op(v))
}

/// Refuses a non-finite angle or payload, or a negative mass, naming the first such
/// sequence (`first` is the batch index of the first of these): one pass over each array,
/// the sequences one by one only when it finds something. A sequence's angles are looked
/// at before its payloads; `states` names the state of a negative mass (sequences; not
/// `solve`, whose rows are one state each).
pub(crate) fn check_finite(
    n: usize,
    alpha_deg: &[f64],
    loads: Loads<'_>,
    s: usize,
    first: usize,
    states: bool,
) -> Result<()> {
    let loads_ok = match loads {
        Loads::Forces(f) => all_finite(f),
        Loads::Masses { kg, .. } => {
            all_finite(kg) && kg.iter().fold(true, |ok, &k| ok & (k >= 0.0))
        }
    };
    if all_finite(alpha_deg) && loads_ok {
        return Ok(());
    }
    for q in 0..alpha_deg.len() / n {
        let row = first + q;
        if !all_finite(&alpha_deg[q * n..(q + 1) * n]) {
            return Err(ArmError::NonFinite {
                row,
                what: "alpha_deg",
            });
        }
        let kg = match loads {
            Loads::Forces(f) => {
                if !all_finite(&f[2 * s * q..2 * s * (q + 1)]) {
                    return Err(ArmError::NonFinite {
                        row,
                        what: "payload",
                    });
                }
                continue;
            }
            Loads::Masses { kg, shared: true } => kg,
            Loads::Masses { kg, shared: false } => &kg[s * q..s * (q + 1)],
        };
        for (k, &m) in kg.iter().enumerate() {
            if !m.is_finite() {
                return Err(ArmError::NonFinite {
                    row,
                    what: "mass_kg",
                });
            }
            if m < 0.0 {
                let what = if states {
                    format!("mass_kg is negative (state {k}: {m:?})")
                } else {
                    format!("mass_kg is negative ({m:?})")
                };
                return Err(ArmError::OutOfRange { row, what });
            }
        }
    }
    Ok(())
}

/// The error of a batch from its work items' errors, in the order of their rows: an error
/// of the input itself (a non-finite value, a negative mass) first, whichever row it names,
/// as if the whole input had been checked before any pose was solved; else the lowest
/// failing item's.
pub(crate) fn first_error(mut errors: Vec<ArmError>) -> Result<()> {
    if errors.is_empty() {
        return Ok(());
    }
    let input = |e: &ArmError| match e {
        ArmError::NonFinite { .. } => true,
        ArmError::OutOfRange { what, .. } => what.starts_with("mass_kg"),
        _ => false,
    };
    let k = errors.iter().position(input).unwrap_or(0);
    Err(errors.swap_remove(k))
}
