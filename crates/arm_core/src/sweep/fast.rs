//! The block kernel of the sweep: the baseline model and the effects that only change
//! actuator lengths (`actuator_compliance`, `mount_compliance`, `actuator_play` centred or
//! taken up when unloaded), for
//! [`L`] poses at once in structure-of-arrays form, vectorised: the pose stage in packs of four
//! lanes ([`crate::lanes::F4`], one AVX2 register), the cell loops as lane loops that LLVM
//! vectorises itself.
//!
//! It computes what [`crate::Workspace::solve`] computes (docs/model.md §2–§5), rearranged:
//!
//! * **Forward kinematics** with [`sincos_deg`] (cheap trigonometry, within a few ulp; see
//!   [`crate::lanes::trig`]); every vector of link i is `R(α_i)` times a per-arm constant.
//! * **Statics** by the same tip-to-base recursion, for the self-weight case and for a unit
//!   payload mass. Forces are linear in the payload, so for a mass m the change is
//!   `ΔF = m·F_unit` and the loaded force `F_w + m·F_unit`.
//! * **Exact closure without acos/atan2.** With a rigid chassis and rigid links, the vector
//!   D_i = B_{i−1} − O_i turns with body i−1 (it is fixed for link 1), so the loaded angle is
//!   `α′_i = α_i + Δα_{i−1} + s_i·(acos c′_i − acos c_i)` with
//!   `c = (ρ² + |D|² − ℓ²)/(2ρ|D|)` (= D·R(α)a / (|D|ρ)) and `s_i` the side of the triangle.
//!   The rotation δ = acos c′ − acos c has `sin δ = −Δc·(s + c(2c + Δc)/(s + s′))` and
//!   `cos δ = c c′ + s s′` (s = √(1−c²), s′ = √(1−c′²), Δc = c′ − c = (ℓ² − ℓ′²)/(2ρ|D|) from
//!   the length change directly), written so that nothing cancels for small δ. Rotations
//!   compose as unit complex numbers kept as (sin, cos − 1), so the displacement of the
//!   measure point `Σ (R(Δα_i) − I)·g_i` has no cancellation either. The output angle needs
//!   δ itself: [`asin_small`] (series, < 1 ulp) for |sin δ| ≤ 1/16 and cos δ > 0, `atan2`
//!   otherwise. A triangle that cannot close shows as `s′² < 0` (|c′| > 1 in the scalar core).
//!
//! * **Status** (docs/model.md §7, [`crate::validity`]) in the same pass: the stroke and
//!   moment-arm checks per pose (with the geometry), the force and deflection limits per
//!   cell. The closure keeps each triangle's side by construction (`s′ ≥ 0`), so no cell of
//!   this kernel flips branch; a triangle that cannot close counts as a large deflection.
//!
//! The pose stage ([`FastArm::poses_sc_impl`], with a payload per lane), [`Turn`] and
//! [`compose`] are shared with the block kernel of `solve` (`crate::solve::fast`), which adds
//! the effects that move pins and the status of each pose.
//!
//! The results agree with `Workspace::solve` to rounding (≈ 1e-13 relative on the deflections,
//! whose magnitude is small against the positions they are differences of; the scalar core is
//! the less accurate of the two there).

// Lane loops index several `[link][lane]` arrays in step; `!(x >= t)` is meant: NaN fails.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use crate::arm::Arm;
use crate::arm::Drive;
use crate::effects::{Effect, EffectSet, Unloaded, FORCE_ZERO_N, TORQUE_ZERO_NMM};
use crate::lanes::transpose::{lanes_of_rows, Shuffles};
use crate::lanes::trig::{
    asin_small, cos_m1, sincos_deg, sincos_small, wrap_once, ASIN_SERIES_MAX,
};
pub use crate::lanes::L;
use crate::lanes::{rot4, Lane, F4, M4, W};
use crate::statics::SINGULAR_TOL;
use crate::validity::{
    self, Status, MAX_DALPHA_DEG, MAX_DEFLECTION_OF_REACH, MAX_RISE_OF_REACH, MIN_MOMENT_ARM,
};

/// Per-arm constants of the kernel, for an arm of `N` links.
#[derive(Debug, Clone)]
pub struct FastArm<const N: usize> {
    pub(crate) o1: [f64; 2],
    /// D_1 = B_0 − O_1 (global, fixed).
    pub(crate) d0: [f64; 2],
    pub(crate) a: [[f64; 2]; N],
    c: [[f64; 2]; N],
    pub(crate) next: [[f64; 2]; N],
    /// `b_i` in link i's frame.
    pub(crate) b: [[f64; 2]; N],
    pub(crate) measure: [f64; 2],
    /// ρ_i = |a_i| and |D_i| (the pin's and the base pin's distances from O_i).
    pub(crate) rho: [f64; N],
    pub(crate) dlen: [f64; N],
    /// Zero-length threshold `1e-12·(1 + ρ)` and singular threshold `1e-9·ρ` (as the core).
    len_tol: [f64; N],
    arm_tol: [f64; N],
    /// 1/(ρ|D|).
    inv_rd: [f64; N],
    /// 1/(2ρ|D|).
    pub(crate) half_inv_rd: [f64; N],
    /// Link weights and half actuator weights (N), zero without self-weight.
    w_link: [f64; N],
    w_half: [f64; N],
    /// A rotary drive's weight (N) at O_i on body i−1 (zero at linear joints and joint 1).
    w_drive: [f64; N],
    g: f64,
    /// Joint i is turned by a rotary drive: no triangle, its load a torque (N·mm), its own
    /// spring a gear (`body_c` in rad per N·mm, `play` a backlash in rad).
    pub(crate) rotary: [bool; N],
    /// Some joint is turned by a rotary drive.
    pub(crate) any_rotary: bool,
    /// Below this load a gap has no side: [`FORCE_ZERO_N`], [`TORQUE_ZERO_NMM`] at a drive.
    zero: [f64; N],
    /// Body compliance (mm/N), series mount compliance (mm/N), play (mm).
    pub(crate) body_c: [f64; N],
    mount_c: [f64; N],
    /// Body plus mount compliance: the pin-to-pin length per unit force change (mm/N).
    len_c: [f64; N],
    play: [f64; N],
    /// The part of `play` taken up by the unloaded forces: its length change is
    /// `−p·(sign F − sign F_w)` instead of `−p·sign F`.
    play_up: [f64; N],
    /// Some actuator has play (the cell loop then needs the sign of the loaded force).
    pub(crate) any_play: bool,
    /// Some play is taken up (the cell loop then needs the sign of the unloaded force too).
    pub(crate) any_up: bool,
    /// Stroke limits (mm), ±∞ when absent.
    lo: [f64; N],
    hi: [f64; N],
    /// Near-singular moment arm `MIN_MOMENT_ARM·ρ` (mm) and force limits (N, ∞ when absent).
    near_tol: [f64; N],
    fmax: [f64; N],
    /// Squared largest displacement (mm²) and largest rise (mm) of the measure point.
    move_lim2: f64,
    rise_lim: f64,
    /// The load point's rise is checked ([`validity::checks_load_rise`]).
    pub(crate) load_rise: bool,
    /// The pose stage's constants in every lane of a pack.
    k4: Packed<N>,
    /// The CPU's shuffles for the transposes in and out of a block.
    pub(crate) sh: Shuffles,
}

