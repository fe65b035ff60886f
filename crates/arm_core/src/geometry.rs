//! Planar vector helpers: rotation, cross product and the closed-form triangle closure.

use nalgebra::Vector2;

/// A 2-vector in mm (points, displacements) or N (forces).
pub type V2 = Vector2<f64>;

/// Rotates `v` counter-clockwise by `theta` radians: `R(θ)·v`.
#[inline(always)]
pub fn rot(theta: f64, v: V2) -> V2 {
    let (s, c) = theta.sin_cos();
    rot_sc(s, c, v)
}

/// `R(θ)·v` from precomputed `sin θ`, `cos θ`.
#[inline(always)]
pub fn rot_sc(s: f64, c: f64, v: V2) -> V2 {
    V2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

/// Scalar cross product `a × b = a_x b_y − a_y b_x` (moment of `b` applied at lever `a`).
#[inline(always)]
pub fn cross(a: V2, b: V2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Polar angle of `v` in radians.
#[inline(always)]
pub fn angle(v: V2) -> f64 {
    v.y.atan2(v.x)
}

/// Closes a triangle: a point at distance `rho` from the origin and `len` from `d`.
///
/// Returns the polar angle θ of that point, on the side `side` (+1: counter-clockwise of `d`,
/// −1: clockwise), or `None` when no such point exists (|cos| > 1 or a degenerate `d`).
///
/// ```
/// use arm_core::geometry::{close_triangle, V2};
/// // 3-4-5 triangle: the point (0, 3) is 3 from the origin and 5 from (4, 0).
/// let th = close_triangle(V2::new(4.0, 0.0), 3.0, 5.0, 1.0).unwrap();
/// assert!((th - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
/// ```
#[inline]
pub fn close_triangle(d: V2, rho: f64, len: f64, side: f64) -> Option<f64> {
    let dn = d.norm();
    if dn <= 0.0 || rho <= 0.0 {
        return None;
    }
    let c = (rho * rho + dn * dn - len * len) / (2.0 * rho * dn);
    if !(-1.0..=1.0).contains(&c) {
        return None;
    }
    Some(angle(d) + side * c.acos())
}

/// Wraps an angle difference into [−π, π).
///
/// ```
/// use arm_core::geometry::wrap_pi;
/// assert!((wrap_pi(3.0 * std::f64::consts::PI / 2.0) + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
/// ```
#[inline]
pub fn wrap_pi(x: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    if (-PI..PI).contains(&x) {
        x
    } else {
        (x + PI).rem_euclid(TAU) - PI
    }
}
