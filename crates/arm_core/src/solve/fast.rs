//! The block kernel of `solve`: [`L`] poses at once in structure-of-arrays form, every
//! built-in effect, each pose with its own payload, and the status of every pose in the same
//! pass (docs/architecture.md, "Where the general path is used").
//!
//! The unloaded geometry and both load cases come from the sweep kernel's pose stage
//! ([`FastArm`], with the lane's own payload instead of a unit mass); the length-only effects
//! (compliances, play) are the sweep's too. The closure generalises the sweep's: with joint
//! clearance and link bending, body i−1's vector D_i = B_{i−1} − O_i and link i's pin a_i
//! change as well as the length, so link i turns relative to body i−1 by
//!
//! ```text
//! ∠(D_i + δ_i) − ∠D_i  +  s_i·(acos c′_i − acos c_i)  −  (∠a′_i − ∠a_i)
//! ```
//!
//! with `δ_i = R(α_{i−1})·(Δb − Δnext)_{i−1} − R(−Δα_{i−1})·u_i` (bending shifts of body
//! i−1's pins, the clearance offset u_i of joint i) and `c′_i` from the changed ρ′, |D′|, ℓ′
//! (docs/model.md §5). A base tilt Δφ is the turn of body 0. The turns are kept as rotations
//! (sin, cos − 1) and composed without cancellation; the measure point moves by
//! `Σ_i (R(Δα_i) − I)·g_i + R(α′_i)·Δnext_i + u_{i+1}` plus the tilt of O_1 about the pivot.
//!
//! A lane that does not solve (singular, or a triangle that cannot close) is solved again by
//! [`Workspace::solve`], which gives its error (or its NaN row with `nan_on_failure`), so
//! errors name the same row and actuator as the general path's.

// Lane loops index several `[link][lane]` arrays in step; `!(x >= t)` is meant: NaN fails.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

mod base;
mod bending;
mod block;
mod clearance;
mod friction;
mod group;
mod rotary;

use base::Base;
use bending::{Bending, Shifts};
use block::{Moves, SolveBlock};
use clearance::Clearance;
use friction::{Friction, Held};
use group::{Group, GROUP};
use rotary::{Ranges, Turns};

use super::batch::{write_outcome, BatchBuffers, BatchInput, BatchOutput, SequenceInput};
use super::general::{SolveOptions, Workspace};
use super::status::pose_status;
use crate::arm::{Arm, Drive};
use crate::effects::{Effect, EffectSet};
use crate::error::Result;
use crate::geometry::V2;
use crate::lanes::transpose::{lanes_of_rows, Shuffles};
use crate::lanes::transpose::{transpose_into, transpose_xy_into};
use crate::lanes::trig::{asin_small, cos_m1, wrap_once, ASIN_SERIES_MAX};
use crate::lanes::{Lane, F4, M4, W};
use crate::sweep::fast::{block_trig, compose, rot, FastArm, PoseBlock, Turn, L};
use crate::validity::{self, Checks};
use std::ops::Range;

/// Per-arm constants of the solve kernel for an arm of `N` links.
#[derive(Debug, Clone)]
pub(crate) struct SolveKernel<const N: usize> {
    fa: FastArm<N>,
    clear: Clearance<N>,
    bend: Bending<N>,
    base: Base,
    fric: Friction<N>,
    /// The rotary drives with an angle range.
    ranges: Ranges<N>,
    /// The arm's reach Σ|next_i| (validity).
    reach: f64,
    /// Load limits (N, N·mm at a rotary drive), +∞ where none.
    fmax: [f64; N],
    /// Per link i: D_i = B_{i−1} − O_i changes (joint i's clearance, body i−1 bends); link
    /// i's pin a_i moves in its frame (link i bends). Where neither, link i closes as without
    /// geometric effects.
    d_moves: [bool; N],
    a_moves: [bool; N],
}

impl<const N: usize> SolveKernel<N> {
    /// The kernel of `arm` (with `N` links) and `effects`, or `None` for another `N`.
    pub(crate) fn new(arm: &Arm, effects: &EffectSet, self_weight: bool) -> Option<Self> {
        // Every effect the kernel computes, listed without a wildcard: a new kind of the
        // catalogue does not compile until it is added here (and to the lanes).
        for e in effects.effects() {
            match e {
                Effect::ActuatorCompliance(_)
                | Effect::MountCompliance(_)
                | Effect::ActuatorPlay(_)
                | Effect::JointClearance(_)
                | Effect::LinkBending(_)
                | Effect::BaseCompliance(_) => {}
                Effect::ActuatorFriction(_) | Effect::JointFriction(_) => {}
                Effect::DriveCompliance(_)
                | Effect::DriveBacklash(_)
                | Effect::DriveFriction(_) => {}
            }
        }
        let clear = Clearance::new(effects);
        let bend = Bending::new(arm, effects);
        // A link bent under a drive's housing turns it and carries its couple, which the
        // bending influences do not: such sets take the general path.
        if (1..N).any(|i| arm.is_rotary(i) && bend.bends(i - 1)) {
            return None;
        }
        Some(Self {
            fa: FastArm::with_lengths(arm, effects, self_weight)?,
            d_moves: std::array::from_fn(|i| clear.at(i) || (i > 0 && bend.bends(i - 1))),
            a_moves: std::array::from_fn(|i| bend.bends(i)),
            clear,
            bend,
            base: Base::new(arm, effects),
            fric: Friction::new(arm, effects)?,
            ranges: Ranges::new(arm),
            reach: validity::reach(arm),
            fmax: std::array::from_fn(|i| match &arm.drives[i] {
                Drive::Linear(a) => a.max_force.unwrap_or(f64::INFINITY),
                Drive::Rotary(d) => d.max_torque.unwrap_or(f64::INFINITY),
            }),
        })
    }