/// The per-arm constants of the pose stage, each in every lane of a pack ([`F4`]): an
/// operand read from memory as a whole register, where a scalar costs a broadcast
/// instruction per use and pack (AVX2 cannot fold one). The same values as the scalar
/// fields, so the same bits.
#[derive(Debug, Clone)]
struct Packed<const N: usize> {
    a: [[F4; 2]; N],
    next: [[F4; 2]; N],
    b: [[F4; 2]; N],
    c: [[F4; 2]; N],
    measure: [F4; 2],
    d0: [F4; 2],
    o1: [F4; 2],
    len_tol: [F4; N],
    arm_tol: [F4; N],
    near_tol: [F4; N],
    lo: [F4; N],
    hi: [F4; N],
    inv_rd: [F4; N],
    /// −w_link, w_half and w_half of the next actuator (zero beyond the tip), their sum
    /// w_link + w_half + w_half(next) and a drive's weight, per link.
    neg_wl: [F4; N],
    wa: [F4; N],
    wb: [F4; N],
    w_sum: [F4; N],
    w_drive: [F4; N],
}

impl<const N: usize> Packed<N> {
    /// Zeros, until the scalar fields are known.
    fn of_nothing() -> Self {
        let (z, z2) = ([F4::ZERO; N], [[F4::ZERO; 2]; N]);
        let p = [F4::ZERO; 2];
        Self {
            a: z2,
            next: z2,
            b: z2,
            c: z2,
            measure: p,
            d0: p,
            o1: p,
            len_tol: z,
            arm_tol: z,
            near_tol: z,
            lo: z,
            hi: z,
            inv_rd: z,
            neg_wl: z,
            wa: z,
            wb: z,
            w_sum: z,
            w_drive: z,
        }
    }

    fn of(k: &FastArm<N>) -> Self {
        let sp = |v: [f64; 2]| [F4::splat(v[0]), F4::splat(v[1])];
        let each = |f: &dyn Fn(usize) -> f64| std::array::from_fn(|i| F4::splat(f(i)));
        let wb = |i: usize| if i + 1 < N { k.w_half[i + 1] } else { 0.0 };
        Self {
            a: k.a.map(sp),
            next: k.next.map(sp),
            b: k.b.map(sp),
            c: k.c.map(sp),
            measure: sp(k.measure),
            d0: sp(k.d0),
            o1: sp(k.o1),
            len_tol: each(&|i| k.len_tol[i]),
            arm_tol: each(&|i| k.arm_tol[i]),
            near_tol: each(&|i| k.near_tol[i]),
            lo: each(&|i| k.lo[i]),
            hi: each(&|i| k.hi[i]),
            inv_rd: each(&|i| k.inv_rd[i]),
            neg_wl: each(&|i| -k.w_link[i]),
            wa: each(&|i| k.w_half[i]),
            wb: each(&|i| wb(i)),
            w_sum: each(&|i| k.w_link[i] + k.w_half[i] + wb(i)),
            w_drive: each(&|i| k.w_drive[i]),
        }
    }
}

fn p2(v: crate::V2) -> [f64; 2] {
    [v.x, v.y]
}

impl<const N: usize> FastArm<N> {
    /// The kernel's constants, or `None` when an effect is not one of a drive's own spring
    /// and gap (length-only at an actuator, a turn only at a rotary drive), `arm.n() != N`,
    /// or a rotary drive has an angle range (its loaded angle is checked per cell by the
    /// per-cell path, from the degrees of the grid).
    pub fn new(arm: &Arm, effects: &EffectSet, self_weight: bool) -> Option<Self> {
        let length_only = effects.effects().iter().all(|e| {
            matches!(
                e,
                Effect::ActuatorCompliance(_)
                    | Effect::MountCompliance(_)
                    | Effect::ActuatorPlay(_)
                    | Effect::DriveCompliance(_)
                    | Effect::DriveBacklash(_)
            )
        });
        let ranged = arm.drives.iter().any(|d| {
            d.rotary()
                .is_some_and(|r| r.min_angle.is_some() || r.max_angle.is_some())
        });
        if !length_only || ranged {
            return None;
        }
        Self::with_lengths(arm, effects, self_weight)
    }

