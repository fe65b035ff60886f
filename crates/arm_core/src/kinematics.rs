//! Frame transforms (seed relation 1), actuator lengths, angles from lengths, inverse kinematics.
//!
//! All positions are global, in mm; angles are absolute, counter-clockwise from global x.

use crate::arm::Arm;
use crate::error::{ArmError, Result};
use crate::geometry::{angle, close_triangle, cross, rot, rot_sc, wrap_pi, V2};

/// The global geometry of one pose, filled in place (no allocation once sized).
#[derive(Debug, Clone, Default)]
pub struct Frames {
    /// Absolute link angles α_i (rad).
    pub alpha: Vec<f64>,
    /// `sin α_i`.
    pub sin: Vec<f64>,
    /// `cos α_i`.
    pub cos: Vec<f64>,
    /// Joints O_1…O_n followed by the load point (n + 1 entries).
    pub joint: Vec<V2>,
    /// Pin A_i of actuator i on link i (NaN where a rotary drive turns link i: no pin).
    pub a: Vec<V2>,
    /// Base pin of actuator i: B_0 (chassis) for i = 1, else link i−1's B point (NaN where
    /// a rotary drive turns link i).
    pub b: Vec<V2>,
    /// Centre of mass of link i.
    pub c: Vec<V2>,
    /// Measurement point.
    pub measure: V2,
}

impl Frames {
    /// Empty frames sized for an arm of `n` links.
    pub fn new(n: usize) -> Self {
        Self {
            alpha: vec![0.0; n],
            sin: vec![0.0; n],
            cos: vec![0.0; n],
            joint: vec![V2::zeros(); n + 1],
            a: vec![V2::zeros(); n],
            b: vec![V2::zeros(); n],
            c: vec![V2::zeros(); n],
            measure: V2::zeros(),
        }
    }

    /// Fills the frames from absolute angles in radians (`alpha.len() == arm.n()`).
    pub fn fill(&mut self, arm: &Arm, alpha: &[f64]) {
        let mut o = arm.o1;
        let mut base_pin = arm.b0;
        for (i, link) in arm.links.iter().enumerate() {
            let (s, c) = alpha[i].sin_cos();
            self.alpha[i] = alpha[i];
            self.sin[i] = s;
            self.cos[i] = c;
            self.joint[i] = o;
            if arm.is_rotary(i) {
                // No actuator, no pins: NaN, so that no computation can use them unawares.
                self.a[i] = V2::repeat(f64::NAN);
                self.b[i] = V2::repeat(f64::NAN);
            } else {
                self.a[i] = o + rot_sc(s, c, link.a);
                self.b[i] = base_pin;
            }
            self.c[i] = o + rot_sc(s, c, link.c);
            base_pin = o + rot_sc(s, c, link.b);
            o += rot_sc(s, c, link.next);
        }
        let n = arm.n();
        self.joint[n] = o;
        let last = n - 1;
        self.measure = self.joint[last] + rot_sc(self.sin[last], self.cos[last], arm.measure);
    }

    /// Pin-to-pin length of actuator `i` (mm; NaN at a rotary drive).
    #[inline]
    pub fn length(&self, i: usize) -> f64 {
        (self.a[i] - self.b[i]).norm()
    }

    /// Local vector `v` of link `i` expressed in the global frame (rotation only).
    #[inline]
    pub fn to_global(&self, i: usize, v: V2) -> V2 {
        rot_sc(self.sin[i], self.cos[i], v)
    }

    /// Global vector `v` expressed in link `i`'s frame (rotation only).
    #[inline]
    pub fn to_local(&self, i: usize, v: V2) -> V2 {
        rot_sc(-self.sin[i], self.cos[i], v)
    }

    /// Side of actuator `i`'s triangle: +1 when A_i lies counter-clockwise of B_{i−1} as seen
    /// from O_i, −1 otherwise, 0 when degenerate.
    #[inline]
    pub fn side(&self, i: usize) -> f64 {
        let o = self.joint[i];
        let s = cross(self.b[i] - o, self.a[i] - o);
        if s > 0.0 {
            1.0
        } else if s < 0.0 {
            -1.0
        } else {
            0.0
        }
    }
}