    /// Solves a block of up to [`L`] poses (unloaded stage, then the closure) and writes
    /// its rows `p..p + count` of `out` and `status`: one function compiled for the best
    /// instruction set of this CPU (AVX-512, AVX2 + FMA, else x86-64's SSE2; `pulp`), every
    /// stage inlined into it.
    #[allow(clippy::too_many_arguments)]
    fn block(
        &self,
        simd: pulp::Arch,
        alpha_deg: &[f64],
        payload: &[f64],
        count: usize,
        pb: &mut PoseBlock<N>,
        sb: &mut SolveBlock<N>,
        mv: &mut Moves<N>,
        out: &mut BatchOutput<'_>,
        status: &mut [u8],
        p: usize,
        held: Option<&mut Held<N>>,
    ) {
        struct Op<'a, 'o, const N: usize> {
            k: &'a SolveKernel<N>,
            alpha_deg: &'a [f64],
            payload: &'a [f64],
            count: usize,
            pb: &'a mut PoseBlock<N>,
            sb: &'a mut SolveBlock<N>,
            mv: &'a mut Moves<N>,
            out: &'a mut BatchOutput<'o>,
            status: &'a mut [u8],
            p: usize,
            held: Option<&'a mut Held<N>>,
        }
        impl<const N: usize> pulp::WithSimd for Op<'_, '_, N> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: pulp::Simd>(self, _simd: S) {
                // Missing lanes repeat the last pose.
                let sh = self.k.fa.sh;
                let pay = lanes_of_rows::<2>(sh, self.payload, self.count);
                let trig = block_trig::<N>(sh, self.alpha_deg, self.count);
                let k = self.k;
                k.fa.poses_sc_impl(&trig.0, &trig.1, &pay, self.pb);
                if k.ranges.any {
                    k.ranges
                        .unloaded(self.alpha_deg, self.count, self.pb, &mut self.sb.q);
                }
                if k.fric.any {
                    // `solve` is a sequence of one state: a fresh memory.
                    let mut fresh = Held::new();
                    let held = self.held.unwrap_or(&mut fresh);
                    k.fric.step(self.pb, held, &k.fa.body_c, &mut self.sb.seen);
                }
                k.close_any(&trig, &pay, self.pb, self.sb, self.mv);
                let rotary = k.fa.any_rotary.then_some(&k.fa.rotary);
                write_block(
                    sh,
                    self.pb,
                    self.sb,
                    rotary,
                    self.out,
                    self.status,
                    self.p,
                    self.count,
                );
            }
        }
        simd.dispatch(Op {
            k: self,
            alpha_deg,
            payload,
            count,
            pb,
            sb,
            mv,
            out,
            status,
            p,
            held,
        });
    }

    /// [`Self::close`] for every combination of play and geometric effects.
    #[inline(always)]
    fn close_any(
        &self,
        trig: &([[f64; L]; N], [[f64; L]; N]),
        pay: &[[f64; L]; 2],
        pb: &PoseBlock<N>,
        sb: &mut SolveBlock<N>,
        mv: &mut Moves<N>,
    ) {
        let geom = self.clear.any || self.bend.any;
        match (self.fa.any_play, self.fa.any_up, geom) {
            (_, true, true) => self.close::<true, true, true>(trig, pay, pb, sb, mv),
            (_, true, false) => self.close::<true, true, false>(trig, pay, pb, sb, mv),
            (true, false, true) => self.close::<true, false, true>(trig, pay, pb, sb, mv),
            (true, false, false) => self.close::<true, false, false>(trig, pay, pb, sb, mv),
            (false, false, true) => self.close::<false, false, true>(trig, pay, pb, sb, mv),
            (false, false, false) => self.close::<false, false, false>(trig, pay, pb, sb, mv),
        }
    }

    /// The loaded pose of a block (see the module documentation); `GEOM`: some joint has
    /// clearance or some link bends. The lanes go in packs of four ([`F4`]), each pack link
    /// by link from the base with its state in registers.
    #[inline(always)]
    fn close<const PLAY: bool, const UP: bool, const GEOM: bool>(
        &self,
        trig: &([[f64; L]; N], [[f64; L]; N]),
        pay: &[[f64; L]; 2],
        pb: &PoseBlock<N>,
        sb: &mut SolveBlock<N>,
        mv: &mut Moves<N>,
    ) {
        let (sn, cs) = (&trig.0, &trig.1);
        // The base tilt (rad), its rotation (sin, cos − 1) and the displacement it gives;
        // the clearance offsets and bending shifts. Each is written by its own effect, or
        // stays zero from the scratch's making (`Moves`: not zeroed again for every block).
        if self.base.on() {
            let [phi, sr, cm, dx, dy] = &mut mv.tilt;
            self.base.tilt(pb, pay, phi, sr, cm, dx, dy);
        }
        if GEOM {
            if self.clear.any {
                self.clear.offsets(pb, &mut mv.u);
            }
            if self.bend.any {
                self.bend.shifts(pb, sn, cs, pay, &mut mv.sh);
            }
        }
        let (tilt, u, sh) = (&mv.tilt, &mv.u, &mv.sh);
        let geo = Geo { sn, cs, u, sh };
        // Not `bool::then` with a closure: a closure may be left out of line, and would then
        // be compiled for the baseline x86-64 (no AVX, no FMA) instead of this variant.
        let turns = if self.fa.any_rotary {
            Some(Turns::of::<PLAY, UP>(&self.fa, pb, &sb.seen))
        } else {
            None
        };
        for at in (0..L).step_by(W) {
            self.close_pack::<PLAY, UP, GEOM>(at, &geo, turns.as_ref(), tilt, pay, pb, sb);
        }
    }

    /// [`Self::close`] for lanes `at..at + 4`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn close_pack<const PLAY: bool, const UP: bool, const GEOM: bool>(
        &self,
        at: usize,
        geo: &Geo<'_, N>,
        turns: Option<&Turns<N>>,
        tilt: &[[f64; L]; 5],
        pay: &[[f64; L]; 2],
        pb: &PoseBlock<N>,
        sb: &mut SolveBlock<N>,
    ) {
        let ld = |a: &[f64; L]| F4::load(a, at);
        let (sn, cs, u, sh) = (geo.sn, geo.cs, geo.u, geo.sh);
        let fa = &self.fa;
        let [phi, sr, cm, dx, dy] = tilt;
        let (mut sr, mut cm) = (ld(sr), ld(cm)); // sin Δα_{i−1}, cos Δα_{i−1} − 1
        let (mut dx, mut dy) = (ld(dx), ld(dy));
        if GEOM {
            dx = dx + ld(&u[0][0]);
            dy = dy + ld(&u[1][0]);
        }
        let mut fail = M4::load(&pb.singular, at);
        let mut flip = M4::FALSE;
        let mut over = M4::FALSE;
        let mut far = M4::FALSE;
        let mut turn = [[F4::ZERO; N]; 2];
        let mut dth = [F4::ZERO; N];
        for i in 0..N {
            let du = ld(&pb.fu[i]);
            let fw = ld(&pb.fw[i]);
            let f = fw + du;
            // Link i bends (under a drive: the flange's frame; its A has no role).
            let am = GEOM && self.a_moves[i];
            // A drive's link turns by its gear's Δq_i (rad); an actuator's closes its triangle.
            let (ts, tc, tri) = if let Some(t) = turns.filter(|_| fa.rotary[i]) {
                (ld(&t.sin[i]), ld(&t.cos_m1[i]), None)
            } else {
                let hr = fa.half_inv_rd[i];
                let (rho, dl0) = (fa.rho[i], fa.dlen[i]);
                let [ax, ay] = fa.a[i];
                let seen = ld(&sb.seen[i]);
                let dlen = fa.dlen::<PLAY, UP, F4>(i, du, f, fw) + seen;
                let l = ld(&pb.len[i]);
                let (c, s, side) = (ld(&pb.c[i]), ld(&pb.s[i]), ld(&pb.side[i]));
                // The links that no geometric effect touches close as without them.
                let dm = GEOM && self.d_moves[i];
                let (mut dn, mut dn2, mut rd) = (F4::splat(dl0), F4::splat(dl0 * dl0), None);
                if dm {
                    // D′ = R(Δα_{i−1})·(D + δ): δ from body i−1's bending and joint i's offset.
                    let (ux, uy) = (ld(&u[0][i]), ld(&u[1][i]));
                    let cc = 1.0 + cm;
                    let mut ddx = -(cc * ux + sr * uy);
                    let mut ddy = sr * ux - cc * uy;
                    if i > 0 {
                        let lx = ld(&sh.b[0][i - 1]) - ld(&sh.next[0][i - 1]);
                        let ly = ld(&sh.b[1][i - 1]) - ld(&sh.next[1][i - 1]);
                        let (gx, gy) = rot(ld(&sn[i - 1]), ld(&cs[i - 1]), [lx, ly]);
                        ddx = ddx + gx;
                        ddy = ddy + gy;
                    }
                    let (vx, vy) = (ld(&pb.d[0][i]), ld(&pb.d[1][i]));
                    let (nx, ny) = (vx + ddx, vy + ddy);
                    dn2 = nx * nx + ny * ny;
                    dn = dn2.sqrt();
                    let inv = 1.0 / (dl0 * dn);
                    let rds = (vx * ddy - vy * ddx) * inv;
                    rd = Some((rds, cos_m1(rds, (dl0 * dl0 + vx * ddx + vy * ddy) * inv)));
                }
                let (mut rp, mut rp2, mut ra) = (F4::splat(rho), F4::splat(rho * rho), None);
                if am {
                    // a′ = a + Δa, in link i's frame.
                    let (sx, sy) = (ld(&sh.a[0][i]), ld(&sh.a[1][i]));
                    let (px, py) = (ax + sx, ay + sy);
                    rp2 = px * px + py * py;
                    rp = rp2.sqrt();
                    let inva = 1.0 / (rho * rp);
                    let ras = (ax * sy - ay * sx) * inva;
                    ra = Some((ras, cos_m1(ras, (rho * rho + ax * sx + ay * sy) * inva)));
                }
                let dc = if dm || am {
                    let lp = l + dlen;
                    (rp2 + dn2 - lp * lp) / (2.0 * rp * dn) - c
                } else {
                    -dlen * (2.0 * l + dlen) * hr
                };
                let tr = Turn::of(c, s, dc);
                fail = fail | !tr.closes;
                let (mut ts, mut tc) = (side * tr.sin, tr.cos_m1);
                if let Some((s, c)) = rd {
                    (ts, tc) = compose(s, c, ts, tc);
                }
                if let Some((s, c)) = ra {
                    (ts, tc) = compose(ts, tc, -s, c);
                }
                (ts, tc, Some((side * s, c, dlen, seen)))
            };
            let (ns, nc) = compose(sr, cm, ts, tc);
            if let Some((sg, c, ..)) = tri {
                // The rigid loaded triangle (docs/model.md §7) turned by the relative turn of
                // link i against body i−1 (against the fixed chassis for link 1).
                let (rs, rc) = if i == 0 { (ns, nc) } else { (ts, tc) };
                flip = flip | Lane::lt(sg * (sg * (1.0 + rc) + c * rs), 0.0);
            }
            sr = ns;
            cm = nc;
            let (gx, gy) = (ld(&pb.gx[i]), ld(&pb.gy[i]));
            dx = dx + nc.mul_add(gx, -(ns * gy));
            dy = dy + ns.mul_add(gx, nc * gy);
            if am {
                // the bent link's next pin (the measure point on the last link)
                let (qx, qy) = if i + 1 < N {
                    (ld(&sh.next[0][i]), ld(&sh.next[1][i]))
                } else {
                    (ld(&sh.measure[0]), ld(&sh.measure[1]))
                };
                let g = rot(ld(&sn[i]), ld(&cs[i]), [qx, qy]);
                let (hx, hy) = rot(ns, 1.0 + nc, [g.0, g.1]);
                dx = dx + hx;
                dy = dy + hy;
            }
            if GEOM && i + 1 < N && self.clear.at(i + 1) {
                dx = dx + ld(&u[0][i + 1]);
                dy = dy + ld(&u[1][i + 1]);
            }
            if let Some((_, _, dlen, seen)) = tri {
                far = far | !(Lane::le(ts.abs(), ASIN_SERIES_MAX) & Lane::gt(1.0 + tc, 0.0));
                turn[0][i] = ts;
                turn[1][i] = tc;
                dth[i] = asin_small(ts);
                (-du * fa.body_c[i] + seen).store(&mut sb.dl[i], at);
                dlen.store(&mut sb.dlength[i], at);
            } else if let Some(t) = turns {
                // A drive's turn is its angle; it has no body length nor pins' distance.
                dth[i] = ld(&t.q[i]);
                F4::splat(f64::NAN).store(&mut sb.dl[i], at);
                F4::splat(f64::NAN).store(&mut sb.dlength[i], at);
            }
            over = over | Lane::gt(f.abs(), self.fmax[i]);
            f.store(&mut sb.force[i], at);
            du.store(&mut sb.dforce[i], at);
            (ld(&pb.rw[0][i]) + ld(&pb.ru[0][i])).store(&mut sb.reaction[0][i], at);
            (ld(&pb.rw[1][i]) + ld(&pb.ru[1][i])).store(&mut sb.reaction[1][i], at);
        }
        if far.any() {
            large_turns(&turn, far, &mut dth);
        }
        let deg = 180.0f64 / std::f64::consts::PI;
        let mut da = ld(phi);
        let mut max_da = F4::ZERO;
        let (mut before, mut beyond) = (F4::ZERO, M4::FALSE);
        for i in 0..N {
            // The loaded angle nearest the unloaded one.
            da = wrap_once(da + dth[i]);
            let d = da * deg;
            d.store(&mut sb.dalpha[i], at);
            max_da = Lane::max(max_da, d.abs());
            if self.ranges.at(i) {
                beyond = beyond | self.ranges.loaded_out(i, ld(&sb.q[i]), d, before);
            }
            before = d;
        }
        let down = Lane::lt(ld(&pay[1]), 0.0);
        let mut large = validity::large_deflection_sq(max_da, dx, dy, down, self.reach);
        if self.fa.load_rise {
            // the load point rising (validity::MAX_LOAD_RISE_MM): not an elastic answer
            let lift = validity::load_dy(dy, sr, cm, ld(&pb.lx), ld(&pb.ly));
            large = large | (down & Lane::gt(lift, validity::MAX_LOAD_RISE_MM));
        }
        for j in 0..W {
            let k = at + j;
            sb.status[k] = validity::code_of(Checks {
                out_of_stroke: pb.out_of_stroke[k] || beyond.get(j),
                near_singular: pb.near_singular[k],
                branch_flip: flip.get(j),
                over_force: over.get(j),
                large_deflection: large.get(j),
            });
            sb.fail[k] = fail.get(j);
        }
        dx.store(&mut sb.dx, at);
        dy.store(&mut sb.dy, at);
    }
}