    /// The kernel's constants with the effects of `effects` on the drives' own springs and
    /// gaps (the others are left to the caller: the solve kernel adds them), or `None` when
    /// `arm.n() != N`. A rotary drive's joint has no triangle: its `len` is NaN, its `e` zero
    /// and its unit load's moment 1 (docs/model.md §10).
    pub(crate) fn with_lengths(arm: &Arm, effects: &EffectSet, self_weight: bool) -> Option<Self> {
        if arm.n() != N {
            return None;
        }
        let z = [0.0; N];
        let z2 = [[0.0; 2]; N];
        let mut k = Self {
            o1: p2(arm.o1),
            d0: p2(arm.b0 - arm.o1),
            a: z2,
            c: z2,
            next: z2,
            b: z2,
            measure: p2(arm.measure),
            rho: z,
            dlen: z,
            len_tol: z,
            arm_tol: z,
            inv_rd: z,
            half_inv_rd: z,
            w_link: z,
            w_half: z,
            w_drive: z,
            g: arm.g,
            rotary: std::array::from_fn(|i| arm.is_rotary(i)),
            any_rotary: arm.any_rotary(),
            zero: [FORCE_ZERO_N; N],
            body_c: z,
            mount_c: z,
            len_c: z,
            play: z,
            play_up: z,
            any_play: false,
            any_up: false,
            lo: z,
            hi: z,
            near_tol: z,
            fmax: z,
            move_lim2: 0.0,
            rise_lim: 0.0,
            load_rise: validity::checks_load_rise(arm, effects),
            k4: Packed::of_nothing(),
            sh: Shuffles::detect(),
        };
        let reach = validity::reach(arm);
        k.move_lim2 = (MAX_DEFLECTION_OF_REACH * reach).powi(2);
        k.rise_lim = MAX_RISE_OF_REACH * reach;
        for i in 0..N {
            let link = &arm.links[i];
            k.c[i] = p2(link.c);
            k.next[i] = p2(link.next);
            if let Drive::Rotary(d) = &arm.drives[i] {
                // No triangle: unit distances keep the unused constants finite.
                (k.rho[i], k.dlen[i], k.inv_rd[i], k.half_inv_rd[i]) = (1.0, 1.0, 1.0, 0.5);
                if self_weight {
                    k.w_link[i] = link.mass_kg * arm.g;
                    if i > 0 {
                        k.w_drive[i] = d.mass_kg * arm.g;
                    }
                }
                k.body_c[i] = 1.0 / d.stiffness;
                (k.lo[i], k.hi[i]) = (f64::NEG_INFINITY, f64::INFINITY);
                k.fmax[i] = d.max_torque.unwrap_or(f64::INFINITY);
                k.zero[i] = TORQUE_ZERO_NMM;
                if i + 1 < N && !arm.is_rotary(i + 1) {
                    k.b[i] = p2(link.b);
                }
                continue;
            }
            let act = arm.actuator(i)?;
            k.a[i] = p2(link.a);
            if i + 1 < N && !arm.is_rotary(i + 1) {
                k.b[i] = p2(link.b);
            }
            let rho = link.a.norm();
            let dn = if i == 0 {
                (arm.b0 - arm.o1).norm()
            } else {
                (arm.links[i - 1].b - arm.links[i - 1].next).norm()
            };
            k.rho[i] = rho;
            k.dlen[i] = dn;
            k.len_tol[i] = 1e-12 * (1.0 + rho);
            k.arm_tol[i] = SINGULAR_TOL * rho;
            k.inv_rd[i] = 1.0 / (rho * dn);
            k.half_inv_rd[i] = 0.5 / (rho * dn);
            if self_weight {
                k.w_link[i] = link.mass_kg * arm.g;
                k.w_half[i] = 0.5 * act.mass_kg * arm.g;
            }
            k.body_c[i] = 1.0 / act.stiffness;
            k.lo[i] = act.min_length.unwrap_or(f64::NEG_INFINITY);
            k.hi[i] = act.max_length.unwrap_or(f64::INFINITY);
            k.near_tol[i] = MIN_MOMENT_ARM * rho;
            k.fmax[i] = act.max_force.unwrap_or(f64::INFINITY);
        }
        for e in effects.effects() {
            match e {
                Effect::ActuatorCompliance(x) => k.body_c[x.actuator] = 1.0 / x.stiffness,
                Effect::MountCompliance(x) => k.mount_c[x.actuator] += 1.0 / x.stiffness,
                Effect::ActuatorPlay(x) => {
                    k.play[x.actuator] += x.play;
                    if x.unloaded == Unloaded::TakenUp {
                        k.play_up[x.actuator] += x.play;
                    }
                }
                Effect::DriveCompliance(x) => k.body_c[x.joint] = 1.0 / x.stiffness,
                Effect::DriveBacklash(x) => {
                    let b = x.backlash_deg.to_radians();
                    k.play[x.joint] += b;
                    if x.unloaded == Unloaded::TakenUp {
                        k.play_up[x.joint] += b;
                    }
                }
                _ => {}
            }
        }
        for i in 0..N {
            k.len_c[i] = k.body_c[i] + k.mount_c[i];
        }
        k.any_play = k.play.iter().any(|&p| p != 0.0);
        k.any_up = k.play_up.iter().any(|&p| p != 0.0);
        k.k4 = Packed::of(&k);
        Some(k)
    }
}

