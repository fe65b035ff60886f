//! Conversions at the boundary: numpy arrays to slices, the arm (`CoreArm`), the effect arrays
//! and the poses of a batch in; the outputs of a solve out as a dict of arrays.

use crate::errors::{value_error, PyArmError};
use arm_core::effects::{Effect, EffectSet};
use arm_core::{Actuator, Arm, BatchBuffers, BatchInput, Drive, Link, RotaryDrive, V2};
use numpy::{
    IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArrayDyn,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Borrows a C-contiguous float64 array of shape `(rows, cols)` as a slice.
pub(crate) fn matrix<'a>(
    a: &'a PyReadonlyArray2<'_, f64>,
    name: &str,
    cols: usize,
) -> PyResult<(&'a [f64], usize)> {
    let shape = a.shape();
    if shape[1] != cols {
        return Err(value_error(format!(
            "{name}: expected shape (N, {cols}), got ({}, {})",
            shape[0], shape[1]
        )));
    }
    let s = a
        .as_slice()
        .map_err(|_| value_error(format!("{name}: array must be C-contiguous")))?;
    Ok((s, shape[0]))
}

/// Borrows an optional C-contiguous float64 array of exactly `shape` as a slice (`None` when
/// absent); `dims` spells the expected shape in the error, e.g. `(N, n, 2)`.
pub(crate) fn optional<'a>(
    a: &'a Option<PyReadonlyArrayDyn<'_, f64>>,
    name: &str,
    shape: &[usize],
    dims: &str,
) -> PyResult<Option<&'a [f64]>> {
    let Some(a) = a else { return Ok(None) };
    if a.shape() != shape {
        return Err(value_error(format!(
            "{name}: expected shape {dims} = {shape:?}, got {:?}",
            a.shape()
        )));
    }
    let s = a
        .as_slice()
        .map_err(|_| value_error(format!("{name}: array must be C-contiguous")))?;
    Ok(Some(s))
}

pub(crate) fn vector<'a>(
    a: &'a PyReadonlyArray1<'_, f64>,
    name: &str,
    len: usize,
) -> PyResult<&'a [f64]> {
    let s = a
        .as_slice()
        .map_err(|_| value_error(format!("{name}: array must be contiguous")))?;
    if s.len() != len {
        return Err(value_error(format!(
            "{name}: expected {len} values, got {}",
            s.len()
        )));
    }
    Ok(s)
}

pub(crate) fn opt(v: f64) -> Option<f64> {
    (!v.is_nan()).then_some(v)
}

/// An arm in the core's form, built from the arrays of `eodarm.Arm.arrays()`. Each joint's
/// drive is a linear actuator (`kind` 0, the default) or a rotary drive (`kind` 1); a
/// rotary drive's `stiffness` is in N·mm/rad, its limits in `max_torque` (N·mm) and
/// `min_angle_deg`, `max_angle_deg` (degrees), NaN where absent; the pins it does not use
/// (`A`, `B`, `b0`) are ignored.
#[pyclass(frozen, name = "CoreArm", module = "eodarm._core")]
pub(crate) struct CoreArm {
    pub(crate) inner: Arm,
}