/// Absolute angles (rad) of a rigid arm whose actuators have pin-to-pin lengths `length` (mm).
///
/// Each triangle is closed in closed form from the base out; the branch is the one of the
/// reference pose `alpha_ref` (rad), i.e. the nearest. A joint turned by a rotary drive has
/// no length: its entry must be NaN, and the joint keeps the reference pose's relative angle
/// `q_i = α_i − α_{i−1}` (so `forward`'s lengths, NaN there, give back the angles).
///
/// # Errors
/// [`ArmError::Unreachable`] when a length cannot close its triangle;
/// [`ArmError::OutOfRange`] for a length that is not > 0, or not NaN at a rotary drive.
pub fn angles_from_lengths(
    arm: &Arm,
    length: &[f64],
    alpha_ref: &[f64],
    row: usize,
    out: &mut [f64],
) -> Result<()> {
    let mut sides = vec![0.0; arm.n()];
    triangle_sides(arm, alpha_ref, &mut sides);
    angles_from_lengths_sided(arm, length, alpha_ref, &sides, row, out)
}

/// The side (±1, 0 when degenerate or at a rotary drive) of every actuator triangle in the
/// pose `alpha_ref` (rad): the branch [`angles_from_lengths`] closes on.
pub fn triangle_sides(arm: &Arm, alpha_ref: &[f64], sides: &mut [f64]) {
    let mut reference = Frames::new(arm.n());
    reference.fill(arm, alpha_ref);
    for (i, s) in sides.iter_mut().enumerate() {
        *s = reference.side(i);
    }
}

/// [`angles_from_lengths`] with the triangle sides of the reference pose already known
/// ([`triangle_sides`]): no allocation.
///
/// # Errors
/// As [`angles_from_lengths`].
pub fn angles_from_lengths_sided(
    arm: &Arm,
    length: &[f64],
    alpha_ref: &[f64],
    sides: &[f64],
    row: usize,
    out: &mut [f64],
) -> Result<()> {
    let mut o = arm.o1;
    let mut base_pin = arm.b0;
    for (i, link) in arm.links.iter().enumerate() {
        let al = if arm.is_rotary(i) {
            if !length[i].is_nan() {
                return Err(ArmError::OutOfRange {
                    row,
                    what: format!(
                        "length_mm of joint {} must be NaN: a rotary drive turns it, which has \
                         no length (it keeps the reference pose's angle), got {}",
                        i + 1,
                        length[i]
                    ),
                });
            }
            let before = if i == 0 {
                0.0
            } else {
                out[i - 1] - alpha_ref[i - 1]
            };
            alpha_ref[i] + before
        } else {
            if length[i].is_nan() || length[i] <= 0.0 {
                return Err(ArmError::OutOfRange {
                    row,
                    what: format!(
                        "length_mm of actuator {} must be > 0, got {}",
                        i + 1,
                        length[i]
                    ),
                });
            }
            let theta = close_triangle(base_pin - o, link.a.norm(), length[i], sides[i]).ok_or(
                ArmError::Unreachable {
                    row,
                    actuator: i + 1,
                    length: length[i],
                },
            )?;
            // The solution nearest the reference, not merely equal modulo 2π.
            alpha_ref[i] + wrap_pi(theta - angle(link.a) - alpha_ref[i])
        };
        out[i] = al;
        base_pin = o + rot(al, link.b);
        o += rot(al, link.next);
    }
    Ok(())
}

/// Rows per parallel task of [`angles_from_lengths_batch`].
const LENGTHS_CHUNK: usize = 4096;

