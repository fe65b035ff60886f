//! Cheap, vectorisable trigonometry for the sweep kernel (no libm calls inside the lane loops).
//!
//! * [`sincos_deg`]: sine and cosine of angles given in **degrees**. The reduction modulo 90°
//!   is exact (`x − 90·q` is representable for every |x| below [`FAST_TRIG_LIMIT_DEG`]), the
//!   remainder (|r| ≤ 45°) is turned into radians with one rounding, and fdlibm's kernels
//!   (`__kernel_sin`, `__kernel_cos`, error below 1 ulp on |t| ≤ π/4; their polynomials
//!   evaluated in fused multiply–adds) give the result. Overall
//!   within about 2 ulp of the exact sine/cosine of the degree value: the core's `sin_cos` of
//!   `x.to_radians()` differs from it by the rounding of `x·π/180` (≈ |x| · 2e-18 absolute for
//!   x in degrees), i.e. a few 1e-16 for arm angles. Lanes beyond the limit use libm exactly
//!   as the scalar core does.
//! * [`asin_small`]: `asin x` for |x| ≤ [`ASIN_SERIES_MAX`] by its Taylor series to x¹³
//!   (truncation below 1e-18 relative; rounding below 1 ulp). The sweep uses it for the small
//!   rotation of each loaded triangle and falls back to `atan2` where it does not apply.

// The kernels' coefficients as fdlibm publishes them (they round to its exact doubles).
#![allow(clippy::excessive_precision)]

pub use super::Lane;

/// Above this magnitude (degrees) [`sincos_deg`] hands the lane to libm.
pub const FAST_TRIG_LIMIT_DEG: f64 = 1e5;
/// Largest |x| for which [`asin_small`] is accurate to 1 ulp.
pub const ASIN_SERIES_MAX: f64 = 0.0625;

/// 1.5·2⁵²: adding it rounds a double of magnitude < 2⁵¹ to an integer (ties to even).
const ROUND_MAGIC: f64 = 6_755_399_441_055_744.0;

// fdlibm k_sin.c / k_cos.c minimax coefficients on [−π/4, π/4].
const S1: f64 = -1.666_666_666_666_663_243_48e-1;
const S2: f64 = 8.333_333_333_322_489_461_24e-3;
const S3: f64 = -1.984_126_982_985_794_931_34e-4;
const S4: f64 = 2.755_731_370_707_006_767_89e-6;
const S5: f64 = -2.505_076_025_340_686_341_95e-8;
const S6: f64 = 1.589_690_995_211_550_102_21e-10;
const C1: f64 = 4.166_666_666_666_660_190_37e-2;
const C2: f64 = -1.388_888_888_887_410_957_49e-3;
const C3: f64 = 2.480_158_728_947_672_941_78e-5;
const C4: f64 = -2.755_731_435_139_066_330_35e-7;
const C5: f64 = 2.087_572_321_298_174_827_90e-9;
const C6: f64 = -1.135_964_755_778_819_482_65e-11;

/// sin and cos of `t`, |t| ≤ π/4 (fdlibm kernels, no tail).
#[inline(always)]
fn kernel(t: f64) -> (f64, f64) {
    // Horner's scheme in fused multiply–adds (one rounding per step, not two).
    let z = t * t;
    let v = z * t;
    let rs = z.mul_add(z.mul_add(z.mul_add(z.mul_add(S6, S5), S4), S3), S2);
    let s = v.mul_add(z.mul_add(rs, S1), t);
    let rc = z * z.mul_add(
        z.mul_add(z.mul_add(z.mul_add(z.mul_add(C6, C5), C4), C3), C2),
        C1,
    );
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    let c = w + z.mul_add(rc, (1.0 - w) - hz);
    (s, c)
}

/// Lane-wise sine and cosine of `x` (degrees); see the module documentation for accuracy.
#[inline(always)]
pub fn sincos_deg<const L: usize>(x: &[f64; L], sin: &mut [f64; L], cos: &mut [f64; L]) {
    let deg = std::f64::consts::PI / 180.0;
    for k in 0..L {
        // q = round(x / 90); r = x − 90q is exact, |r| ≤ 45 (a hair more at a rounding tie).
        let t = x[k] * (1.0 / 90.0) + ROUND_MAGIC;
        let q = t - ROUND_MAGIC;
        let (s, c) = kernel((x[k] - 90.0 * q) * deg);
        // The low mantissa bits of t hold q mod 4: swap sin/cos for odd q, then set signs.
        let qb = t.to_bits();
        let swap = 0u64.wrapping_sub(qb & 1);
        let neg_s = (qb & 2) << 62;
        let neg_c = (qb.wrapping_add(1) & 2) << 62;
        let (sb, cb) = (s.to_bits(), c.to_bits());
        sin[k] = f64::from_bits(((sb & !swap) | (cb & swap)) ^ neg_s);
        cos[k] = f64::from_bits(((cb & !swap) | (sb & swap)) ^ neg_c);
    }
    let mut far = false;
    for v in x {
        far |= v.abs() > FAST_TRIG_LIMIT_DEG;
    }
    if far {
        for k in 0..L {
            if x[k].abs() > FAST_TRIG_LIMIT_DEG {
                (sin[k], cos[k]) = x[k].to_radians().sin_cos();
            }
        }
    }
}

