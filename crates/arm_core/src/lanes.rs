//! What the two block kernels (the sweep's, `sweep/fast.rs`, and `solve`'s, `solve/fast.rs`)
//! share, below both (docs/architecture.md): a block of [`L`] poses in lanes, the lanes'
//! trigonometry ([`trig`]) and the transposes of a block back into the caller's rows
//! (`transpose`).
//!
//! Four lanes of `f64` ([`F4`]) and their masks ([`M4`]): element-wise operations written so
//! that LLVM turns each into one vector instruction (one AVX2 `ymm` register, two SSE2 `xmm`).
//!
//! The block kernels' pose stage and the solve kernel's closure are written with them instead
//! of `for k in 0..L` lane loops: with AVX2 and generic tuning LLVM's loop vectoriser left the
//! pose stage's loop (square root, division, sixteen stores per lane) scalar, which made it
//! the kernel's largest cost. Each operation here rounds exactly as the scalar one, so the
//! results are the same bits on every instruction set. Rust never contracts `a·b + c` on its
//! own; the kernels ask for a fused multiply–add where they want one ([`Lane::mul_add`]),
//! which IEEE 754 rounds once, the same on every instruction set (one `vfmadd` with AVX2 +
//! FMA or AVX-512; libm's correctly rounded `fma` on a CPU without FMA, which is slow but
//! gives the same bits).

pub(crate) mod transpose;
pub mod trig;

use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

/// Poses per block (lanes): four packs of four, or two AVX-512 vectors.
pub const L: usize = 16;

/// Lanes per pack.
pub(crate) const W: usize = 4;

const SIGN: u64 = 1 << 63;

/// Four `f64` lanes.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(32))]
pub(crate) struct F4(pub(crate) [f64; W]);

/// Four lane masks: all ones (true) or all zeros (false) per lane.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(C, align(32))]
pub(crate) struct M4(pub(crate) [u64; W]);

impl F4 {
    pub(crate) const ZERO: Self = Self([0.0; W]);

    #[inline(always)]
    pub(crate) fn splat(x: f64) -> Self {
        Self([x; W])
    }

    /// Lanes `at..at + 4` of a lane array.
    #[inline(always)]
    pub(crate) fn load<const L: usize>(a: &[f64; L], at: usize) -> Self {
        let mut v = [0.0; W];
        v.copy_from_slice(&a[at..at + W]);
        Self(v)
    }

    /// Writes the lanes to `a[at..at + 4]`.
    #[inline(always)]
    pub(crate) fn store<const L: usize>(self, a: &mut [f64; L], at: usize) {
        a[at..at + W].copy_from_slice(&self.0);
    }

    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        Self(std::array::from_fn(|k| f(self.0[k])))
    }

    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        Self(std::array::from_fn(|k| f(self.0[k], o.0[k])))
    }

    #[inline(always)]
    fn cmp(self, o: Self, f: impl Fn(f64, f64) -> bool) -> M4 {
        let m = |a: f64, b: f64| 0u64.wrapping_sub(u64::from(f(a, b)));
        M4(std::array::from_fn(|k| m(self.0[k], o.0[k])))
    }

    /// `self·a + b`, rounded once (see [`Lane::mul_add`]).
    #[inline(always)]
    pub(crate) fn mul_add(self, a: Self, b: Self) -> Self {
        Self(std::array::from_fn(|k| self.0[k].mul_add(a.0[k], b.0[k])))
    }

    #[inline(always)]
    fn bits(self, f: impl Fn(u64) -> u64) -> Self {
        self.map(|x| f64::from_bits(f(x.to_bits())))
    }

    #[inline(always)]
    pub(crate) fn sqrt(self) -> Self {
        self.map(f64::sqrt)
    }

    #[inline(always)]
    pub(crate) fn abs(self) -> Self {
        self.bits(|b| b & !SIGN)
    }

    /// `1.0f64.copysign(self)` lane by lane: ±1 with the sign bit of each lane.
    #[inline(always)]
    pub(crate) fn sign_one(self) -> Self {
        self.bits(|b| (b & SIGN) | 1.0f64.to_bits())
    }

    /// Lanes where `self > o` (false for NaN).
    #[inline(always)]
    pub(crate) fn gt(self, o: Self) -> M4 {
        self.cmp(o, |a, b| a > b)
    }

    /// Lanes where `self >= o` (false for NaN).
    #[inline(always)]
    pub(crate) fn ge(self, o: Self) -> M4 {
        self.cmp(o, |a, b| a >= b)
    }

    /// Lanes where `self <= o` (false for NaN).
    #[inline(always)]
    pub(crate) fn le(self, o: Self) -> M4 {
        self.cmp(o, |a, b| a <= b)
    }
}