/// [`angles_from_lengths`] of N rows, in degrees, in parallel (rayon).
///
/// `length_mm` is `N × n` (NaN at the joints turned by rotary drives); `alpha_ref_deg` is
/// `n` (one reference pose for every row) or `N × n`. With `nan_on_failure`, a row whose lengths cannot close a triangle gets NaN
/// angles instead of an error.
///
/// # Errors
/// [`ArmError::Shape`] for arrays of the wrong length; [`ArmError::NonFinite`] naming the
/// first row with a non-finite length or reference angle; the error of the first row that
/// fails ([`ArmError::Unreachable`] only without `nan_on_failure`).
pub fn angles_from_lengths_batch(
    arm: &Arm,
    length_mm: &[f64],
    alpha_ref_deg: &[f64],
    nan_on_failure: bool,
    out_deg: &mut [f64],
) -> Result<()> {
    use rayon::prelude::*;
    let n = arm.n();
    let rows = length_mm.len() / n;
    if length_mm.len() != rows * n || out_deg.len() != rows * n {
        return Err(ArmError::Shape {
            what: "length_mm",
            expected: out_deg.len(),
            got: length_mm.len(),
        });
    }
    let shared = alpha_ref_deg.len() == n;
    if !shared && alpha_ref_deg.len() != rows * n {
        return Err(ArmError::Shape {
            what: "alpha_ref_deg",
            expected: rows * n,
            got: alpha_ref_deg.len(),
        });
    }
    let ref_rad: Vec<f64> = alpha_ref_deg.iter().map(|a| a.to_radians()).collect();
    let mut shared_sides = vec![0.0; n];
    if shared {
        if !ref_rad.iter().all(|v| v.is_finite()) {
            return Err(ArmError::NonFinite {
                row: 0,
                what: "alpha_ref_deg",
            });
        }
        triangle_sides(arm, &ref_rad, &mut shared_sides);
    }
    let chunk = |c: usize, out: &mut [f64]| -> Result<()> {
        let mut sides = shared_sides.clone();
        let mut frames = Frames::new(n);
        let r0 = c * LENGTHS_CHUNK;
        for (k, dst) in out.chunks_exact_mut(n).enumerate() {
            let row = r0 + k;
            let l = &length_mm[row * n..(row + 1) * n];
            let r = if shared {
                &ref_rad[..]
            } else {
                &ref_rad[row * n..(row + 1) * n]
            };
            // NaN is a rotary drive's length (checked in the closure); ±∞ is never one.
            let given = |(i, v): (usize, &f64)| v.is_finite() || (v.is_nan() && arm.is_rotary(i));
            if !(l.iter().enumerate().all(given) && r.iter().all(|v| v.is_finite())) {
                return Err(ArmError::NonFinite {
                    row,
                    what: "length_mm/alpha_ref_deg",
                });
            }
            if !shared {
                frames.fill(arm, r);
                for (i, s) in sides.iter_mut().enumerate() {
                    *s = frames.side(i);
                }
            }
            match angles_from_lengths_sided(arm, l, r, &sides, row, dst) {
                Ok(()) => dst.iter_mut().for_each(|v| *v = v.to_degrees()),
                Err(ArmError::Unreachable { .. }) if nan_on_failure => dst.fill(f64::NAN),
                Err(e) => return Err(e),
            }
        }
        Ok(())
    };
    let results: Vec<Result<()>> = if rows >= 2 * LENGTHS_CHUNK {
        out_deg
            .par_chunks_mut(LENGTHS_CHUNK * n)
            .enumerate()
            .map(|(c, out)| chunk(c, out))
            .collect()
    } else {
        out_deg
            .chunks_mut(LENGTHS_CHUNK * n)
            .enumerate()
            .map(|(c, out)| chunk(c, out))
            .collect()
    };
    // The first failing row: chunks are in order and each stops at its first failure.
    results.into_iter().collect()
}

/// Inverse kinematics of a 3-link arm: absolute angles (rad) that put the load point at
/// `(x, y)` (mm, global) with the last link at angle `alpha3` (rad).
///
/// `elbow` (+1 or −1) picks the branch of the relative angle β = α₂ − α₁ (−1 is the seed's
/// "elbow up" pose, with α₂ < α₁). α₁ and α₂ are returned in [−π, π), α₃ as given.
/// Returns `Ok(false)` and leaves `out` unchanged when the target is out of reach.
///
/// # Errors
/// [`ArmError::Unsupported`] when the arm does not have exactly 3 links.
pub fn inverse_kinematics(
    arm: &Arm,
    target: [f64; 3],
    elbow: f64,
    out: &mut [f64],
) -> Result<bool> {
    if arm.n() != 3 {
        return Err(ArmError::Unsupported(format!(
            "inverse kinematics needs a 3-link arm, this one has {} links",
            arm.n()
        )));
    }
    let [x, y, a3] = target;
    let o3 = V2::new(x, y) - rot(a3, arm.links[2].next);
    let d = o3 - arm.o1;
    let (n1, n2) = (arm.links[0].next, arm.links[1].next);
    let (r1, r2) = (n1.norm(), n2.norm());
    let c = (d.norm_squared() - r1 * r1 - r2 * r2) / (2.0 * r1 * r2);
    if !(-1.0..=1.0).contains(&c) {
        return Ok(false);
    }
    let beta = angle(n1) - angle(n2) + elbow.signum() * c.acos();
    let a1 = wrap_pi(angle(d) - angle(n1 + rot(beta, n2)));
    out[0] = a1;
    out[1] = wrap_pi(a1 + beta);
    out[2] = a3;
    Ok(true)
}