/// The trigonometry and the geometric effects' offsets of a block, read by every pack.
struct Geo<'a, const N: usize> {
    sn: &'a [[f64; L]; N],
    cs: &'a [[f64; L]; N],
    u: &'a [[[f64; L]; N]; 2],
    sh: &'a Shifts<N>,
}

/// The angle of the turns the series does not cover (lanes of `far`), with `atan2`.
#[cold]
fn large_turns<const N: usize>(turn: &[[F4; N]; 2], far: M4, dth: &mut [F4; N]) {
    for i in 0..N {
        for j in 0..W {
            let (s, cm) = (turn[0][i].0[j], turn[1][i].0[j]);
            if far.get(j) && !(s.abs() <= ASIN_SERIES_MAX && 1.0 + cm > 0.0) {
                dth[i].0[j] = s.atan2(1.0 + cm);
            }
        }
    }
}

/// Writes a solved block to rows `p..p + count` of the outputs (inlined into the block's
/// instruction-set variant, so that the transposes are vectorised with it: no closure or
/// helper here may be left out of line, which would compile it for the baseline x86-64).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn write_block<const N: usize>(
    sh: Shuffles,
    pb: &PoseBlock<N>,
    sb: &SolveBlock<N>,
    rotary: Option<&[bool; N]>,
    out: &mut BatchOutput<'_>,
    status: &mut [u8],
    p: usize,
    count: usize,
) {
    let span = p * N..(p + count) * N;
    // An output not asked for is empty: `get_mut` finds no rows there and nothing is written.
    #[inline(always)]
    fn put<const N: usize>(sh: Shuffles, block: &[[f64; L]; N], o: &mut [f64], span: Range<usize>) {
        if let Some(rows) = o.get_mut(span) {
            transpose_into(sh, block, rows);
        }
    }
    match rotary {
        // Linear actuators only: no torques.
        None => {
            put(sh, &sb.force, out.force_n, span.clone());
            put(sh, &sb.dforce, out.dforce_n, span.clone());
            for o in [&mut *out.torque_nmm, &mut *out.dtorque_nmm] {
                if let Some(rows) = o.get_mut(span.clone()) {
                    rows.fill(f64::NAN);
                }
            }
        }
        // Each drive's load in its own arrays, NaN in the other.
        Some(rotary) => {
            let loads = [(false, &sb.force), (false, &sb.dforce)];
            let torques = [(true, &sb.force), (true, &sb.dforce)];
            let targets = [
                &mut *out.force_n,
                &mut *out.dforce_n,
                &mut *out.torque_nmm,
                &mut *out.dtorque_nmm,
            ];
            for ((drive, block), o) in loads.into_iter().chain(torques).zip(targets) {
                if !o.is_empty() {
                    put(sh, &of_kind(block, rotary, drive), o, span.clone());
                }
            }
        }
    }
    put(sh, &sb.dalpha, out.dalpha_deg, span.clone());
    put(sh, &sb.dl, out.dl_mm, span.clone());
    put(sh, &sb.dlength, out.dlength_mm, span.clone());
    put(sh, &pb.len, out.length_mm, span);
    if let Some(rows) = out.reaction_n.get_mut(2 * p * N..2 * (p + count) * N) {
        transpose_xy_into(sh, &sb.reaction, rows);
    }
    if let Some(rows) = out.dx_mm.get_mut(p..p + count) {
        rows.copy_from_slice(&sb.dx[..count]);
    }
    if let Some(rows) = out.dy_mm.get_mut(p..p + count) {
        rows.copy_from_slice(&sb.dy[..count]);
    }
    status[p..p + count].copy_from_slice(&sb.status[..count]);
}