#[pymethods]
impl CoreArm {
    /// Builds and validates the arm; optional limits are NaN when absent.
    #[new]
    #[pyo3(signature = (g, o1, b0, pivot, next, a, b, c, link_mass, measure, stiffness, act_mass, min_length, max_length, max_force, *, kind=None, max_torque=None, min_angle_deg=None, max_angle_deg=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        g: f64,
        o1: [f64; 2],
        b0: [f64; 2],
        pivot: [f64; 2],
        next: PyReadonlyArray2<'_, f64>,
        a: PyReadonlyArray2<'_, f64>,
        b: PyReadonlyArray2<'_, f64>,
        c: PyReadonlyArray2<'_, f64>,
        link_mass: PyReadonlyArray1<'_, f64>,
        measure: [f64; 2],
        stiffness: PyReadonlyArray1<'_, f64>,
        act_mass: PyReadonlyArray1<'_, f64>,
        min_length: PyReadonlyArray1<'_, f64>,
        max_length: PyReadonlyArray1<'_, f64>,
        max_force: PyReadonlyArray1<'_, f64>,
        kind: Option<PyReadonlyArray1<'_, f64>>,
        max_torque: Option<PyReadonlyArray1<'_, f64>>,
        min_angle_deg: Option<PyReadonlyArray1<'_, f64>>,
        max_angle_deg: Option<PyReadonlyArray1<'_, f64>>,
    ) -> PyResult<Self> {
        let (next, n) = matrix(&next, "next", 2)?;
        let (a, _) = matrix(&a, "A", 2)?;
        let (b, _) = matrix(&b, "B", 2)?;
        let (c, _) = matrix(&c, "C", 2)?;
        let p = |s: &[f64], i: usize| -> PyResult<V2> {
            s.get(2 * i..2 * i + 2)
                .map(|v| V2::new(v[0], v[1]))
                .ok_or_else(|| value_error(format!("link arrays: expected {n} rows")))
        };
        let link_mass = vector(&link_mass, "link_mass", n)?;
        let mut links = Vec::with_capacity(n);
        for (i, &mass_kg) in link_mass.iter().enumerate() {
            links.push(Link {
                next: p(next, i)?,
                a: p(a, i)?,
                b: p(b, i)?,
                c: p(c, i)?,
                mass_kg,
            });
        }
        let k = vector(&stiffness, "stiffness", n)?;
        let m = vector(&act_mass, "act_mass", n)?;
        let lo = vector(&min_length, "min_length", n)?;
        let hi = vector(&max_length, "max_length", n)?;
        let fmax = vector(&max_force, "max_force", n)?;
        let nan = vec![f64::NAN; n];
        let or_nan = |a: &'_ Option<PyReadonlyArray1<'_, f64>>, name: &str| -> PyResult<Vec<f64>> {
            match a {
                Some(a) => Ok(vector(a, name, n)?.to_vec()),
                None => Ok(nan.clone()),
            }
        };
        let kinds = match &kind {
            Some(a) => vector(a, "kind", n)?.to_vec(),
            None => vec![0.0; n],
        };
        let tmax = or_nan(&max_torque, "max_torque")?;
        let qlo = or_nan(&min_angle_deg, "min_angle_deg")?;
        let qhi = or_nan(&max_angle_deg, "max_angle_deg")?;
        let mut drives = Vec::with_capacity(n);
        for (i, &kind) in kinds.iter().enumerate() {
            drives.push(if kind == 0.0 {
                Drive::Linear(Actuator {
                    stiffness: k[i],
                    mass_kg: m[i],
                    min_length: opt(lo[i]),
                    max_length: opt(hi[i]),
                    max_force: opt(fmax[i]),
                })
            } else if kind == 1.0 {
                Drive::Rotary(RotaryDrive {
                    stiffness: k[i],
                    mass_kg: m[i],
                    max_torque: opt(tmax[i]),
                    min_angle: opt(qlo[i]).map(f64::to_radians),
                    max_angle: opt(qhi[i]).map(f64::to_radians),
                })
            } else {
                return Err(value_error(format!(
                    "kind of joint {}: expected 0 (linear) or 1 (rotary), got {kind}",
                    i + 1
                )));
            });
        }
        let v = |q: [f64; 2]| V2::new(q[0], q[1]);
        let inner = Arm::with_drives(g, v(o1), v(b0), v(pivot), links, drives, v(measure))
            .map_err(PyArmError)?;
        Ok(Self { inner })
    }

    /// Number of links.
    #[getter]
    fn n(&self) -> usize {
        self.inner.n()
    }

    /// Each joint's kind of drive: `"linear"` or `"rotary"`.
    #[getter]
    fn kinds(&self) -> Vec<&'static str> {
        self.inner.drives.iter().map(Drive::kind).collect()
    }
}