/// Rows per parallel task of [`forward_batch`].
const FORWARD_CHUNK: usize = 1024;

/// The outputs of [`forward_batch`], row-major, filled in place: `o` (N × (n+1) × 2) joints
/// and the load point, `a`, `b`, `c` (N × n × 2) actuator pins, base pins and centres of
/// mass, `measure` (N × 2), `length` (N × n) pin-to-pin lengths.
#[derive(Debug)]
pub struct ForwardOutput<'a> {
    /// Joints O_1…O_n and the load point.
    pub o: &'a mut [f64],
    /// Actuator pins A_i.
    pub a: &'a mut [f64],
    /// Base pins B_{i−1}.
    pub b: &'a mut [f64],
    /// Centres of mass C_i.
    pub c: &'a mut [f64],
    /// Measure point.
    pub measure: &'a mut [f64],
    /// Pin-to-pin lengths (mm).
    pub length: &'a mut [f64],
}

/// The global points of N poses (`alpha_deg`, N × n, degrees), in parallel over chunks.
///
/// # Errors
/// [`ArmError::Shape`] for outputs of the wrong size; [`ArmError::NonFinite`] naming the
/// first row with a non-finite angle.
pub fn forward_batch(arm: &Arm, alpha_deg: &[f64], out: ForwardOutput<'_>) -> Result<()> {
    use rayon::prelude::*;
    let n = arm.n();
    let rows = alpha_deg.len() / n;
    let sizes = [
        (out.o.len(), rows * (n + 1) * 2),
        (out.a.len(), rows * n * 2),
        (out.b.len(), rows * n * 2),
        (out.c.len(), rows * n * 2),
        (out.measure.len(), rows * 2),
        (out.length.len(), rows * n),
    ];
    if alpha_deg.len() != rows * n || sizes.iter().any(|(got, want)| got != want) {
        return Err(ArmError::Shape {
            what: "forward outputs",
            expected: rows * n,
            got: alpha_deg.len(),
        });
    }
    let k = FORWARD_CHUNK;
    let chunks = alpha_deg
        .par_chunks(k * n)
        .zip(out.o.par_chunks_mut(k * (n + 1) * 2))
        .zip(out.a.par_chunks_mut(k * n * 2))
        .zip(out.b.par_chunks_mut(k * n * 2))
        .zip(out.c.par_chunks_mut(k * n * 2))
        .zip(out.measure.par_chunks_mut(k * 2))
        .zip(out.length.par_chunks_mut(k * n))
        .enumerate();
    let results: Vec<Result<()>> = chunks
        .map(|(ci, ((((((alpha, o), a), b), c), m), len))| {
            let mut fr = Frames::new(n);
            let mut rad = vec![0.0; n];
            for (p, src) in alpha.chunks_exact(n).enumerate() {
                if !src.iter().all(|v| v.is_finite()) {
                    return Err(ArmError::NonFinite {
                        row: ci * k + p,
                        what: "alpha_deg",
                    });
                }
                for (r, d) in rad.iter_mut().zip(src) {
                    *r = d.to_radians();
                }
                fr.fill(arm, &rad);
                let put = |dst: &mut [f64], j: usize, q: V2| {
                    dst[2 * j] = q.x;
                    dst[2 * j + 1] = q.y;
                };
                for (i, q) in fr.joint.iter().enumerate() {
                    put(o, p * (n + 1) + i, *q);
                }
                for i in 0..n {
                    put(a, p * n + i, fr.a[i]);
                    put(b, p * n + i, fr.b[i]);
                    put(c, p * n + i, fr.c[i]);
                    len[p * n + i] = fr.length(i);
                }
                put(m, p, fr.measure);
            }
            Ok(())
        })
        .collect();
    // The first failing row: chunks are in order and each stops at its first failure.
    results.into_iter().collect()
}