impl M4 {
    pub(crate) const FALSE: Self = Self([0; W]);
    pub(crate) const TRUE: Self = Self([u64::MAX; W]);

    /// Lane `k` as a `bool`.
    #[inline(always)]
    pub(crate) fn get(self, k: usize) -> bool {
        self.0[k] != 0
    }
}

macro_rules! float_op {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for F4 {
            type Output = F4;
            #[inline(always)]
            fn $method(self, o: F4) -> F4 {
                self.zip(o, |a, b| a $op b)
            }
        }
        impl $trait<f64> for F4 {
            type Output = F4;
            #[inline(always)]
            fn $method(self, o: f64) -> F4 {
                self.zip(F4::splat(o), |a, b| a $op b)
            }
        }
        impl $trait<F4> for f64 {
            type Output = F4;
            #[inline(always)]
            fn $method(self, o: F4) -> F4 {
                F4::splat(self).zip(o, |a, b| a $op b)
            }
        }
    };
}

float_op!(Add, add, +);
float_op!(Sub, sub, -);
float_op!(Mul, mul, *);
float_op!(Div, div, /);

impl Neg for F4 {
    type Output = F4;
    #[inline(always)]
    fn neg(self) -> F4 {
        self.bits(|b| b ^ SIGN)
    }
}

macro_rules! mask_op {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for M4 {
            type Output = M4;
            #[inline(always)]
            fn $method(self, o: M4) -> M4 {
                M4(std::array::from_fn(|k| self.0[k] $op o.0[k]))
            }
        }
    };
}

mask_op!(BitOr, bitor, |);
mask_op!(BitAnd, bitand, &);

impl Not for M4 {
    type Output = M4;
    #[inline(always)]
    fn not(self) -> M4 {
        M4(self.0.map(|b| !b))
    }
}

impl M4 {
    /// Some lane is true.
    #[inline(always)]
    pub(crate) fn any(self) -> bool {
        self.0.iter().fold(0, |a, &b| a | b) != 0
    }

    /// The mask of a lane array of bools, lanes `at..at + 4`.
    #[inline(always)]
    pub(crate) fn load<const L: usize>(a: &[bool; L], at: usize) -> Self {
        Self(std::array::from_fn(|k| {
            0u64.wrapping_sub(u64::from(a[at + k]))
        }))
    }
}

/// `R(s, c)·v` for lanes of sines and cosines and a constant vector `v` in every lane.
#[inline(always)]
pub(crate) fn rot4(s: F4, c: F4, v: &[F4; 2]) -> (F4, F4) {
    (c.mul_add(v[0], -(s * v[1])), s.mul_add(v[0], c * v[1]))
}

/// A lane type of the block kernels: one `f64` (the lane loops, which LLVM vectorises
/// itself) or a pack of four ([`F4`]). The small functions of the kernels (a triangle's
/// turn, composing rotations, the angle series) are written once over it, so the scalar
/// and the packed code give the same bits. Only `Self op f64` and `Self op Self` are used
/// in generic code (IEEE addition and multiplication commute exactly).
pub trait Lane:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
{
    /// The lanes' truth values.
    type Mask: Copy
        + BitOr<Output = Self::Mask>
        + BitAnd<Output = Self::Mask>
        + Not<Output = Self::Mask>;
    /// `x` in every lane.
    fn splat(x: f64) -> Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// `f64::max` (a NaN lane gives the other operand).
    fn max(self, o: Self) -> Self;
    /// `self > o` (false for NaN).
    fn gt(self, o: f64) -> Self::Mask;
    /// `self >= o` (false for NaN).
    fn ge(self, o: f64) -> Self::Mask;
    /// `self < o` (false for NaN).
    fn lt(self, o: f64) -> Self::Mask;
    /// `self <= o` (false for NaN).
    fn le(self, o: f64) -> Self::Mask;
    /// `a` where `m`, else `b`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// `self·a + b` with one rounding (IEEE 754's fused multiply–add: the same bits on every
    /// instruction set, one instruction where the CPU has FMA).
    fn mul_add(self, a: Self, b: Self) -> Self;
}

