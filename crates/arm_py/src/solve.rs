//! `solve`: the analytic model over N poses (with the extra deformations of user effects), and
//! `statics`: the forces of both states that those effects read.

use crate::convert::{effect_set, matrix, optional, poses_and_payloads, CoreArm};
use crate::errors::{value_error, PyArmError};
use arm_core::{BatchInput, BatchOutput, ExtraDeformations, Masses, SolveOptions, StaticsBuffers};
use numpy::{
    IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArrayDyn,
    PyReadwriteArrayDyn, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The float64 outputs of `solve` and their shapes in rows N and links n (`0` = N, `1` = n,
/// `2` = 2).
const OUT_KEYS: [(&str, &[u8]); 11] = [
    ("force_n", &[0, 1]),
    ("reaction_n", &[0, 1, 2]),
    ("dforce_n", &[0, 1]),
    ("torque_nmm", &[0, 1]),
    ("dtorque_nmm", &[0, 1]),
    ("dx_mm", &[0]),
    ("dy_mm", &[0]),
    ("dalpha_deg", &[0, 1]),
    ("dl_mm", &[0, 1]),
    ("dlength_mm", &[0, 1]),
    ("length_mm", &[0, 1]),
];

/// Which of [`OUT_KEYS`] are asked for: every one without `outputs`, else those it names
/// (`status` is always returned, naming it changes nothing); an unknown name is a one-line
/// error listing the known ones.
pub(crate) fn asked(outputs: Option<Vec<String>>) -> PyResult<[bool; OUT_KEYS.len()]> {
    let Some(names) = outputs else {
        return Ok([true; OUT_KEYS.len()]);
    };
    let mut asked = [false; OUT_KEYS.len()];
    for name in &names {
        match OUT_KEYS.iter().position(|(key, _)| key == name) {
            Some(k) => asked[k] = true,
            None if name == "status" => {}
            None => {
                let known: Vec<&str> = OUT_KEYS.iter().map(|(key, _)| *key).collect();
                return Err(value_error(format!(
                    "outputs: unknown key {name:?}; expected some of {}, status",
                    known.join(", ")
                )));
            }
        }
    }
    Ok(asked)
}

/// The caller's output arrays of the keys `asked` (None for the others), borrowed writeable
/// after their keys, dtypes and shapes were checked (a one-line error naming the key
/// otherwise: missing, of the wrong shape or dtype, or present but not asked for).
#[allow(clippy::type_complexity)]
fn borrow_out<'py>(
    out: &Bound<'py, PyDict>,
    rows: usize,
    n: usize,
    asked: &[bool; OUT_KEYS.len()],
) -> PyResult<(
    Vec<Option<PyReadwriteArrayDyn<'py, f64>>>,
    PyReadwriteArrayDyn<'py, u8>,
)> {
    let get = |key: &str| -> PyResult<Bound<'py, PyAny>> {
        out.get_item(key)?
            .ok_or_else(|| value_error(format!("out: missing key {key:?}")))
    };
    let mut arrays = Vec::with_capacity(OUT_KEYS.len());
    for ((key, code), &wanted) in OUT_KEYS.iter().zip(asked) {
        if !wanted {
            if out.contains(key)? {
                return Err(value_error(format!(
                    "out[{key:?}]: not among the outputs asked for"
                )));
            }
            arrays.push(None);
            continue;
        }
        let want = dims(code, rows, n);
        let a = get(key)?
            .extract::<PyReadwriteArrayDyn<'py, f64>>()
            .map_err(|_| {
                value_error(format!(
                    "out[{key:?}]: expected a writeable float64 array of shape {want:?} \
                     (not shared with another key)"
                ))
            })?;
        if a.shape() != want.as_slice() || !a.is_c_contiguous() {
            return Err(value_error(format!(
                "out[{key:?}]: expected a C-contiguous array of shape {want:?}, got {:?}",
                a.shape()
            )));
        }
        arrays.push(Some(a));
    }
    let status = get("status")?
        .extract::<PyReadwriteArrayDyn<'py, u8>>()
        .map_err(|_| {
            value_error(format!(
                "out[\"status\"]: expected a writeable uint8 array of shape [{rows}]"
            ))
        })?;
    if status.shape() != [rows] || !status.is_c_contiguous() {
        return Err(value_error(format!(
            "out[\"status\"]: expected a C-contiguous array of shape [{rows}], got {:?}",
            status.shape()
        )));
    }
    Ok((arrays, status))
}