/// A load block with NaN at the links whose drive is not of the kind asked for (`drive`:
/// rotary drives' torques; else linear actuators' forces).
#[inline(always)]
fn of_kind<const N: usize>(
    block: &[[f64; L]; N],
    rotary: &[bool; N],
    drive: bool,
) -> [[f64; L]; N] {
    std::array::from_fn(|i| {
        if rotary[i] == drive {
            block[i]
        } else {
            [f64::NAN; L]
        }
    })
}

/// The solve kernel of an arm of 1–6 links (one per call: the variants' sizes do not matter).
#[allow(clippy::large_enum_variant)]
pub(crate) enum Kernel {
    F1(SolveKernel<1>),
    F2(SolveKernel<2>),
    F3(SolveKernel<3>),
    F4(SolveKernel<4>),
    F5(SolveKernel<5>),
    F6(SolveKernel<6>),
}

impl Kernel {
    /// The kernel of `arm`, or `None` beyond 6 links (the general path solves those).
    pub(crate) fn new(arm: &Arm, effects: &EffectSet, self_weight: bool) -> Option<Self> {
        let sw = self_weight;
        match arm.n() {
            1 => SolveKernel::new(arm, effects, sw).map(Self::F1),
            2 => SolveKernel::new(arm, effects, sw).map(Self::F2),
            3 => SolveKernel::new(arm, effects, sw).map(Self::F3),
            4 => SolveKernel::new(arm, effects, sw).map(Self::F4),
            5 => SolveKernel::new(arm, effects, sw).map(Self::F5),
            6 => SolveKernel::new(arm, effects, sw).map(Self::F6),
            _ => None,
        }
    }

