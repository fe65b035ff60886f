//! `jacobian`: predicted channels and their sensitivities to effect parameters.

use crate::convert::{matrix, CoreArm};
use crate::errors::{value_error, PyArmError};
use arm_core::sensitivity::{jacobian_batch, n_channels, Place};
use arm_core::{BatchInput, SolveOptions};
use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

fn places(
    codes: &PyReadonlyArray1<'_, i64>,
    index: &PyReadonlyArray1<'_, i64>,
) -> PyResult<Vec<Place>> {
    let err = |_| value_error("effect arrays must be contiguous".into());
    let (codes, index) = (
        codes.as_slice().map_err(err)?,
        index.as_slice().map_err(err)?,
    );
    if codes.len() != index.len() {
        return Err(value_error("effect arrays differ in length".into()));
    }
    codes
        .iter()
        .zip(index)
        .map(|(&code, &i)| {
            let index = usize::try_from(i)
                .map_err(|_| value_error(format!("effect place index {i} is negative")))?;
            Ok(Place { code, index })
        })
        .collect()
}

/// Predicted channels y (N, C) and sensitivities dy/dθ (N, C, P); channels are dx, dy,
/// dα₁…dαₙ (deg), dl₁…dlₙ (mm). See `arm_core::sensitivity`.
#[pyfunction]
#[pyo3(signature = (arm, alpha_deg, payload_n, model_codes, model_places, model_thetas, probe_codes, probe_places, self_weight, nan_on_failure=false))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn jacobian<'py>(
    py: Python<'py>,
    arm: &CoreArm,
    alpha_deg: PyReadonlyArray2<'py, f64>,
    payload_n: PyReadonlyArray2<'py, f64>,
    model_codes: PyReadonlyArray1<'py, i64>,
    model_places: PyReadonlyArray1<'py, i64>,
    model_thetas: PyReadonlyArray1<'py, f64>,
    probe_codes: PyReadonlyArray1<'py, i64>,
    probe_places: PyReadonlyArray1<'py, i64>,
    self_weight: bool,
    nan_on_failure: bool,
) -> PyResult<JacOut<'py>> {
    let arm = &arm.inner;
    let n = arm.n();
    let (alpha, rows) = matrix(&alpha_deg, "alpha_deg", n)?;
    let (payload, prow) = matrix(&payload_n, "payload_n", 2)?;
    if prow != rows {
        return Err(value_error(format!(
            "payload_n: expected {rows} rows, got {prow}"
        )));
    }
    let model_places = places(&model_codes, &model_places)?;
    let thetas = model_thetas
        .as_slice()
        .map_err(|_| value_error("model_thetas must be contiguous".into()))?;
    if thetas.len() != model_places.len() {
        return Err(value_error(
            "model_thetas differs in length from the model".into(),
        ));
    }
    let model: Vec<(Place, f64)> = model_places
        .into_iter()
        .zip(thetas.iter().copied())
        .collect();
    let probes = places(&probe_codes, &probe_places)?;
    let c = n_channels(n);
    let p = probes.len();
    let mut y = vec![0.0; rows * c];
    let mut jac = vec![0.0; rows * c * p];
    py.detach(|| {
        jacobian_batch(
            arm,
            &model,
            &probes,
            BatchInput {
                alpha_deg: alpha,
                payload_n: payload,
            },
            SolveOptions {
                self_weight,
                nan_on_failure,
            },
            &mut y,
            &mut jac,
        )
    })
    .map_err(PyArmError)?;
    Ok((
        y.into_pyarray(py).reshape([rows, c])?,
        jac.into_pyarray(py).reshape([rows, c, p])?,
    ))
}

/// Channels (N, C) and Jacobian (N, C, P) of a sensitivity batch.
type JacOut<'py> = (
    Bound<'py, numpy::PyArray2<f64>>,
    Bound<'py, numpy::PyArray3<f64>>,
);