/// Per-pose results of a block, structure of arrays (`[link][lane]`).
#[derive(Debug, Clone)]
pub struct PoseBlock<const N: usize> {
    /// Unloaded pin-to-pin lengths ℓ_i (mm).
    pub len: [[f64; L]; N],
    /// cos and |sin| of the angle at O_i between D_i and A_i − O_i.
    pub(crate) c: [[f64; L]; N],
    pub(crate) s: [[f64; L]; N],
    /// Side of the triangle (±1).
    pub(crate) side: [[f64; L]; N],
    /// Forces (N) of the self-weight case and of the payload (per kg of a unit payload mass
    /// for the sweep, for each lane's own payload for the solve).
    pub(crate) fw: [[f64; L]; N],
    pub(crate) fu: [[f64; L]; N],
    /// Joint reactions R_i (N, global) of the same two cases.
    pub(crate) rw: [[[f64; L]; N]; 2],
    pub(crate) ru: [[[f64; L]; N]; 2],
    /// Unit vector e_i of actuator i (global) and D_i = B_{i−1} − O_i (global).
    pub(crate) e: [[[f64; L]; N]; 2],
    pub(crate) d: [[[f64; L]; N]; 2],
    /// Global levers whose rotation moves the measure point: R(α_i)·next_i, last R(α_n)·m.
    pub(crate) gx: [[f64; L]; N],
    pub(crate) gy: [[f64; L]; N],
    /// R(α_n)·(next_n − m): from the measure point to the load point (global), the lever of
    /// [`validity::load_dy`].
    pub(crate) lx: [f64; L],
    pub(crate) ly: [f64; L],
    /// The pose is singular (an actuator through its joint, or coincident pins).
    pub singular: [bool; L],
    /// Some actuator's moment arm below [`crate::validity::MIN_MOMENT_ARM`] of |A_i − O_i|.
    pub near_singular: [bool; L],
    /// Some unloaded length outside its stroke.
    pub out_of_stroke: [bool; L],
    /// Within every stroke limit (and not singular).
    pub reachable: [bool; L],
    /// The pose's own status: out of stroke, near singular, else ok (code).
    pub code: [u8; L],
    /// Unloaded load point (mm).
    pub ex: [f64; L],
    /// Unloaded load point (mm).
    pub ey: [f64; L],
}

impl<const N: usize> PoseBlock<N> {
    /// Zeroed block.
    pub fn new() -> Self {
        let z = [[0.0; L]; N];
        Self {
            len: z,
            c: z,
            s: z,
            side: z,
            fw: z,
            fu: z,
            rw: [z; 2],
            ru: [z; 2],
            e: [z; 2],
            d: [z; 2],
            gx: z,
            gy: z,
            lx: [0.0; L],
            ly: [0.0; L],
            singular: [false; L],
            near_singular: [false; L],
            out_of_stroke: [false; L],
            reachable: [false; L],
            code: [0; L],
            ex: [0.0; L],
            ey: [0.0; L],
        }
    }
}

/// Per-cell results of a block for one payload mass (`[link][lane]`).
#[derive(Debug, Clone)]
pub struct CellBlock<const N: usize> {
    /// Loaded actuator forces (N).
    pub force: [[f64; L]; N],
    /// Measure point displacement (mm).
    pub dx: [f64; L],
    /// Measure point displacement (mm).
    pub dy: [f64; L],
    /// Change of absolute link angles (deg).
    pub dalpha: [[f64; L]; N],
    /// Actuator body length change (mm).
    pub dl: [[f64; L]; N],
    /// The cell solved and within every limit (status ok).
    pub ok: [bool; L],
    /// The status code ([`Status`]).
    pub status: [u8; L],
}

impl<const N: usize> CellBlock<N> {
    /// Sets every field of the lanes that did not solve to NaN (lane loops, vectorised;
    /// nothing to do in the usual case that every lane solved).
    #[inline]
    pub fn nan_failed(&mut self) {
        if self.ok.iter().all(|&o| o) {
            return;
        }
        let nan = |x: &mut f64, good: bool| *x = if good { *x } else { f64::NAN };
        for k in 0..L {
            let good = self.ok[k];
            for i in 0..N {
                nan(&mut self.force[i][k], good);
                nan(&mut self.dalpha[i][k], good);
                nan(&mut self.dl[i][k], good);
            }
            nan(&mut self.dx[k], good);
            nan(&mut self.dy[k], good);
        }
    }

    /// Zeroed block.
    pub fn new() -> Self {
        let z = [[0.0; L]; N];
        Self {
            force: z,
            dx: [0.0; L],
            dy: [0.0; L],
            dalpha: z,
            dl: z,
            ok: [false; L],
            status: [0; L],
        }
    }
}

/// The turn δ = acos c′ − acos c of an actuator triangle whose cosine at O_i changes by
/// `dc` from `c` (|sin| `s`), as (sin δ, cos δ, cos δ − 1), written so that nothing cancels
/// for small δ (see the module documentation). `closes` is false where |c + dc| > 1.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Turn<T: Lane> {
    pub(crate) closes: T::Mask,
    pub(crate) sin: T,
    pub(crate) cos: T,
    pub(crate) cos_m1: T,
}

impl<T: Lane> Turn<T> {
    #[inline(always)]
    pub(crate) fn of(c: T, s: T, dc: T) -> Self {
        let t = c.mul_add(T::splat(2.0), dc);
        let s2 = s.mul_add(s, -(dc * t));
        let s1 = s2.max(T::splat(0.0)).sqrt();
        let cosd = c.mul_add(c + dc, s * s1);
        // One division for 1/(s + s′) and 1/(1 + |cos δ|) (≥ 1, used where cos δ > 0).
        let den = cosd.abs() + 1.0;
        let q = T::splat(1.0) / ((s + s1) * den);
        let sind = -dc * (c * t).mul_add(den * q, s);
        let cos_m1 = T::select(cosd.gt(0.0), -sind * sind * ((s + s1) * q), cosd - 1.0);
        Self {
            closes: s2.ge(0.0),
            sin: sind,
            cos: cosd,
            cos_m1,
        }
    }
}