    /// Solves the rows of one chunk (`first_row` is the batch row of its first pose).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn chunk(
        &self,
        simd: pulp::Arch,
        ctx: &Ctx<'_>,
        input: BatchInput<'_>,
        out: BatchOutput<'_>,
        status: &mut [u8],
        first_row: usize,
    ) -> Result<()> {
        match self {
            Self::F1(k) => k.chunk(simd, ctx, input, out, status, first_row),
            Self::F2(k) => k.chunk(simd, ctx, input, out, status, first_row),
            Self::F3(k) => k.chunk(simd, ctx, input, out, status, first_row),
            Self::F4(k) => k.chunk(simd, ctx, input, out, status, first_row),
            Self::F5(k) => k.chunk(simd, ctx, input, out, status, first_row),
            Self::F6(k) => k.chunk(simd, ctx, input, out, status, first_row),
        }
    }
}

impl Kernel {
    /// Solves the load sequences of `input` (see [`super::sequence`]) into `out` (rows
    /// `q·S + s`; with `last_only` only each sequence's last state, row `q`) and `status`,
    /// [`L`] sequences at a time with each lane's friction memory carried from state to
    /// state; returns the (chunk-local) sequences with a state the kernel could not solve,
    /// for the general path to solve again.
    pub(crate) fn sequences(
        &self,
        simd: pulp::Arch,
        input: SequenceInput<'_>,
        out: &mut BatchOutput<'_>,
        status: &mut [u8],
        last_only: bool,
    ) -> Vec<usize> {
        let l = last_only;
        match self {
            Self::F1(k) => k.sequences(simd, input, out, status, l),
            Self::F2(k) => k.sequences(simd, input, out, status, l),
            Self::F3(k) => k.sequences(simd, input, out, status, l),
            Self::F4(k) => k.sequences(simd, input, out, status, l),
            Self::F5(k) => k.sequences(simd, input, out, status, l),
            Self::F6(k) => k.sequences(simd, input, out, status, l),
        }
    }
}

