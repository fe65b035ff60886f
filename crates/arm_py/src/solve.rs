//! `solve`: the analytic model over N poses.

use crate::convert::{effect_set, poses_and_payloads, solve_dict, CoreArm};
use crate::errors::PyArmError;
use arm_core::{BatchBuffers, SolveOptions};
use numpy::{PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Solves N poses; returns a dict of float64 arrays (see `eodarm.solve`).
#[pyfunction]
#[pyo3(signature = (arm, alpha_deg, payload_n, codes, places, values, self_weight, nan_on_failure=false))]
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
) -> PyResult<Bound<'py, PyDict>> {
    let arm = &arm.inner;
    let n = arm.n();
    let input = poses_and_payloads(&alpha_deg, &payload_n, n)?;
    let rows = input.payload_n.len() / 2;
    let effects = effect_set(arm, &codes, &places, &values, true)?;
    let mut arrays = BatchBuffers::new(rows, n);
    py.detach(|| {
        arm_core::solve_batch(
            arm,
            &effects,
            input,
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