/// Sines and cosines ([`sincos_deg`]) of a block's `count` rows of `N` angles (deg), as
/// `[link][lane]` (see [`lanes_of_rows`]).
#[inline(always)]
pub(crate) fn block_trig<const N: usize>(
    sh: Shuffles,
    alpha_deg: &[f64],
    count: usize,
) -> ([[f64; L]; N], [[f64; L]; N]) {
    let x = lanes_of_rows::<N>(sh, alpha_deg, count);
    let (mut sn, mut cs) = ([[0.0; L]; N], [[0.0; L]; N]);
    for i in 0..N {
        sincos_deg(&x[i], &mut sn[i], &mut cs[i]);
    }
    (sn, cs)
}

/// Rotation (sin a, cos a − 1) followed by (sin b, cos b − 1): (sin(a+b), cos(a+b) − 1).
#[inline(always)]
pub(crate) fn compose<T: Lane>(sa: T, ca: T, sb: T, cb: T) -> (T, T) {
    (
        sa + sb + sa.mul_add(cb, ca * sb),
        ca + cb + ca.mul_add(cb, -(sa * sb)),
    )
}

/// `sign(f)`, 0 below `z` (the scalar core's `sign_above`), branch-free.
#[inline(always)]
pub(crate) fn sign_above<T: Lane>(f: T, z: f64) -> T {
    let (one, zero) = (T::splat(1.0), T::splat(0.0));
    T::select(f.ge(z), one, zero) - T::select(f.le(-z), one, zero)
}

/// `R(s, c)·v`.
#[inline(always)]
pub(crate) fn rot<T: Lane>(s: T, c: T, v: [T; 2]) -> (T, T) {
    (c.mul_add(v[0], -(s * v[1])), s.mul_add(v[0], c * v[1]))
}

impl<const N: usize> FastArm<N> {
    /// The body of [`Self::poses`], inlined into each instruction-set variant.
    #[inline(always)]
    fn poses_impl(&self, alpha_deg: &[f64], count: usize, out: &mut PoseBlock<N>) {
        let (sn, cs) = block_trig::<N>(self.sh, alpha_deg, count);
        self.poses_sc_impl(&sn, &cs, &self.unit_payload(), out);
    }

    /// The payload of a unit mass, (0, −g) N, in every lane.
    #[inline(always)]
    fn unit_payload(&self) -> [[f64; L]; 2] {
        [[0.0; L], [-self.g; L]]
    }

    /// The body of [`Self::poses_trig`]: everything after the sines and cosines, with the
    /// payload force `pay` (N, global, `[x or y][lane]`) at the load point. The lanes go in
    /// packs of four ([`F4`]), each pack link by link from the tip with its state in registers.
    #[inline(always)]
    pub(crate) fn poses_sc_impl(
        &self,
        sn: &[[f64; L]; N],
        cs: &[[f64; L]; N],
        pay: &[[f64; L]; 2],
        out: &mut PoseBlock<N>,
    ) {
        // One branch per block on the arm's kinds of drive, none per link in the packs: an
        // arm of linear actuators only runs the code without the rotary drives' cases.
        if self.any_rotary {
            for at in (0..L).step_by(W) {
                self.poses_pack::<true>(at, sn, cs, pay, out);
            }
        } else {
            for at in (0..L).step_by(W) {
                self.poses_pack::<false>(at, sn, cs, pay, out);
            }
        }
    }

