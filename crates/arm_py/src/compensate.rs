//! `compensate`: the angles to command so that the loaded measure point lands on the nominal
//! one (`arm_core::compensate_batch`), and the names of its statuses.

use crate::convert::{effect_set, poses_and_payloads, CoreArm};
use crate::errors::{value_error, PyArmError};
use arm_core::{CompensateBuffers, CompensateOptions, CompensateStatus, JacobianKind};
use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The status names, indexed by the codes in `compensate(...)["status"]`.
pub(crate) fn status_names() -> Vec<&'static str> {
    CompensateStatus::ALL.iter().map(|s| s.name()).collect()
}

/// Compensates N nominal poses (see `arm_core::compensate_batch` and
/// `eodarm.analysis.compensate`): `alpha_deg` (N, n) nominal unloaded angles, `payload_n`
/// (N, 2) payload force at the load point. `jacobian` is `"auto"`, `"rigid"` (quasi-Newton)
/// or `"finite_difference"`. Returns a dict: `alpha_deg`, `length_mm` (N, n) float64 (NaN
/// where the status is not ok), `residual_mm` (N,) float64, `status` (N,) uint8 (codes of
/// `COMPENSATE_STATUSES`), `iterations` (N,) uint32, `actuator` (N,) uint32 (the actuator
/// concerned, 1-based, 0 for none).
#[pyfunction]
#[pyo3(signature = (arm, alpha_deg, payload_n, codes, places, values, self_weight, *, jacobian="auto", max_iter=50, tol_mm=1e-9, min_moment_ratio=1e-2))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn compensate<'py>(
    py: Python<'py>,
    arm: &CoreArm,
    alpha_deg: PyReadonlyArray2<'py, f64>,
    payload_n: PyReadonlyArray2<'py, f64>,
    codes: PyReadonlyArray1<'py, i64>,
    places: PyReadonlyArray1<'py, i64>,
    values: PyReadonlyArray1<'py, f64>,
    self_weight: bool,
    jacobian: &str,
    max_iter: u32,
    tol_mm: f64,
    min_moment_ratio: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let arm = &arm.inner;
    let n = arm.n();
    let input = poses_and_payloads(&alpha_deg, &payload_n, n)?;
    let rows = input.payload_n.len() / 2;
    let effects = effect_set(arm, &codes, &places, &values, true)?;
    let jacobian = match jacobian {
        "auto" => JacobianKind::Auto,
        "rigid" => JacobianKind::Rigid,
        "finite_difference" => JacobianKind::FiniteDifference,
        other => {
            return Err(value_error(format!(
                "jacobian must be 'auto', 'rigid' or 'finite_difference', got '{other}'"
            )))
        }
    };
    let opts = CompensateOptions {
        self_weight,
        jacobian,
        max_iter,
        tol_mm,
        min_moment_ratio,
    };
    let mut b = CompensateBuffers::new(rows, n);
    py.detach(|| arm_core::compensate_batch(arm, &effects, input, opts, b.out()))
        .map_err(PyArmError)?;
    let out = PyDict::new(py);
    out.set_item(
        "alpha_deg",
        b.alpha_deg.into_pyarray(py).reshape([rows, n])?,
    )?;
    out.set_item(
        "length_mm",
        b.length_mm.into_pyarray(py).reshape([rows, n])?,
    )?;
    out.set_item("residual_mm", b.residual_mm.into_pyarray(py))?;
    out.set_item("status", b.status.into_pyarray(py))?;
    out.set_item("iterations", b.iterations.into_pyarray(py))?;
    out.set_item("actuator", b.actuator.into_pyarray(py))?;
    Ok(out)
}