/// The effects of the arrays; `checked: false` leaves the parameter values to the caller (the
/// FE model takes an infinite stiffness as rigid, the fit's θ = 0).
pub(crate) fn effect_set(
    arm: &Arm,
    codes: &PyReadonlyArray1<'_, i64>,
    places: &PyReadonlyArray1<'_, i64>,
    values: &PyReadonlyArray1<'_, f64>,
    checked: bool,
) -> PyResult<EffectSet> {
    let err = |_| value_error("effect arrays must be contiguous".into());
    let (codes, places, values) = (
        codes.as_slice().map_err(err)?,
        places.as_slice().map_err(err)?,
        values.as_slice().map_err(err)?,
    );
    if codes.len() != places.len() || codes.len() != values.len() {
        return Err(value_error("effect arrays differ in length".into()));
    }
    let mut effects = Vec::with_capacity(codes.len());
    for ((&code, &place), &value) in codes.iter().zip(places).zip(values) {
        let place = usize::try_from(place)
            .map_err(|_| value_error(format!("effect place index {place} is negative")))?;
        effects.push(Effect::from_code(code, place, value).map_err(PyArmError)?);
    }
    let set = if checked {
        EffectSet::new(arm, effects)
    } else {
        EffectSet::new_unchecked(arm, effects)
    };
    Ok(set.map_err(PyArmError)?)
}

/// The outputs of `eodarm.solve` that both models fill (`arm_core::BatchBuffers`) as a dict
/// of float64 arrays: `force_n`, `dforce_n`, `torque_nmm`, `dtorque_nmm`, `dalpha_deg`,
/// `dl_mm`, `dlength_mm`, `length_mm` (rows, n), `reaction_n` (rows, n, 2), `dx_mm`, `dy_mm`
/// (rows,).
pub(crate) fn solve_dict<'py>(
    py: Python<'py>,
    b: BatchBuffers,
    rows: usize,
    n: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let per_link = |v: Vec<f64>| v.into_pyarray(py).reshape([rows, n]);
    let out = PyDict::new(py);
    out.set_item("force_n", per_link(b.force_n)?)?;
    out.set_item(
        "reaction_n",
        b.reaction_n.into_pyarray(py).reshape([rows, n, 2])?,
    )?;
    out.set_item("dforce_n", per_link(b.dforce_n)?)?;
    out.set_item("torque_nmm", per_link(b.torque_nmm)?)?;
    out.set_item("dtorque_nmm", per_link(b.dtorque_nmm)?)?;
    out.set_item("dx_mm", b.dx_mm.into_pyarray(py))?;
    out.set_item("dy_mm", b.dy_mm.into_pyarray(py))?;
    out.set_item("dalpha_deg", per_link(b.dalpha_deg)?)?;
    out.set_item("dl_mm", per_link(b.dl_mm)?)?;
    out.set_item("dlength_mm", per_link(b.dlength_mm)?)?;
    out.set_item("length_mm", per_link(b.length_mm)?)?;
    Ok(out)
}

/// The poses (N × n angles) and payloads (N × 2) of a solve, checked to have the same rows.
pub(crate) fn poses_and_payloads<'a>(
    alpha_deg: &'a PyReadonlyArray2<'_, f64>,
    payload_n: &'a PyReadonlyArray2<'_, f64>,
    n: usize,
) -> PyResult<BatchInput<'a>> {
    let (alpha, rows) = matrix(alpha_deg, "alpha_deg", n)?;
    let (payload, prow) = matrix(payload_n, "payload_n", 2)?;
    if prow != rows {
        return Err(value_error(format!(
            "payload_n: expected {rows} rows, got {prow}"
        )));
    }
    Ok(BatchInput {
        alpha_deg: alpha,
        payload_n: payload,
    })
}