    /// [`Self::poses_sc_impl`] for lanes `at..at + 4`; `ROT`: some joint is turned by a
    /// rotary drive (else `self.rotary` is all false and is not read).
    #[inline(always)]
    fn poses_pack<const ROT: bool>(
        &self,
        at: usize,
        sn: &[[f64; L]; N],
        cs: &[[f64; L]; N],
        pay: &[[f64; L]; 2],
        pb: &mut PoseBlock<N>,
    ) {
        let this = self;
        let ld = |a: &[f64; L]| F4::load(a, at);
        // First the geometry of every link (independent of each other, so that the square
        // roots and divisions of all links overlap), then the statics from the tip, which
        // need the actuator line of link i+1.
        let mut singular = M4::FALSE;
        let mut near = M4::FALSE;
        let mut reach = M4::TRUE;
        let (mut px, mut py) = (F4::ZERO, F4::ZERO);
        // Per link: R(α_i)·a_i, R(α_i)·next_i, R(α_i)·b_i, R(α_i)·c_i (x), e_i and 1/h_i.
        let mut rax = [F4::ZERO; N];
        let mut ray = [F4::ZERO; N];
        let mut rnx = [F4::ZERO; N];
        let mut rny = [F4::ZERO; N];
        let mut rbx = [F4::ZERO; N];
        let mut rby = [F4::ZERO; N];
        let mut rcx = [F4::ZERO; N];
        let mut e0 = [F4::ZERO; N];
        let mut e1 = [F4::ZERO; N];
        let mut inv_h = [F4::ZERO; N];
        let k4 = &this.k4;
        for i in 0..N {
            let (s, c) = (ld(&sn[i]), ld(&cs[i]));
            (rax[i], ray[i]) = rot4(s, c, &k4.a[i]);
            (rnx[i], rny[i]) = rot4(s, c, &k4.next[i]);
            (rbx[i], rby[i]) = rot4(s, c, &k4.b[i]);
            rcx[i] = c.mul_add(k4.c[i][0], -(s * k4.c[i][1]));
        }
        for i in 0..N {
            if ROT && this.rotary[i] {
                // A drive's torque is a couple: no line (e = 0), unit moment, no length.
                inv_h[i] = F4::splat(1.0);
                let nan = F4::splat(f64::NAN);
                for c in 0..2 {
                    F4::ZERO.store(&mut pb.e[c][i], at);
                    F4::ZERO.store(&mut pb.d[c][i], at);
                }
                nan.store(&mut pb.len[i], at);
                F4::ZERO.store(&mut pb.c[i], at);
                F4::ZERO.store(&mut pb.s[i], at);
                F4::splat(1.0).store(&mut pb.side[i], at);
            }
            let (gx, gy) = if i + 1 < N {
                (rnx[i], rny[i])
            } else {
                rot4(ld(&sn[i]), ld(&cs[i]), &k4.measure)
            };
            gx.store(&mut pb.gx[i], at);
            gy.store(&mut pb.gy[i], at);
            if i + 1 == N {
                (rnx[i] - gx).store(&mut pb.lx, at);
                (rny[i] - gy).store(&mut pb.ly, at);
            }
            px = px + rnx[i];
            py = py + rny[i];
            if ROT && this.rotary[i] {
                continue;
            }
            // D_i = B_{i−1} − O_i: fixed on the chassis, else R(α_{i−1})·(b − next)_{i−1}.
            let (dx, dy) = if i > 0 {
                (rbx[i - 1] - rnx[i - 1], rby[i - 1] - rny[i - 1])
            } else {
                (k4.d0[0], k4.d0[1])
            };
            let (ax, ay) = (rax[i], ray[i]);
            let (vx, vy) = (ax - dx, ay - dy);
            let l2 = vx.mul_add(vx, vy * vy);
            let l = l2.sqrt();
            // h = (A − O) × e = hv / ℓ. One division, which does not wait for the square
            // root, gives both 1/ℓ = ℓ·hv/(ℓ²·hv) and 1/h = ℓ·ℓ²/(ℓ²·hv).
            let hv = ax.mul_add(vy, -(ay * vx));
            let q = 1.0 / (l2 * hv);
            let inv_l = l * (hv * q);
            inv_h[i] = l * (l2 * q);
            (e0[i], e1[i]) = (vx * inv_l, vy * inv_l);
            // `!(x > t)`: NaN counts as singular, as in the scalar core.
            let habs = hv.abs();
            singular = singular | !l.gt(k4.len_tol[i]) | !habs.ge(k4.arm_tol[i] * l);
            near = near | !habs.ge(k4.near_tol[i] * l);
            reach = reach & l.ge(k4.lo[i]) & l.le(k4.hi[i]);
            e0[i].store(&mut pb.e[0][i], at);
            e1[i].store(&mut pb.e[1][i], at);
            dx.store(&mut pb.d[0][i], at);
            dy.store(&mut pb.d[1][i], at);
            l.store(&mut pb.len[i], at);
            let sg = dx.mul_add(ay, -(dy * ax)) * k4.inv_rd[i];
            (dx.mul_add(ax, dy * ay) * k4.inv_rd[i]).store(&mut pb.c[i], at);
            sg.abs().store(&mut pb.s[i], at);
            sg.sign_one().store(&mut pb.side[i], at);
        }
        // Statics, link by link from the tip: actuator i+1's force −F·e at B_i (a drive i+1's
        // weight at O_{i+1} and its couple −T instead) and the distal reaction −R at O_{i+1},
        // for the self-weight case (w) and the payload (u). Beyond the tip: no actuator, and a
        // "reaction" −P so that −R_{n+1} is the payload P at the load point. A drive i's
        // torque is `T_i = −t`: its e_i is zero and its moment `inv_h` one.
        let (mut e0n, mut e1n) = (F4::ZERO, F4::ZERO);
        let (mut fw1, mut rwx1, mut rwy1) = (F4::ZERO, F4::ZERO, F4::ZERO);
        let mut fu1 = F4::ZERO;
        let mut rux1 = F4::ZERO - ld(&pay[0]);
        let mut ruy1 = F4::ZERO - ld(&pay[1]);
        for i in (0..N).rev() {
            // Weights at C_i, A_i and B_i; moments about O_i. B_i is unused for the last link.
            let (ax, nx, ny) = (rax[i], rnx[i], rny[i]);
            let (bx, by) = if i + 1 < N {
                (rbx[i], rby[i])
            } else {
                (F4::ZERO, F4::ZERO)
            };
            let (fx, fy) = (-fw1 * e0n, -fw1 * e1n);
            let qx = fx - rwx1;
            let mut qy = fy - rwy1 - k4.w_sum[i];
            let mut t = k4.neg_wl[i] * rcx[i] - k4.wa[i] * ax - k4.wb[i] * bx
                + bx.mul_add(fy, -(by * fx))
                - nx.mul_add(rwy1, -(ny * rwx1));
            let (gx, gy) = (-fu1 * e0n, -fu1 * e1n);
            let qux = gx - rux1;
            let quy = gy - ruy1;
            let mut tu = bx.mul_add(gy, -(by * gx)) - nx.mul_add(ruy1, -(ny * rux1));
            if ROT && i + 1 < N && this.rotary[i + 1] {
                // Drive i+1's housing: its weight at O_{i+1} and the couple −T_{i+1}.
                let wo = k4.w_drive[i + 1];
                qy = qy - wo;
                t = t - wo * nx - fw1;
                tu = tu - fu1;
            }
            let f = -t * inv_h[i];
            let fu = -tu * inv_h[i];
            fw1 = f;
            rwx1 = (-f).mul_add(e0[i], -qx);
            rwy1 = (-f).mul_add(e1[i], -qy);
            fu1 = fu;
            rux1 = (-fu).mul_add(e0[i], -qux);
            ruy1 = (-fu).mul_add(e1[i], -quy);
            e0n = e0[i];
            e1n = e1[i];
            f.store(&mut pb.fw[i], at);
            fu.store(&mut pb.fu[i], at);
            rwx1.store(&mut pb.rw[0][i], at);
            rwy1.store(&mut pb.rw[1][i], at);
            rux1.store(&mut pb.ru[0][i], at);
            ruy1.store(&mut pb.ru[1][i], at);
        }
        (px + k4.o1[0]).store(&mut pb.ex, at);
        (py + k4.o1[1]).store(&mut pb.ey, at);
        for j in 0..W {
            let k = at + j;
            let (singular, near, reach) = (singular.get(j), near.get(j), reach.get(j));
            pb.singular[k] = singular;
            pb.near_singular[k] = near;
            pb.out_of_stroke[k] = !reach;
            pb.reachable[k] = reach & !singular;
            pb.code[k] = if !reach {
                Status::OutOfStroke.code()
            } else if near | singular {
                Status::NearSingular.code()
            } else {
                Status::Ok.code()
            };
        }
    }

