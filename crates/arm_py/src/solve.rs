//! `solve`: the analytic model over N poses (with the extra deformations of user effects), and
//! `statics`: the forces of both states that those effects read.

use crate::convert::{effect_set, optional, poses_and_payloads, solve_dict, CoreArm};
use crate::errors::PyArmError;
use arm_core::{BatchBuffers, ExtraDeformations, SolveOptions, StaticsBuffers};
use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Solves N poses; returns a dict of float64 arrays (see `eodarm.solve`).
///
/// The keyword-only `extra_*` arrays (float64, C-contiguous, each optional) are deformations
/// of user-written effects added to the built-in effects' (global frame, see
/// `arm_core::ExtraDeformations`): `extra_seen_mm` (N, n) pin-to-pin length change that the
/// actuator's sensor sees, `extra_unseen_mm` (N, n) one it does not see, `extra_joint_mm`
/// (N, n, 2) offset of link i's pin centre at O_i, `extra_tilt_rad` (N,) chassis tilt about
/// the base pivot, `extra_measure_mm` (N, 2) displacement of the measure point.
#[pyfunction]
#[pyo3(signature = (arm, alpha_deg, payload_n, codes, places, values, self_weight, nan_on_failure=false, *, extra_seen_mm=None, extra_unseen_mm=None, extra_joint_mm=None, extra_tilt_rad=None, extra_measure_mm=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve<'py>(
    py: Python<'py>,
    arm: &CoreArm,
    alpha_deg: PyReadonlyArray2<'py, f64>,
    payload_n: PyReadonlyArray2<'py, f64>,
    codes: PyReadonlyArray1<'py, i64>,
    places: PyReadonlyArray1<'py, i64>,
    values: PyReadonlyArray1<'py, f64>,
    self_weight: bool,
    nan_on_failure: bool,
    extra_seen_mm: Option<PyReadonlyArrayDyn<'py, f64>>,
    extra_unseen_mm: Option<PyReadonlyArrayDyn<'py, f64>>,
    extra_joint_mm: Option<PyReadonlyArrayDyn<'py, f64>>,
    extra_tilt_rad: Option<PyReadonlyArrayDyn<'py, f64>>,
    extra_measure_mm: Option<PyReadonlyArrayDyn<'py, f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let arm = &arm.inner;
    let n = arm.n();
    let input = poses_and_payloads(&alpha_deg, &payload_n, n)?;
    let rows = input.payload_n.len() / 2;
    let effects = effect_set(arm, &codes, &places, &values, true)?;
    let extra = ExtraDeformations {
        seen_mm: optional(&extra_seen_mm, "extra_seen_mm", &[rows, n], "(N, n)")?,
        unseen_mm: optional(&extra_unseen_mm, "extra_unseen_mm", &[rows, n], "(N, n)")?,
        joint_mm: optional(
            &extra_joint_mm,
            "extra_joint_mm",
            &[rows, n, 2],
            "(N, n, 2)",
        )?,
        tilt_rad: optional(&extra_tilt_rad, "extra_tilt_rad", &[rows], "(N,)")?,
        measure_mm: optional(&extra_measure_mm, "extra_measure_mm", &[rows, 2], "(N, 2)")?,
    };
    let mut arrays = BatchBuffers::new(rows, n);
    py.detach(|| {
        arm_core::solve_batch_extra(
            arm,
            &effects,
            input,
            extra,
            SolveOptions {
                self_weight,
                nan_on_failure,
            },
            arrays.out(),
        )
    })
    .map_err(PyArmError)?;
    solve_dict(py, arrays, rows, n)
}

/// Statics of N poses on the undeformed geometry (see `arm_core::statics_batch`): a dict of
/// float64 arrays `force_n`, `force0_n` (N, n) loaded and unloaded actuator forces
/// (compression +), `reaction_n`, `reaction0_n` (N, n, 2) loaded and unloaded joint reactions
/// (force of body i−1 on link i, global), `length_mm` (N, n) unloaded pin-to-pin lengths.
#[pyfunction]
#[pyo3(signature = (arm, alpha_deg, payload_n, self_weight))]
pub(crate) fn statics<'py>(
    py: Python<'py>,
    arm: &CoreArm,
    alpha_deg: PyReadonlyArray2<'py, f64>,
    payload_n: PyReadonlyArray2<'py, f64>,
    self_weight: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let arm = &arm.inner;
    let n = arm.n();
    let input = poses_and_payloads(&alpha_deg, &payload_n, n)?;
    let rows = input.payload_n.len() / 2;
    let mut b = StaticsBuffers::new(rows, n);
    py.detach(|| arm_core::statics_batch(arm, input, self_weight, b.out()))
        .map_err(PyArmError)?;
    let out = PyDict::new(py);
    out.set_item("force_n", b.force_n.into_pyarray(py).reshape([rows, n])?)?;
    out.set_item("force0_n", b.force0_n.into_pyarray(py).reshape([rows, n])?)?;
    out.set_item(
        "reaction_n",
        b.reaction_n.into_pyarray(py).reshape([rows, n, 2])?,
    )?;
    out.set_item(
        "reaction0_n",
        b.reaction0_n.into_pyarray(py).reshape([rows, n, 2])?,
    )?;
    out.set_item(
        "length_mm",
        b.length_mm.into_pyarray(py).reshape([rows, n])?,
    )?;
    Ok(out)
}
