//! `solve_sequence`: N load sequences of S states each, relative to each sequence's reference
//! (see `eodarm.solve_sequence` and `arm_core::solve_sequence`).

use crate::convert::{effect_set, matrix, CoreArm};
use crate::errors::{value_error, PyArmError};
use crate::solve::{asked, fill_out, new_out};
use arm_core::SolveOptions;
use numpy::{
    IntoPyArray, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArrayDyn,
    PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Solves N sequences of S states; returns a dict of float64 arrays `force_n`, `dforce_n`,
/// `torque_nmm`, `dtorque_nmm`, `dalpha_deg`, `dl_mm`, `dlength_mm`, `length_mm` (N, S, n),
/// `reaction_n` (N, S, n, 2),
/// `dx_mm`, `dy_mm` (N, S) and the uint8 `status` (N, S), every state relative to its
/// sequence's reference. `mass_kg` (N, S) is the payload mass (kg) of each state, its
/// weight `m·g` downward (`g` of the arm); (1, S) or (S,) gives every sequence the same S.
/// With `outputs` (a list of those keys) only those arrays and `status` are returned.
#[pyfunction]
#[pyo3(signature = (arm, alpha_deg, mass_kg, codes, places, values, self_weight, nan_on_failure=false, *, outputs=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve_sequence<'py>(
    py: Python<'py>,
    arm: &CoreArm,
    alpha_deg: PyReadonlyArray2<'py, f64>,
    mass_kg: PyReadonlyArrayDyn<'py, f64>,
    codes: PyReadonlyArray1<'py, i64>,
    places: PyReadonlyArray1<'py, i64>,
    values: PyReadonlyArray1<'py, f64>,
    self_weight: bool,
    nan_on_failure: bool,
    outputs: Option<Vec<String>>,
) -> PyResult<Bound<'py, PyDict>> {
    let arm = &arm.inner;
    let n = arm.n();
    let asked = asked(outputs)?;
    let (alpha, seqs) = matrix(&alpha_deg, "alpha_deg", n)?;
    let states = match *mass_kg.shape() {
        [s] | [1, s] => s,
        [rows, s] if rows == seqs => s,
        ref shape => {
            return Err(value_error(format!(
                "mass_kg: expected shape ({seqs}, S), (1, S) or (S,), got {shape:?}"
            )))
        }
    };
    if states == 0 {
        return Err(value_error(
            "mass_kg: a sequence needs at least one state".into(),
        ));
    }
    let mass = mass_kg
        .as_slice()
        .map_err(|_| value_error("mass_kg: array must be C-contiguous".into()))?;
    let effects = effect_set(arm, &codes, &places, &values, true)?;
    let opts = SolveOptions {
        self_weight,
        nan_on_failure,
    };
    let total = seqs * states;
    // numpy allocates the outputs (uninitialised, as for `solve`: `new_out`); the rows
    // are the states, sequence-major, reshaped below to (N, S, ...) views.
    let flat = new_out(py, total, n, &asked)?;
    fill_out(py, &flat, total, n, &asked, |batch, st| {
        arm_core::solve_sequence_masses(arm, &effects, alpha, mass, states, opts, batch, st)
    })?;
    let out = PyDict::new(py);
    for (key, value) in flat.iter() {
        let a = value.cast_into::<PyUntypedArray>()?;
        let mut shape = vec![seqs, states];
        shape.extend_from_slice(&a.shape()[1..]);
        out.set_item(key, a.call_method1("reshape", (shape,))?)?;
    }
    Ok(out)
}

/// `(dx, dy)` of [`cycle_returns`].
type Returns<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);

/// Where each cell (pose p, mass m_j) comes back to after its load cycle reference → m_j → 0
/// (see `arm_core::cycle_returns`): `(dx, dy)`, float64 arrays (P, M) in mm relative to the
/// reference, NaN where the cycle cannot be solved. `alpha_deg` (P, n), `mass_kg` (M,).
#[pyfunction]
#[pyo3(signature = (arm, alpha_deg, mass_kg, codes, places, values, self_weight))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn cycle_returns<'py>(
    py: Python<'py>,
    arm: &CoreArm,
    alpha_deg: PyReadonlyArray2<'py, f64>,
    mass_kg: PyReadonlyArray1<'py, f64>,
    codes: PyReadonlyArray1<'py, i64>,
    places: PyReadonlyArray1<'py, i64>,
    values: PyReadonlyArray1<'py, f64>,
    self_weight: bool,
) -> PyResult<Returns<'py>> {
    let arm = &arm.inner;
    let n = arm.n();
    let (alpha, poses) = matrix(&alpha_deg, "alpha_deg", n)?;
    let mass = mass_kg
        .as_slice()
        .map_err(|_| value_error("mass_kg: array must be C-contiguous".into()))?;
    let effects = effect_set(arm, &codes, &places, &values, true)?;
    let m = mass.len();
    let (mut dx, mut dy) = (vec![0.0; poses * m], vec![0.0; poses * m]);
    py.detach(|| {
        arm_core::cycle_returns(arm, &effects, alpha, mass, self_weight, &mut dx, &mut dy)
    })
    .map_err(PyArmError)?;
    Ok((
        dx.into_pyarray(py).reshape([poses, m])?,
        dy.into_pyarray(py).reshape([poses, m])?,
    ))
}