    /// [`Self::cells`] for every play setting.
    #[inline(always)]
    fn cells_any(&self, pb: &PoseBlock<N>, m: f64, cb: &mut CellBlock<N>) {
        // One branch per block on the play settings and the arm's kinds of drive, none per
        // joint in the lane loops.
        match (self.any_rotary, self.any_play, self.any_up) {
            (true, _, true) => self.cells_impl::<true, true, true>(pb, m, cb),
            (true, true, false) => self.cells_impl::<true, true, false>(pb, m, cb),
            (true, false, false) => self.cells_impl::<true, false, false>(pb, m, cb),
            (false, _, true) => self.cells_impl::<false, true, true>(pb, m, cb),
            (false, true, false) => self.cells_impl::<false, true, false>(pb, m, cb),
            (false, false, false) => self.cells_impl::<false, false, false>(pb, m, cb),
        }
    }

    /// The pin-to-pin length change of actuator `i` under the force change `du` (loaded
    /// force `f`, unloaded `fw`): compliance and play (`UP`: some play is taken up). At a
    /// rotary drive the same for its gear: the turn Δq_i (rad) under the torque change `du`
    /// (N·mm), the gear's compliance and backlash.
    #[inline(always)]
    pub(crate) fn dlen<const PLAY: bool, const UP: bool, T: Lane>(
        &self,
        i: usize,
        du: T,
        f: T,
        fw: T,
    ) -> T {
        let elastic = -du * self.len_c[i];
        let z = self.zero[i];
        if UP {
            elastic - sign_above(f, z) * self.play[i] + sign_above(fw, z) * self.play_up[i]
        } else if PLAY {
            elastic - sign_above(f, z) * self.play[i]
        } else {
            elastic
        }
    }

    /// [`Self::cells`], without the play terms when `PLAY` is false, without those of a
    /// taken-up play when `UP` is false and without the rotary drives' case when `ROT` is
    /// false (an arm of linear actuators only).
    #[inline(always)]
    fn cells_impl<const ROT: bool, const PLAY: bool, const UP: bool>(
        &self,
        pb: &PoseBlock<N>,
        m: f64,
        cb: &mut CellBlock<N>,
    ) {
        let mut sr = [0.0; L]; // sin Δα_i
        let mut cm = [0.0; L]; // cos Δα_i − 1
        let mut dx = [0.0; L];
        let mut dy = [0.0; L];
        let mut fail = pb.singular;
        let mut over = [false; L];
        let mut dth = [[0.0; L]; N];
        let mut far = false;
        for i in 0..N {
            let (bc, hr, fmax) = (self.body_c[i], self.half_inv_rd[i], self.fmax[i]);
            if ROT && self.rotary[i] {
                // Link i turns against body i−1 by its gear's Δq_i: no triangle. A drive's
                // torque and its (absent) body length are not cell fields: NaN.
                let (mut q, mut f) = ([0.0; L], [0.0; L]);
                for k in 0..L {
                    let du = m * pb.fu[i][k];
                    let fw = pb.fw[i][k];
                    f[k] = fw + du;
                    q[k] = self.dlen::<PLAY, UP, f64>(i, du, f[k], fw);
                }
                let (mut qs, mut qc) = ([0.0; L], [0.0; L]);
                sincos_small(&q, &mut qs, &mut qc);
                for k in 0..L {
                    let (ns, nc) = compose(sr[k], cm[k], qs[k], cos_m1(qs[k], qc[k]));
                    sr[k] = ns;
                    cm[k] = nc;
                    dx[k] += nc * pb.gx[i][k] - ns * pb.gy[i][k];
                    dy[k] += ns * pb.gx[i][k] + nc * pb.gy[i][k];
                    dth[i][k] = q[k];
                    over[k] |= f[k].abs() > fmax;
                    cb.force[i][k] = f64::NAN;
                    cb.dl[i][k] = f64::NAN;
                }
                continue;
            }
            for k in 0..L {
                let du = m * pb.fu[i][k];
                let fw = pb.fw[i][k];
                let f = fw + du;
                let body = -du * bc;
                let dlen = self.dlen::<PLAY, UP, f64>(i, du, f, fw);
                let l = pb.len[i][k];
                let dc = -dlen * (2.0 * l + dlen) * hr;
                let (c, s, side) = (pb.c[i][k], pb.s[i][k], pb.side[i][k]);
                let tr = Turn::of(c, s, dc);
                fail[k] |= !tr.closes;
                let (sind, cosd) = (tr.sin, tr.cos);
                let (rs, rc) = (side * sind, tr.cos_m1);
                let (ns, nc) = compose(sr[k], cm[k], rs, rc);
                sr[k] = ns;
                cm[k] = nc;
                dx[k] += nc * pb.gx[i][k] - ns * pb.gy[i][k];
                dy[k] += ns * pb.gx[i][k] + nc * pb.gy[i][k];
                far |= !(sind.abs() <= ASIN_SERIES_MAX && cosd > 0.0);
                dth[i][k] = side * asin_small(sind);
                over[k] |= f.abs() > fmax;
                cb.force[i][k] = f;
                cb.dl[i][k] = body;
            }
        }
        if far {
            self.fix_large_turns(pb, m, &mut dth);
        }
        let deg = 180.0f64 / std::f64::consts::PI;
        let mut da = [0.0; L];
        let mut big = [false; L];
        for i in 0..N {
            for k in 0..L {
                let a = da[k] + dth[i][k];
                // The loaded angle nearest the unloaded one.
                let a = wrap_once(a);
                da[k] = a;
                cb.dalpha[i][k] = a * deg;
                big[k] |= !((a * deg).abs() <= MAX_DALPHA_DEG);
            }
        }
        cb.dx = dx;
        cb.dy = dy;
        // The status (validity::classify's order): the pose's own, else over force, else
        // large deflection (a triangle that cannot close included).
        // Selects, not branches: the lane loop stays vectorised.
        let down = m * self.g > 0.0;
        let (large, over_code) = (Status::LargeDeflection.code(), Status::OverForce.code());
        for k in 0..L {
            let moved = !(dx[k] * dx[k] + dy[k] * dy[k] <= self.move_lim2);
            let rise = down & (dy[k] > self.rise_lim);
            // the load point rising (validity::MAX_LOAD_RISE_MM): not an elastic answer
            let lift = self.load_rise
                & down
                & (validity::load_dy(dy[k], sr[k], cm[k], pb.lx[k], pb.ly[k])
                    > validity::MAX_LOAD_RISE_MM);
            let cell = if fail[k] | big[k] | moved | rise | lift {
                large
            } else {
                0
            };
            let cell = if over[k] & !fail[k] { over_code } else { cell };
            let code = if pb.code[k] != 0 { pb.code[k] } else { cell };
            cb.status[k] = code;
            cb.ok[k] = code == 0;
        }
    }

