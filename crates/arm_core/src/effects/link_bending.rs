//! `link_bending@Li`: link i as an Euler–Bernoulli beam along its local x axis.
//!
//! Every change of force on the link, `(f_x, f_y)` at local `(x_p, y_p)`, is carried to the
//! axis as a transverse force `f_y` and a couple `C = −y_p·f_x` at `x_p`. The changes are in
//! equilibrium, so `EI·v″(x) = M(x) = Σ_{x_p > x} [f_y (x_p − x) + C]`, integrated in closed form.
//! A link turned by a linear actuator rests on `v(0) = 0` (joint O_i) and `v(x_A) = 0` (abscissa
//! of A_i; the link frame is the chord through them). A link turned by a rotary drive is clamped
//! at the drive's flange, `v(0) = v′(0) = 0` (the link frame is the flange's): a cantilever each
//! way from x = 0, the loads at `x_p > 0` bending the part `x > 0` and those at `x_p < 0` the part
//! `x < 0` (docs/model.md §10). A point (x, y) of the link moves by `(−y·v′(x), v(x))` in the
//! link frame.

use super::{check_param, check_place, Deformation, EffectContext, Mechanism, PinShift};
use crate::arm::Arm;
use crate::error::{ArmError, Result};
use crate::geometry::V2;

/// Flexural rigidity EI (N·mm²) of link `link` (0-based).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkBending {
    /// 0-based link index.
    pub link: usize,
    /// Flexural rigidity (N·mm²), > 0.
    pub ei: f64,
}

/// A point load on the beam axis: abscissa, transverse force, couple.
#[derive(Debug, Clone, Copy, Default)]
struct AxisLoad {
    x: f64,
    f: f64,
    c: f64,
}

/// Loads a link carries at most: its joint, its actuator pin, the next actuator's pin and the
/// next joint, and the couples of its two joints.
const MAX_LOADS: usize = 6;

/// How a beam is held (docs/model.md §4 and §10).
#[derive(Debug, Clone, Copy)]
enum Support {
    /// `v = 0` at x = 0 and at x = `xa` (a link turned by a linear actuator).
    Pinned { xa: f64 },
    /// `v = v′ = 0` at x = 0 (a link turned by a rotary drive, clamped at its flange).
    Clamped,
}

impl Support {
    /// How link `k` of `arm` is held.
    fn of(arm: &Arm, k: usize) -> Self {
        if arm.is_rotary(k) {
            Self::Clamped
        } else {
            Self::Pinned {
                xa: arm.links[k].a.x,
            }
        }
    }
}

/// Closed-form deflection of a beam under axis loads.
struct Beam {
    loads: [AxisLoad; MAX_LOADS],
    len: usize,
    inv_ei: f64,
    support: Support,
    w0: f64,
    slope: f64,
}

impl Beam {
    fn new(loads: [AxisLoad; MAX_LOADS], len: usize, ei: f64, support: Support) -> Self {
        let mut b = Self {
            loads,
            len,
            inv_ei: 1.0 / ei,
            support,
            w0: 0.0,
            slope: 0.0,
        };
        if let Support::Pinned { xa } = support {
            b.w0 = b.w(0.0);
            b.slope = (b.w(xa) - b.w0) / xa;
        }
        b
    }

    /// Particular solution w with w″ = M/EI.
    fn w(&self, x: f64) -> f64 {
        let mut s = 0.0;
        for l in &self.loads[..self.len] {
            let d = (l.x - x).max(0.0);
            s += l.f * d * d * d / 6.0 + l.c * d * d / 2.0;
        }
        s * self.inv_ei
    }

    fn dw(&self, x: f64) -> f64 {
        let mut s = 0.0;
        for l in &self.loads[..self.len] {
            let d = (l.x - x).max(0.0);
            s += l.f * d * d / 2.0 + l.c * d;
        }
        -s * self.inv_ei
    }

    /// Deflection v and slope v′ at abscissa x.
    fn deflection(&self, x: f64) -> (f64, f64) {
        match self.support {
            Support::Pinned { .. } => (
                self.w(x) - self.w0 - self.slope * x,
                self.dw(x) - self.slope,
            ),
            Support::Clamped => {
                // Each side a cantilever from x = 0; the left one seen in the mirror u = −x,
                // where a couple turns the other way and a slope changes sign.
                let side = if x < 0.0 { -1.0 } else { 1.0 };
                let u = side * x;
                let (mut v, mut dv) = (0.0, 0.0);
                for l in &self.loads[..self.len] {
                    let up = side * l.x;
                    if up <= 0.0 {
                        continue;
                    }
                    let (f, c) = (l.f, side * l.c);
                    let d = (up - u).max(0.0);
                    v += f * (d * d * d - up * up * up + 3.0 * up * up * u) / 6.0
                        + c * (d * d - up * up + 2.0 * up * u) / 2.0;
                    dv += f * (up * up - d * d) / 2.0 + c * (up - d);
                }
                (v * self.inv_ei, side * dv * self.inv_ei)
            }
        }
    }

