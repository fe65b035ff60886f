//! What is free when K is singular: the error path of the factorisation.
//!
//! The null vector of K (its eigenvector of the smallest eigenvalue, after scaling K to a
//! unit diagonal) is a motion that deforms nothing. Reading which bodies it moves names the
//! fault: the chassis (nothing supports the model), or the first link of the chain that
//! moves — turning rigidly about its joint (its drive does not hold it: an actuator whose line
//! passes through the joint, or a zero stiffness) or deforming (a zero section stiffness).

use faer::{Mat, Side};

use crate::arm::Arm;
use crate::error::ArmError;
use crate::geometry::rot_sc;
use crate::kinematics::Frames;

use super::assemble::Assembly;
use super::maps::{perp, Maps};
use super::mesh::Mesh;
use super::solve::SingularAt;

/// The error for a singular K, naming what moves.
#[allow(clippy::too_many_arguments)]
pub fn describe(
    arm: &Arm,
    mesh: &Mesh,
    asm: &Assembly,
    maps: &Maps,
    fr: &Frames,
    values: &[f64],
    at: SingularAt,
    row: usize,
) -> ArmError {
    let fallback = || ArmError::Mechanism {
        row,
        what: format!(
            "the stiffness matrix is singular at DOF {} ({})",
            at.dof,
            dof_name(mesh, at.dof)
        ),
    };
    let Some(v) = null_vector(asm, values) else {
        return fallback();
    };
    let reach: f64 = mesh.links.iter().map(|l| l.extent()).sum();
    let chassis = mesh.base_dof.map_or(0.0, |d| v[d].abs() * reach);
    let mut link_motion = vec![0.0_f64; mesh.links.len()];
    for (i, lm) in mesh.links.iter().enumerate() {
        let mut m = 0.0_f64;
        // (A rotary drive's link has an empty map of A: it reads as zero.)
        for lin in maps.station[i]
            .iter()
            .chain([&maps.a[i], &maps.next[i], &maps.c[i]])
        {
            m = m.max(lin.linear(&v).norm());
        }
        if lm.kind.bends() {
            for r in &maps.rot[i] {
                m = m.max(r.eval(&v).abs() * lm.extent());
            }
        }
        link_motion[i] = m;
    }
    let top = link_motion.iter().copied().fold(chassis, f64::max);
    if top <= 0.0 {
        return fallback();
    }
    let moves = |m: f64| m > 1e-6 * top;
    if moves(chassis) {
        return ArmError::Unsupported(format!(
            "the FE model is not supported: the chassis and the arm can turn together about \
             base.pivot without deforming anything (base spring stiffness {} N·mm/rad)",
            asm.base_k
        ));
    }
    let Some(j) = link_motion.iter().position(|&m| moves(m)) else {
        return fallback();
    };
    // Is it link j turning rigidly about its joint?
    let lm = &mesh.links[j];
    let omega = v[lm.theta_origin()];
    let o = maps.pin[j].linear(&v);
    let (s, c) = (fr.sin[j], fr.cos[j]);
    let link = &arm.links[j];
    let mut misfit = 0.0_f64;
    let pins = [
        (&maps.next[j], link.next),
        (&maps.c[j], link.c),
        (&maps.a[j], link.a),
    ];
    let used = if lm.rotary { 2 } else { 3 };
    for &(lin, p) in &pins[..used] {
        let rigid = o + omega * perp(rot_sc(s, c, p));
        misfit = misfit.max((lin.linear(&v) - rigid).norm());
    }
    let turns = misfit <= 1e-6 * top && omega.abs() * reach > 1e-6 * top;
    let what = if turns && lm.rotary {
        format!(
            "link {k} (with the links beyond it) turns about joint O{k} with nothing to resist \
             it: drive {k} does not hold it (its stiffness is zero)",
            k = j + 1
        )
    } else if turns {
        format!(
            "link {k} (with the links beyond it) turns about joint O{k} with nothing to resist \
             it: actuator {k} does not hold it (its line passes through O{k}, or its stiffness \
             is zero)",
            k = j + 1
        )
    } else {
        format!(
            "link {k} deforms without resistance (a section stiffness of link {k} is zero?)",
            k = j + 1
        )
    };
    ArmError::Mechanism { row, what }
}

/// The eigenvector of the smallest eigenvalue of D^{-1/2}·K·D^{-1/2}, mapped back by D^{-1/2}.
#[allow(clippy::needless_range_loop)] // CSC walk: p indexes row_idx and values
fn null_vector(asm: &Assembly, values: &[f64]) -> Option<Vec<f64>> {
    let n = asm.diag_pos.len();
    let d: Vec<f64> = asm
        .diag_pos
        .iter()
        .map(|&p| {
            let x = values[p];
            if x > 0.0 {
                1.0 / x.sqrt()
            } else {
                1.0
            }
        })
        .collect();
    let mut k = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        for p in asm.col_ptr[j]..asm.col_ptr[j + 1] {
            let i = asm.row_idx[p];
            let x = values[p] * d[i] * d[j];
            k[(i, j)] = x;
            k[(j, i)] = x;
        }
    }
    let eig = k.self_adjoint_eigen(Side::Lower).ok()?;
    let u = eig.U();
    let v: Vec<f64> = (0..n).map(|i| u[(i, 0)] * d[i]).collect();
    v.iter().all(|x| x.is_finite()).then_some(v)
}

/// A readable name of a DOF, for the fallback message.
fn dof_name(mesh: &Mesh, dof: usize) -> String {
    if mesh.base_dof == Some(dof) {
        return "chassis tilt".into();
    }
    for (i, lm) in mesh.links.iter().enumerate() {
        for (k, d) in lm.dof.iter().enumerate() {
            if let Some(c) = d.iter().position(|&x| x == dof) {
                let what = ["u_x", "u_y", "rotation"][c];
                return format!("link {} {what} at x = {:.1} mm", i + 1, lm.x[k]);
            }
        }
    }
    "unknown".into()
}