    /// Unloaded geometry and statics of up to `L` poses: `alpha_deg` holds `count` rows of
    /// `N` angles (deg); missing lanes repeat the last pose and are to be ignored. Compiled
    /// for the best instruction set of this CPU, as [`Self::cells`].
    pub fn poses(&self, simd: pulp::Arch, alpha_deg: &[f64], count: usize, out: &mut PoseBlock<N>) {
        struct Op<'a, const N: usize>(&'a FastArm<N>, &'a [f64], usize, &'a mut PoseBlock<N>);
        impl<const N: usize> pulp::WithSimd for Op<'_, N> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: pulp::Simd>(self, _simd: S) {
                self.0.poses_impl(self.1, self.2, self.3);
            }
        }
        simd.dispatch(Op(self, alpha_deg, count, out));
    }

    /// [`Self::poses`] from the sines and cosines of the angles (`[link][lane]`, as
    /// [`crate::lanes::trig::sincos_deg`] gives them, so the results are the same bits),
    /// e.g. looked up in tables of a grid's axes; every lane is a pose.
    pub fn poses_trig(
        &self,
        simd: pulp::Arch,
        sn: &[[f64; L]; N],
        cs: &[[f64; L]; N],
        out: &mut PoseBlock<N>,
    ) {
        struct Op<'a, const N: usize>(
            &'a FastArm<N>,
            &'a [[f64; L]; N],
            &'a [[f64; L]; N],
            &'a mut PoseBlock<N>,
        );
        impl<const N: usize> pulp::WithSimd for Op<'_, N> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: pulp::Simd>(self, _simd: S) {
                self.0
                    .poses_sc_impl(self.1, self.2, &self.0.unit_payload(), self.3);
            }
        }
        simd.dispatch(Op(self, sn, cs, out));
    }

    /// Loaded minus unloaded state of the block's poses under a payload mass `m` (kg).
    ///
    /// The lane loops are inlined into `pulp`'s `#[target_feature]` wrapper for the best
    /// instruction set of this CPU (AVX-512 or AVX2 + FMA where present, else x86-64's SSE2),
    /// so LLVM vectorises them 8 or 4 wide there. Rust never contracts `a·b + c`; the fused
    /// multiply–adds asked for (`Lane::mul_add`) round once on every instruction set, so
    /// every instruction set gives the same bits.
    pub fn cells(&self, simd: pulp::Arch, pb: &PoseBlock<N>, m: f64, cb: &mut CellBlock<N>) {
        struct Op<'a, const N: usize>(&'a FastArm<N>, &'a PoseBlock<N>, f64, &'a mut CellBlock<N>);
        impl<const N: usize> pulp::WithSimd for Op<'_, N> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: pulp::Simd>(self, _simd: S) {
                self.0.cells_any(self.1, self.2, self.3);
            }
        }
        simd.dispatch(Op(self, pb, m, cb));
    }

    /// Recomputes the turn of the lanes where the series does not apply, with `atan2`.
    #[cold]
    fn fix_large_turns(&self, pb: &PoseBlock<N>, m: f64, dth: &mut [[f64; L]; N]) {
        for i in 0..N {
            if self.rotary[i] {
                continue; // a drive's turn is its own angle
            }
            for k in 0..L {
                let du = m * pb.fu[i][k];
                let fw = pb.fw[i][k];
                let f = fw + du;
                let dlen = match (self.any_play, self.any_up) {
                    (_, true) => self.dlen::<true, true, f64>(i, du, f, fw),
                    (true, false) => self.dlen::<true, false, f64>(i, du, f, fw),
                    (false, false) => self.dlen::<false, false, f64>(i, du, f, fw),
                };
                let l = pb.len[i][k];
                let dc = -dlen * (2.0 * l + dlen) * self.half_inv_rd[i];
                let (c, s) = (pb.c[i][k], pb.s[i][k]);
                let t = 2.0 * c + dc;
                let s1 = (s * s - dc * t).max(0.0).sqrt();
                let sind = -dc * (s + c * t / (s + s1));
                let cosd = c * (c + dc) + s * s1;
                if !(sind.abs() <= ASIN_SERIES_MAX && cosd > 0.0) {
                    dth[i][k] = pb.side[i][k] * sind.atan2(cosd);
                }
            }
        }
    }
}