impl<const N: usize> SolveKernel<N> {
    fn sequences(
        &self,
        simd: pulp::Arch,
        input: SequenceInput<'_>,
        out: &mut BatchOutput<'_>,
        status: &mut [u8],
        last_only: bool,
    ) -> Vec<usize> {
        let seqs = input.alpha_deg.len() / N;
        let mut sc = SeqScratch {
            ux: Unit::new(),
            uy: Unit::new(),
            pb: PoseBlock::<N>::new(),
            sb: SolveBlock::<N>::new(),
            mv: Moves::new(),
            pay: Vec::new(),
            group: Group::new(),
        };
        let mut failed = Vec::new();
        let mut q0 = 0;
        while q0 < seqs {
            let count = (seqs - q0).min(L);
            let bad =
                self.sequence_block(simd, input, (q0, count), &mut sc, out, status, last_only);
            failed.extend((0..count).filter(|&k| bad[k]).map(|k| q0 + k));
            q0 += count;
        }
        failed
    }

    /// Sequences `q0..q0 + count` through all their states: the poses' trigonometry and the
    /// statics of a unit payload along x and along y once (the payload case is linear in the
    /// payload), then per state the payload case scaled, the frictions stepped, the closure.
    /// Returns which lanes failed in some state. With `last_only` only the last state is
    /// written, to row `q` of sequence q.
    #[allow(clippy::too_many_arguments)]
    fn sequence_block(
        &self,
        simd: pulp::Arch,
        input: SequenceInput<'_>,
        (q0, count): (usize, usize),
        sc: &mut SeqScratch<N>,
        out: &mut BatchOutput<'_>,
        status: &mut [u8],
        last_only: bool,
    ) -> [bool; L] {
        struct Op<'a, 'o, const N: usize> {
            k: &'a SolveKernel<N>,
            input: SequenceInput<'a>,
            q0: usize,
            count: usize,
            sc: &'a mut SeqScratch<N>,
            out: &'a mut BatchOutput<'o>,
            status: &'a mut [u8],
            last_only: bool,
        }
        impl<const N: usize> pulp::WithSimd for Op<'_, '_, N> {
            type Output = [bool; L];
            #[inline(always)]
            fn with_simd<S: pulp::Simd>(self, _simd: S) -> [bool; L] {
                let (k, sc, count, q0) = (self.k, self.sc, self.count, self.q0);
                let states = self.input.states;
                let alpha = &self.input.alpha_deg[q0 * N..(q0 + count) * N];
                let trig = block_trig::<N>(k.fa.sh, alpha, count);
                // The pose stage twice, with a unit payload along x and along y: only the
                // payload case changes from state to state, so only its forces are kept.
                let (one, zero) = ([1.0; L], [0.0; L]);
                k.fa.poses_sc_impl(&trig.0, &trig.1, &[one, zero], &mut sc.pb);
                sc.ux.keep(&sc.pb);
                k.fa.poses_sc_impl(&trig.0, &trig.1, &[zero, one], &mut sc.pb);
                sc.uy.keep(&sc.pb);
                if k.ranges.any {
                    k.ranges.unloaded(alpha, count, &mut sc.pb, &mut sc.sb.q);
                }
                let mut held = Held::<N>::new();
                let mut bad = [false; L];
                let group = states.min(GROUP);
                // The block's payloads by state, its lanes' rows being contiguous; missing
                // lanes repeat the last sequence.
                let rows = &self.input.payload_n[2 * q0 * states..2 * (q0 + count) * states];
                sc.pay.clear();
                sc.pay.resize(states, [[0.0; L]; 2]);
                for j in 0..L {
                    let lane = &rows[2 * j.min(count - 1) * states..][..2 * states];
                    for (pay, xy) in sc.pay.iter_mut().zip(lane.chunks_exact(2)) {
                        pay[0][j] = xy[0];
                        pay[1][j] = xy[1];
                    }
                }
                for st in 0..states {
                    let pay = sc.pay[st];
                    for i in 0..N {
                        for j in 0..L {
                            let (px, py) = (pay[0][j], pay[1][j]);
                            sc.pb.fu[i][j] = px * sc.ux.fu[i][j] + py * sc.uy.fu[i][j];
                            for c in 0..2 {
                                sc.pb.ru[c][i][j] = px * sc.ux.ru[c][i][j] + py * sc.uy.ru[c][i][j];
                            }
                        }
                    }
                    if k.fric.any {
                        k.fric
                            .step(&mut sc.pb, &mut held, &k.fa.body_c, &mut sc.sb.seen);
                    }
                    k.close_any(&trig, &pay, &sc.pb, &mut sc.sb, &mut sc.mv);
                    for j in 0..count {
                        bad[j] |= sc.sb.fail[j];
                    }
                    // Every state is written, a group of states at a time; or only the
                    // last state, to row q (a group of one).
                    let (g, first, stride) = if !self.last_only {
                        let g = st % group + 1;
                        if g < group && st + 1 < states {
                            sc.group.keep(g - 1, &sc.sb, self.out);
                            continue;
                        }
                        (g, q0 * states + st + 1 - g, states)
                    } else if st + 1 == states {
                        (1, q0, 1)
                    } else {
                        continue;
                    };
                    sc.group.keep(g - 1, &sc.sb, self.out);
                    let rows: [usize; L] =
                        std::array::from_fn(|j| first + j.min(count - 1) * stride);
                    let (len, rotary) = (&sc.pb.len, &k.fa.rotary);
                    sc.group
                        .write(g, len, rotary, self.out, self.status, &rows[..count]);
                }
                bad
            }
        }
        simd.dispatch(Op {
            k: self,
            input,
            q0,
            count,
            sc,
            out,
            status,
            last_only,
        })
    }
}