impl Lane for f64 {
    type Mask = bool;
    #[inline(always)]
    fn splat(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        f64::max(self, o)
    }
    #[inline(always)]
    fn gt(self, o: f64) -> bool {
        self > o
    }
    #[inline(always)]
    fn ge(self, o: f64) -> bool {
        self >= o
    }
    #[inline(always)]
    fn lt(self, o: f64) -> bool {
        self < o
    }
    #[inline(always)]
    fn le(self, o: f64) -> bool {
        self <= o
    }
    #[inline(always)]
    fn select(m: bool, a: Self, b: Self) -> Self {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        f64::mul_add(self, a, b)
    }
}

impl Lane for F4 {
    type Mask = M4;
    #[inline(always)]
    fn splat(x: f64) -> Self {
        F4::splat(x)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        F4::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        F4::abs(self)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        self.zip(o, f64::max)
    }
    #[inline(always)]
    fn gt(self, o: f64) -> M4 {
        F4::gt(self, F4::splat(o))
    }
    #[inline(always)]
    fn ge(self, o: f64) -> M4 {
        F4::ge(self, F4::splat(o))
    }
    #[inline(always)]
    fn lt(self, o: f64) -> M4 {
        self.cmp(F4::splat(o), |a, b| a < b)
    }
    #[inline(always)]
    fn le(self, o: f64) -> M4 {
        F4::le(self, F4::splat(o))
    }
    #[inline(always)]
    fn select(m: M4, a: Self, b: Self) -> Self {
        Self(std::array::from_fn(|k| {
            f64::from_bits((a.0[k].to_bits() & m.0[k]) | (b.0[k].to_bits() & !m.0[k]))
        }))
    }
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        F4::mul_add(self, a, b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every operation equals the scalar one bit for bit, NaN, ±0 and ±∞ included.
    #[test]
    fn lanes_equal_scalar_operations() {
        let xs = [1.5, -0.0, f64::NAN, -3.25e-300];
        let ys = [0.0, 2.0, -1.0, f64::INFINITY];
        let (x, y) = (F4(xs), F4(ys));
        let same = |v: F4, f: &dyn Fn(f64, f64) -> f64| {
            for k in 0..W {
                assert_eq!(v.0[k].to_bits(), f(xs[k], ys[k]).to_bits(), "lane {k}");
            }
        };
        same(x + y, &|a, b| a + b);
        same(x - y, &|a, b| a - b);
        same(x * y, &|a, b| a * b);
        same(x / y, &|a, b| a / b);
        same(x * 3.0, &|a, _| a * 3.0);
        same(3.0 - x, &|a, _| 3.0 - a);
        same(-x, &|a, _| -a);
        same(x.abs(), &|a, _| a.abs());
        same(x.sqrt(), &|a, _| a.sqrt());
        same(x.sign_one(), &|a, _| 1.0f64.copysign(a));
        // fused: one rounding, the scalar `mul_add`'s (0.1·10 − 1 is not 0 when fused)
        same(x.mul_add(y, x), &|a, b| a.mul_add(b, a));
        let (t, ten) = (F4::splat(0.1), F4::splat(10.0));
        assert_eq!(
            t.mul_add(ten, F4::splat(-1.0)).0[0],
            0.1f64.mul_add(10.0, -1.0)
        );
        assert_ne!(0.1f64.mul_add(10.0, -1.0), 0.1 * 10.0 - 1.0);
        for k in 0..W {
            assert_eq!(x.gt(y).get(k), xs[k] > ys[k]);
            assert_eq!(x.ge(y).get(k), xs[k] >= ys[k]);
            assert_eq!(x.le(y).get(k), xs[k] <= ys[k]);
            // A NaN lane is neither greater nor less-or-equal: `!gt` holds there, `le` not.
            let nan = xs[k].is_nan() || ys[k].is_nan();
            assert_eq!((!x.gt(y)).get(k), nan || xs[k] <= ys[k]);
            assert_eq!((x.gt(y) | x.le(y)).get(k), !nan);
            assert_eq!((x.ge(y) & x.le(y)).get(k), xs[k] == ys[k]);
        }
        let mut a = [0.0; 8];
        F4::load(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0], 4).store(&mut a, 2);
        assert_eq!(a, [0.0, 0.0, 5.0, 6.0, 7.0, 8.0, 0.0, 0.0]);
    }
}
