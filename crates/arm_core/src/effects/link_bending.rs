//! `link_bending@Li`: link i as an Euler–Bernoulli beam along its local x axis.
//!
//! Every change of force on the link, `(f_x, f_y)` at local `(x_p, y_p)`, is carried to the
//! axis as a transverse force `f_y` and a couple `C = −y_p·f_x` at `x_p`. The changes are in
//! equilibrium, so `EI·v″(x) = M(x) = Σ_{x_p > x} [f_y (x_p − x) + C]`, integrated in closed form
//! with `v(0) = 0` (joint O_i) and `v(x_A) = 0` (abscissa of A_i). A point (x, y) of the link
//! moves by `(−y·v′(x), v(x))` in the link frame.

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
/// next joint, and the friction couples of its two joints.
const MAX_LOADS: usize = 6;

/// Closed-form deflection of a beam under axis loads, supports at 0 and `xa`.
struct Beam {
    loads: [AxisLoad; MAX_LOADS],
    len: usize,
    inv_ei: f64,
    w0: f64,
    slope: f64,
}

impl Beam {
    fn new(loads: [AxisLoad; MAX_LOADS], len: usize, ei: f64, xa: f64) -> Self {
        let mut b = Self {
            loads,
            len,
            inv_ei: 1.0 / ei,
            w0: 0.0,
            slope: 0.0,
        };
        b.w0 = b.w(0.0);
        b.slope = (b.w(xa) - b.w0) / xa;
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

    /// Displacement of local point p: (−y·v′(x), v(x)).
    fn shift(&self, p: V2) -> V2 {
        let v = self.w(p.x) - self.w0 - self.slope * p.x;
        let dv = self.dw(p.x) - self.slope;
        V2::new(-p.y * dv, v)
    }
}

impl LinkBending {
    /// Checks the place and that the beam's two supports (O_i and the abscissa of A_i) differ.
    ///
    /// # Errors
    /// [`ArmError::InvalidEffect`].
    pub fn check_supports(&self, arm: &Arm) -> Result<()> {
        check_place(&self.label(), self.link, arm)?;
        let a = arm.links[self.link].a;
        if a.x.abs() <= 1e-9 * (1.0 + a.norm()) {
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
                let beam = Beam::new(loads, 1, self.ei, link.a.x);
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
        // A joint friction's couple acts at its pin: on link k at O_k, and the opposite one
        // at O_{k+1} (this link's `next`) on it as body k of joint k+1.
        push(V2::zeros(), d.r[k], ctx.couple[k]);
        push(link.a, d.f[k] * ctx.lines.e[k], 0.0);
        if k + 1 < n {
            push(link.b, -d.f[k + 1] * ctx.lines.e[k + 1], 0.0);
            push(link.next, -d.r[k + 1], -ctx.couple[k + 1]);
        } else {
            push(link.next, ctx.payload, 0.0);
        }
        let beam = Beam::new(loads, len, self.ei, link.a.x);
        let s = &mut def.pin_shift[k];
        *s = PinShift {
            a: s.a + beam.shift(link.a),
            b: s.b + beam.shift(link.b),
            next: s.next + beam.shift(link.next),
            measure: s.measure + beam.shift(arm.measure),
        };
    }
}