/// Scratch of [`SolveKernel::sequence_block`]: the unit payload cases' forces, the state's
/// pose and solved blocks, the payloads and the states kept for writing.
struct SeqScratch<const N: usize> {
    ux: Unit<N>,
    uy: Unit<N>,
    pb: PoseBlock<N>,
    sb: SolveBlock<N>,
    mv: Moves<N>,
    /// The block's payloads (x, y per lane) by state.
    pay: Vec<[[f64; L]; 2]>,
    /// The states kept for writing.
    group: Group<N>,
}

/// The forces and reactions of a unit payload (a pose stage's payload case), `[link][lane]`.
struct Unit<const N: usize> {
    fu: [[f64; L]; N],
    ru: [[[f64; L]; N]; 2],
}

impl<const N: usize> Unit<N> {
    fn new() -> Self {
        let z = [[0.0; L]; N];
        Self { fu: z, ru: [z; 2] }
    }

    #[inline(always)]
    fn keep(&mut self, pb: &PoseBlock<N>) {
        self.fu = pb.fu;
        self.ru = pb.ru;
    }
}

/// Copies row `k` of `from` into row `r` of `to` (`n` links).
pub(crate) fn copy_row(
    from: &BatchBuffers,
    k: usize,
    to: &mut BatchOutput<'_>,
    r: usize,
    n: usize,
) {
    let (a, b) = (k * n..(k + 1) * n, r * n..(r + 1) * n);
    // An output not asked for in `to` is empty: nothing is copied there.
    let copy =
        |to: &mut [f64], from: &[f64], (b, a): (std::ops::Range<usize>, std::ops::Range<usize>)| {
            if !to.is_empty() {
                to[b].copy_from_slice(&from[a]);
            }
        };
    let rows = (b.clone(), a.clone());
    copy(to.force_n, &from.force_n, rows.clone());
    copy(to.dforce_n, &from.dforce_n, rows.clone());
    copy(to.torque_nmm, &from.torque_nmm, rows.clone());
    copy(to.dtorque_nmm, &from.dtorque_nmm, rows.clone());
    copy(to.dalpha_deg, &from.dalpha_deg, rows.clone());
    copy(to.dl_mm, &from.dl_mm, rows.clone());
    copy(to.dlength_mm, &from.dlength_mm, rows.clone());
    copy(to.length_mm, &from.length_mm, rows);
    let xy = (2 * r * n..2 * (r + 1) * n, 2 * k * n..2 * (k + 1) * n);
    copy(to.reaction_n, &from.reaction_n, xy);
    copy(to.dx_mm, &from.dx_mm, (r..r + 1, k..k + 1));
    copy(to.dy_mm, &from.dy_mm, (r..r + 1, k..k + 1));
}