/// Solves N poses; returns a dict of float64 arrays and the uint8 `status` per pose (see
/// `eodarm.solve`). With `outputs` (a list of those keys) only those arrays and `status` are
/// allocated, written and returned. With `out` (a dict of C-contiguous writeable arrays of
/// those keys, shapes and dtypes) the results are written into the caller's arrays, and that
/// dict is returned.
///
/// The keyword-only `extra_*` arrays (float64, C-contiguous, each optional) are deformations
/// of user-written effects added to the built-in effects' (global frame, see
/// `arm_core::ExtraDeformations`): `extra_seen_mm` (N, n) pin-to-pin length change that the
/// actuator's sensor sees, `extra_unseen_mm` (N, n) one it does not see (both zero at rotary
/// drives), `extra_turn_rad` (N, n) turn of link i against body i−1 at a rotary drive (zero
/// at linear actuators), `extra_joint_mm` (N, n, 2) offset of link i's pin centre at O_i,
/// `extra_tilt_rad` (N,) chassis tilt about the base pivot, `extra_measure_mm` (N, 2)
/// displacement of the measure point.
///
/// `payload_n` may be None with the keyword `mass_kg` instead: a float (every pose) or an
/// (N,) float64 array of payload masses (kg) whose weight `m·g` acts downward (`g` of the
/// arm), as `eodarm.solve` takes them; the force rows are then made a chunk at a time in the
/// core, never for the whole batch. Not with the `extra_*` arrays.
#[pyfunction]
#[pyo3(signature = (arm, alpha_deg, payload_n, codes, places, values, self_weight, nan_on_failure=false, *, mass_kg=None, extra_seen_mm=None, extra_unseen_mm=None, extra_joint_mm=None, extra_tilt_rad=None, extra_measure_mm=None, extra_turn_rad=None, out=None, outputs=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve<'py>(
    py: Python<'py>,
    arm: &CoreArm,
    alpha_deg: PyReadonlyArray2<'py, f64>,
    payload_n: Option<PyReadonlyArray2<'py, f64>>,
    codes: PyReadonlyArray1<'py, i64>,
    places: PyReadonlyArray1<'py, i64>,
    values: PyReadonlyArray1<'py, f64>,
    self_weight: bool,
    nan_on_failure: bool,
    mass_kg: Option<Bound<'py, PyAny>>,
    extra_seen_mm: Option<PyReadonlyArrayDyn<'py, f64>>,
    extra_unseen_mm: Option<PyReadonlyArrayDyn<'py, f64>>,
    extra_joint_mm: Option<PyReadonlyArrayDyn<'py, f64>>,
    extra_tilt_rad: Option<PyReadonlyArrayDyn<'py, f64>>,
    extra_measure_mm: Option<PyReadonlyArrayDyn<'py, f64>>,
    extra_turn_rad: Option<PyReadonlyArrayDyn<'py, f64>>,
    out: Option<Bound<'py, PyDict>>,
    outputs: Option<Vec<String>>,
) -> PyResult<Bound<'py, PyDict>> {
    let arm = &arm.inner;
    let asked = asked(outputs)?;
    let n = arm.n();
    let effects = effect_set(arm, &codes, &places, &values, true)?;
    let opts = SolveOptions {
        self_weight,
        nan_on_failure,
    };
    // a mass per pose, borrowed for the call (a float is read below)
    let per_pose = mass_kg
        .as_ref()
        .and_then(|m| m.extract::<PyReadonlyArray1<'py, f64>>().ok());
    let (rows, given) = match (&payload_n, &mass_kg) {
        (Some(payload_n), None) => {
            let input = poses_and_payloads(&alpha_deg, payload_n, n)?;
            let rows = input.payload_n.len() / 2;
            let extra = ExtraDeformations {
                seen_mm: optional(&extra_seen_mm, "extra_seen_mm", &[rows, n], "(N, n)")?,
                unseen_mm: optional(&extra_unseen_mm, "extra_unseen_mm", &[rows, n], "(N, n)")?,
                turn_rad: optional(&extra_turn_rad, "extra_turn_rad", &[rows, n], "(N, n)")?,
                joint_mm: optional(
                    &extra_joint_mm,
                    "extra_joint_mm",
                    &[rows, n, 2],
                    "(N, n, 2)",
                )?,
                tilt_rad: optional(&extra_tilt_rad, "extra_tilt_rad", &[rows], "(N,)")?,
                measure_mm: optional(&extra_measure_mm, "extra_measure_mm", &[rows, 2], "(N, 2)")?,
            };
            (rows, Given::Forces(input, extra))
        }
        (None, Some(m)) => {
            let extras = [
                &extra_seen_mm,
                &extra_unseen_mm,
                &extra_joint_mm,
                &extra_tilt_rad,
                &extra_measure_mm,
                &extra_turn_rad,
            ];
            if extras.iter().any(|e| e.is_some()) {
                return Err(value_error(
                    "mass_kg: give payload_n with the extra_* arrays".into(),
                ));
            }
            let (alpha, rows) = matrix(&alpha_deg, "alpha_deg", n)?;
            let masses = match &per_pose {
                Some(a) => Masses::Each(
                    a.as_slice()
                        .map_err(|_| value_error("mass_kg: array must be C-contiguous".into()))?,
                ),
                None => Masses::All(m.extract::<f64>().map_err(|_| {
                    value_error("mass_kg: expected a float or an (N,) float64 array".into())
                })?),
            };
            (rows, Given::Masses(alpha, masses))
        }
        _ => {
            return Err(value_error(
                "give exactly one of payload_n and mass_kg".into(),
            ))
        }
    };
    // Without `out`, numpy allocates the outputs ([`new_out`]) and they are filled as the
    // caller's would be.
    let dict = match out {
        Some(dict) => dict,
        None => new_out(py, rows, n, &asked)?,
    };
    fill_out(py, &dict, rows, n, &asked, |batch, st| match given {
        Given::Forces(input, extra) => {
            arm_core::solve_batch_status(arm, &effects, input, extra, opts, batch, st)
        }
        Given::Masses(alpha, masses) => {
            arm_core::solve_batch_masses(arm, &effects, alpha, masses, opts, batch, st)
        }
    })?;
    Ok(dict)
}