    /// Displacement of local point p: (−y·v′(x), v(x)).
    fn shift(&self, p: V2) -> V2 {
        let (v, dv) = self.deflection(p.x);
        V2::new(-p.y * dv, v)
    }
}

impl LinkBending {
    /// Checks the place and, for a link turned by a linear actuator, that the beam's two
    /// supports (O_i and the abscissa of A_i) differ.
    ///
    /// # Errors
    /// [`ArmError::InvalidEffect`].
    pub fn check_supports(&self, arm: &Arm) -> Result<()> {
        check_place(&self.label(), self.link, arm)?;
        let a = arm.links[self.link].a;
        if !arm.is_rotary(self.link) && a.x.abs() <= 1e-9 * (1.0 + a.norm()) {
            return Err(ArmError::InvalidEffect {
                effect: self.label(),
                reason: "pin A lies at x = 0 of the link, so the beam's two supports coincide"
                    .into(),
            });
        }
        Ok(())
    }
}

/// How a bent link's points move per unit force on it: `[point][load][component]`, the
/// displacement (mm, link frame) of point q ∈ (A_i, B_i, next_i, measure) under a unit force
/// (N, link frame) along x (component 0) or y (1) at load point p ∈ (O_i, A_i, B_i, next_i).
/// The field of §4 is linear in the loads, so any load case is the sum of these.
pub(crate) type BendInfluence = [[[V2; 2]; 4]; 4];

impl LinkBending {
    /// This link's [`BendInfluence`] (by superposition of [`Beam`]s with one unit load).
    pub(crate) fn influence(&self, arm: &Arm) -> BendInfluence {
        let link = &arm.links[self.link];
        let at = [V2::zeros(), link.a, link.b, link.next];
        let points = [link.a, link.b, link.next, arm.measure];
        let mut out = [[[V2::zeros(); 2]; 4]; 4];
        for (p, at_p) in at.iter().enumerate() {
            // A force (f_x, f_y) at (x_p, y_p) is a transverse force f_y and a couple −y_p·f_x.
            for (j, (f, c)) in [(0.0, -at_p.y), (1.0, 0.0)].into_iter().enumerate() {
                let mut loads = [AxisLoad::default(); MAX_LOADS];
                loads[0] = AxisLoad { x: at_p.x, f, c };
                let beam = Beam::new(loads, 1, self.ei, Support::of(arm, self.link));
                for (q, point) in points.iter().enumerate() {
                    out[q][p][j] = beam.shift(*point);
                }
            }
        }
        out
    }
}