/// Lane-wise sine and cosine of `x` (**radians**): fdlibm's kernels (within 1 ulp) where
/// |x| ≤ π/4, libm beyond. For the small turns of a rotary drive's gear.
#[inline(always)]
pub(crate) fn sincos_small<const L: usize>(x: &[f64; L], sin: &mut [f64; L], cos: &mut [f64; L]) {
    let quarter = std::f64::consts::FRAC_PI_4;
    let mut far = false;
    for k in 0..L {
        (sin[k], cos[k]) = kernel(x[k]);
        far |= x[k].abs() > quarter; // NaN stays NaN either way
    }
    if far {
        for k in 0..L {
            if x[k].abs() > quarter {
                (sin[k], cos[k]) = x[k].sin_cos();
            }
        }
    }
}

// Taylor coefficients of asin: c_k = (2k)! / (4^k (k!)² (2k+1)).
const A1: f64 = 1.0 / 6.0;
const A2: f64 = 3.0 / 40.0;
const A3: f64 = 5.0 / 112.0;
const A4: f64 = 35.0 / 1152.0;
const A5: f64 = 63.0 / 2816.0;
const A6: f64 = 231.0 / 13312.0;

/// `a` moved by one turn into [−π, π) when it is just outside (the loaded angle nearest the
/// unloaded one: the sum of an angle in [−π, π) and a rotation of at most π). A select, not
/// [`crate::geometry::wrap_pi`]'s remainder, so that lane loops stay branch-free.
#[inline(always)]
pub fn wrap_once<T: Lane>(a: T) -> T {
    use std::f64::consts::{PI, TAU};
    T::select(a.ge(PI), a - TAU, T::select(a.lt(-PI), a + TAU, a))
}

/// `asin x` for |x| ≤ [`ASIN_SERIES_MAX`] (Taylor series to x¹³); larger |x| is inaccurate.
#[inline(always)]
pub fn asin_small<T: Lane>(x: T) -> T {
    // Estrin's scheme: a short dependency chain (the lanes of the sweep are latency-bound).
    let z = x * x;
    let z2 = z * z;
    let c = T::splat;
    let p = z2.mul_add(
        z2.mul_add(z.mul_add(c(A6), c(A5)), z.mul_add(c(A4), c(A3))),
        z.mul_add(c(A2), c(A1)),
    );
    (x * z).mul_add(p, x)
}

/// `cos a − 1` from `sin a` and `cos a`, without cancellation where cos a > 0.
#[inline(always)]
pub(crate) fn cos_m1<T: Lane>(s: T, c: T) -> T {
    T::select(c.gt(0.0), -s * s / (c + 1.0), c - 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ulps(a: f64, b: f64) -> f64 {
        (a - b).abs() / (f64::EPSILON * b.abs().max(1e-300))
    }

    #[test]
    fn sincos_matches_libm_to_a_few_ulp() {
        let mut state: u64 = 0x2545_F491_4F6C_DD1D;
        let mut worst = 0.0f64;
        for round in 0..20_000 {
            let mut x = [0.0; 8];
            for v in x.iter_mut() {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let u = (state >> 11) as f64 / (1u64 << 53) as f64;
                let span = if round % 2 == 0 { 400.0 } else { 2.0e5 };
                *v = (u - 0.5) * span;
            }
            x[0] = [0.0, 45.0, 90.0, -90.0, 135.0, 180.0, -180.0, 1e-300][round % 8];
            let (mut s, mut c) = ([0.0; 8], [0.0; 8]);
            sincos_deg(&x, &mut s, &mut c);
            for k in 0..8 {
                // Compare with the exact-degree value: libm on the reduced argument.
                let r = x[k] - 360.0 * (x[k] / 360.0).round();
                let (es, ec) = r.to_radians().sin_cos();
                // Absolute error relative to 1 (values near zero are checked absolutely).
                worst = worst.max((s[k] - es).abs().max((c[k] - ec).abs()) / f64::EPSILON);
                if es.abs() > 0.5 {
                    assert!(ulps(s[k], es) < 4.0, "sin({}) = {} vs {}", x[k], s[k], es);
                }
                if ec.abs() > 0.5 {
                    assert!(ulps(c[k], ec) < 4.0, "cos({}) = {} vs {}", x[k], c[k], ec);
                }
            }
        }
        assert!(worst < 4.0, "worst absolute error {worst} eps");
        let (mut s, mut c) = ([0.0; 2], [0.0; 2]);
        sincos_deg(&[90.0, 180.0], &mut s, &mut c);
        assert_eq!((s[0], c[0]), (1.0, 0.0));
        assert_eq!((s[1], c[1]), (0.0, -1.0));
    }

    #[test]
    fn asin_series_matches_libm() {
        for k in -1000..=1000 {
            let x = ASIN_SERIES_MAX * f64::from(k) / 1000.0;
            let e = x.asin();
            assert!(
                (asin_small(x) - e).abs() <= 2.0 * f64::EPSILON * e.abs(),
                "asin({x})"
            );
        }
    }
}