/// The payloads of a `solve` call as given: force rows (with any extra deformations), or
/// masses of the poses `alpha_deg`.
enum Given<'a> {
    Forces(BatchInput<'a>, ExtraDeformations<'a>),
    Masses(&'a [f64], Masses<'a>),
}

/// Runs `solve` (without the GIL) on the arrays of `dict` (checked by [`borrow_out`]) lent as
/// one [`BatchOutput`] (an empty slice where an output is not `asked`) and its status.
pub(crate) fn fill_out<'py, F>(
    py: Python<'py>,
    dict: &Bound<'py, PyDict>,
    rows: usize,
    n: usize,
    asked: &[bool; OUT_KEYS.len()],
    solve: F,
) -> PyResult<()>
where
    F: FnOnce(BatchOutput<'_>, &mut [u8]) -> arm_core::Result<()> + Send,
{
    let (mut arrays, mut status) = borrow_out(dict, rows, n, asked)?;
    let mut slices: Vec<&mut [f64]> = Vec::with_capacity(arrays.len());
    for a in arrays.iter_mut() {
        slices.push(match a {
            Some(a) => a
                .as_slice_mut()
                .map_err(|e| value_error(format!("out: {e}")))?,
            None => &mut [],
        });
    }
    let st = status
        .as_slice_mut()
        .map_err(|e| value_error(format!("out: {e}")))?;
    let mut it = slices.into_iter();
    let mut next = || it.next().unwrap_or_default();
    let batch = BatchOutput {
        force_n: next(),
        reaction_n: next(),
        dforce_n: next(),
        torque_nmm: next(),
        dtorque_nmm: next(),
        dx_mm: next(),
        dy_mm: next(),
        dalpha_deg: next(),
        dl_mm: next(),
        dlength_mm: next(),
        length_mm: next(),
    };
    py.detach(|| solve(batch, st)).map_err(PyArmError)?;
    Ok(())
}

/// Uninitialised numpy output arrays (`numpy.empty`, as a caller's `out=` would be) of
/// `solve` for `rows` poses of an `n`-link arm: those `asked` for, and `status`. The kernel
/// writes every element of them, whatever fails (`arm_core/tests/kernel_mixed.rs` checks),
/// so zeroed arrays would cost a pass for nothing: `calloc` clears memory that the heap
/// hands back rather than fresh from the kernel.
pub(crate) fn new_out<'py>(
    py: Python<'py>,
    rows: usize,
    n: usize,
    asked: &[bool; OUT_KEYS.len()],
) -> PyResult<Bound<'py, PyDict>> {
    let empty = py.import("numpy")?.getattr("empty")?;
    let d = PyDict::new(py);
    for ((key, code), _) in OUT_KEYS.iter().zip(asked).filter(|(_, &a)| a) {
        d.set_item(key, empty.call1((dims(code, rows, n),))?)?;
    }
    d.set_item("status", empty.call1(((rows,), "u1"))?)?;
    Ok(d)
}

/// The shape of an output from its code in [`OUT_KEYS`].
fn dims(code: &[u8], rows: usize, n: usize) -> Vec<usize> {
    code.iter()
        .map(|c| match c {
            0 => rows,
            1 => n,
            _ => 2,
        })
        .collect()
}

/// Statics of N poses on the undeformed geometry (see `arm_core::statics_batch`): a dict of
/// float64 arrays `force_n`, `force0_n` (N, n) loaded and unloaded actuator forces
/// (compression +; NaN at rotary drives), `torque_nmm`, `torque0_nmm` (N, n) loaded and
/// unloaded drive torques (N·mm, counter-clockwise + on link i; NaN at linear actuators),
/// `reaction_n`, `reaction0_n` (N, n, 2) loaded and unloaded joint reactions (force of body
/// i−1 on link i, global), `length_mm` (N, n) unloaded pin-to-pin lengths (NaN at rotary
/// drives).
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
        "torque_nmm",
        b.torque_nmm.into_pyarray(py).reshape([rows, n])?,
    )?;
    out.set_item(
        "torque0_nmm",
        b.torque0_nmm.into_pyarray(py).reshape([rows, n])?,
    )?;
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