impl Mechanism for LinkBending {
    fn label(&self) -> String {
        format!("link_bending@L{}", self.link + 1)
    }
    fn check_site(&self, arm: &Arm) -> Result<()> {
        self.check_supports(arm)
    }
    fn check(&self, arm: &Arm) -> Result<()> {
        check_param(&self.label(), "ei_n_mm2", self.ei, false)?;
        self.check_supports(arm)
    }
    fn apply(&self, ctx: &EffectContext<'_>, def: &mut Deformation) {
        let (k, arm, fr, d) = (self.link, ctx.arm, ctx.frames, ctx.delta);
        let n = arm.n();
        let link = &arm.links[k];
        let mut loads = [AxisLoad::default(); MAX_LOADS];
        let mut len = 0;
        let mut push = |p: V2, f_global: V2, couple: f64| {
            let f = fr.to_local(k, f_global);
            loads[len] = AxisLoad {
                x: p.x,
                f: f.y,
                c: -p.y * f.x + couple,
            };
            len += 1;
        };
        // The couple of a joint (a friction's, a rotary drive's torque) acts at its pin: on
        // link k at O_k, and the opposite one at O_{k+1} (this link's `next`) on it as body k
        // of joint k+1. A clamped link does not feel what acts at x = 0.
        push(V2::zeros(), d.r[k], ctx.joint_couple(k));
        if !arm.is_rotary(k) {
            push(link.a, d.f[k] * ctx.lines.e[k], 0.0);
        }
        if k + 1 < n {
            if !arm.is_rotary(k + 1) {
                push(link.b, -d.f[k + 1] * ctx.lines.e[k + 1], 0.0);
            }
            push(link.next, -d.r[k + 1], -ctx.joint_couple(k + 1));
        } else {
            push(link.next, ctx.payload, 0.0);
        }
        let beam = Beam::new(loads, len, self.ei, Support::of(arm, k));
        let s = &mut def.pin_shift[k];
        *s = PinShift {
            a: s.a + beam.shift(link.a),
            b: s.b + beam.shift(link.b),
            next: s.next + beam.shift(link.next),
            measure: s.measure + beam.shift(arm.measure),
            slope_next: s.slope_next + beam.deflection(link.next.x).1,
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn beam(loads: &[(f64, f64, f64)], support: Support) -> Beam {
        let mut l = [AxisLoad::default(); MAX_LOADS];
        for (k, &(x, f, c)) in loads.iter().enumerate() {
            l[k] = AxisLoad { x, f, c };
        }
        Beam::new(l, loads.len(), 2e9, support)
    }

    /// The clamped beam is a cantilever each way from x = 0: a tip force F at ±L moves its
    /// tip by F·L³/(3EI) and turns it by ±F·L²/(2EI); a tip couple C by C·L²/(2EI) and C·L/EI
    /// (mirrored on the left); loads on one side do not move the other.
    #[test]
    fn a_clamped_beam_is_two_cantilevers() {
        let (l, f, c, ei) = (400.0, 30.0, 5000.0, 2e9);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * (1.0 + b.abs());
        let right = beam(&[(l, f, 0.0)], Support::Clamped);
        let (v, dv) = right.deflection(l);
        assert!(close(v, f * l.powi(3) / (3.0 * ei)) && close(dv, f * l * l / (2.0 * ei)));
        assert_eq!(right.deflection(-l), (0.0, 0.0));
        let left = beam(&[(-l, f, 0.0)], Support::Clamped);
        let (v, dv) = left.deflection(-l);
        assert!(close(v, f * l.powi(3) / (3.0 * ei)) && close(dv, -f * l * l / (2.0 * ei)));
        assert_eq!(left.deflection(l), (0.0, 0.0));
        let couple = beam(&[(l, 0.0, c), (-l, 0.0, c)], Support::Clamped);
        let (v, dv) = couple.deflection(l);
        assert!(close(v, c * l * l / (2.0 * ei)) && close(dv, c * l / ei));
        // a couple C at −L: M = −C on (−L, 0), so v = −C·x²/(2EI)
        let (v, dv) = couple.deflection(-l);
        assert!(close(v, -c * l * l / (2.0 * ei)) && close(dv, c * l / ei));
        assert_eq!(couple.deflection(0.0), (0.0, 0.0));
    }

    /// EI·v″ = M on both supports: the bending moment of the loads beyond x (for x < 0 on a
    /// clamped beam, minus that of the loads before x), by a central difference of v′.
    #[test]
    fn the_deflection_solves_the_beam_equation() {
        let loads = [
            (-150.0, 12.0, 300.0),
            (-40.0, -5.0, 0.0),
            (90.0, 7.0, -800.0),
            (310.0, -3.0, 100.0),
        ];
        let ei = 2e9;
        for support in [Support::Clamped, Support::Pinned { xa: 60.0 }] {
            let b = beam(&loads, support);
            for x in [-120.0, -60.0, -10.0, 20.0, 75.0, 200.0, 305.0] {
                let h = 1e-3;
                let curvature = (b.deflection(x + h).1 - b.deflection(x - h).1) / (2.0 * h);
                let m: f64 = if x > 0.0 || matches!(support, Support::Pinned { .. }) {
                    loads
                        .iter()
                        .filter(|l| l.0 > x)
                        .map(|l| l.1 * (l.0 - x) + l.2)
                        .sum()
                } else {
                    -loads
                        .iter()
                        .filter(|l| l.0 < x)
                        .map(|l| l.1 * (l.0 - x) + l.2)
                        .sum::<f64>()
                };
                assert!(
                    (curvature * ei - m).abs() < 1e-5 * (1.0 + m.abs()),
                    "{support:?} x {x}: {} vs {m}",
                    curvature * ei
                );
            }
            let (v0, dv0) = b.deflection(0.0);
            assert_eq!(v0, 0.0);
            if let Support::Pinned { xa } = support {
                assert!(b.deflection(xa).0.abs() < 1e-15);
            } else {
                assert_eq!(dv0, 0.0);
            }
        }
    }
}