/// What a chunk needs besides its rows: the model, for the lanes the kernel hands back.
pub(crate) struct Ctx<'a> {
    pub(crate) arm: &'a Arm,
    pub(crate) effects: &'a EffectSet,
    pub(crate) opts: SolveOptions,
}

impl<const N: usize> SolveKernel<N> {
    fn chunk(
        &self,
        simd: pulp::Arch,
        ctx: &Ctx<'_>,
        input: BatchInput<'_>,
        mut out: BatchOutput<'_>,
        status: &mut [u8],
        first_row: usize,
    ) -> Result<()> {
        let rows = status.len(); // an output not asked for is empty
        let mut pb = PoseBlock::<N>::new();
        let mut sb = SolveBlock::<N>::new();
        let mut mv = Moves::new();
        let mut general: Option<General> = None;
        let mut p = 0;
        while p < rows {
            let count = (rows - p).min(L);
            let alpha = &input.alpha_deg[p * N..(p + count) * N];
            let payload = &input.payload_n[2 * p..2 * (p + count)];
            self.block(
                simd, alpha, payload, count, &mut pb, &mut sb, &mut mv, &mut out, status, p, None,
            );
            // The lanes the kernel could not solve (rare: one test per block first).
            let failed = sb.fail[..count].contains(&true);
            for q in (0..count).filter(|&q| failed && sb.fail[q]) {
                let r = p + q;
                let g = general.get_or_insert_with(|| General::new(ctx.arm));
                status[r] = g.solve(ctx, alpha, payload, q, &mut out, r, first_row + r)?;
            }
            p += count;
        }
        Ok(())
    }
}

/// The general path for the lanes the kernel cannot solve.
struct General {
    ws: Workspace,
    alpha: Vec<f64>,
    loaded: crate::kinematics::Frames,
    reach: f64,
}

impl General {
    fn new(arm: &Arm) -> Self {
        Self {
            ws: Workspace::new(arm),
            alpha: vec![0.0; arm.n()],
            loaded: crate::kinematics::Frames::new(arm.n()),
            reach: validity::reach(arm),
        }
    }

    /// Solves lane `q` of a block into output row `r` (batch row `row`); its status.
    #[allow(clippy::too_many_arguments)]
    fn solve(
        &mut self,
        ctx: &Ctx<'_>,
        alpha_deg: &[f64],
        payload: &[f64],
        q: usize,
        out: &mut BatchOutput<'_>,
        r: usize,
        row: usize,
    ) -> Result<u8> {
        let n = ctx.arm.n();
        for (a, d) in self.alpha.iter_mut().zip(&alpha_deg[q * n..(q + 1) * n]) {
            *a = d.to_radians();
        }
        let pay = V2::new(payload[2 * q], payload[2 * q + 1]);
        let solved = self
            .ws
            .solve(ctx.arm, ctx.effects, &self.alpha, pay, ctx.opts, row);
        let solved = write_outcome(ctx.arm, &self.ws, &self.alpha, solved, ctx.opts, out, r)?;
        Ok(pose_status(
            ctx.arm,
            &self.ws,
            &self.alpha,
            solved,
            &mut self.loaded,
            pay.y < 0.0,
            self.reach,
            validity::checks_load_rise(ctx.arm, ctx.effects),
        ))
    }
}
