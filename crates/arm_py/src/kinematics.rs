//! Kinematics of the rigid arm: `forward`, `angles_from_lengths`, `inverse_kinematics`.

use crate::convert::{matrix, CoreArm};
use crate::errors::{value_error, PyArmError};
use arm_core::kinematics::{forward_batch, inverse_kinematics, ForwardOutput};
use arm_core::ArmError;
use numpy::{IntoPyArray, PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Global points of N poses: O (N, n+1, 2), A, B, C (N, n, 2), measure (N, 2), length_mm (N, n)
/// (`arm_core::kinematics::forward_batch`, into numpy-allocated arrays); A, B and length_mm
/// are NaN at joints turned by rotary drives (no actuator, no pins).
#[pyfunction]
pub(crate) fn forward<'py>(
    py: Python<'py>,
    arm: &CoreArm,
    alpha_deg: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let arm = &arm.inner;
    let n = arm.n();
    let (alpha, rows) = matrix(&alpha_deg, "alpha_deg", n)?;
    let shapes: [(&str, Vec<usize>); 6] = [
        ("O", vec![rows, n + 1, 2]),
        ("A", vec![rows, n, 2]),
        ("B", vec![rows, n, 2]),
        ("C", vec![rows, n, 2]),
        ("measure", vec![rows, 2]),
        ("length_mm", vec![rows, n]),
    ];
    let out = PyDict::new(py);
    let mut arrays = Vec::with_capacity(shapes.len());
    for (key, shape) in shapes {
        let a = PyArrayDyn::<f64>::zeros(py, shape, false);
        out.set_item(key, &a)?;
        arrays.push(a.readwrite());
    }
    let mut slices = Vec::with_capacity(arrays.len());
    for a in arrays.iter_mut() {
        slices.push(
            a.as_slice_mut()
                .map_err(|e| value_error(format!("forward: {e}")))?,
        );
    }
    let mut it = slices.into_iter();
    let mut next = || it.next().unwrap_or_default();
    let dst = ForwardOutput {
        o: next(),
        a: next(),
        b: next(),
        c: next(),
        measure: next(),
        length: next(),
    };
    py.detach(|| forward_batch(arm, alpha, dst))
        .map_err(PyArmError)?;
    Ok(out)
}

/// Absolute angles (N, n), degrees, of the rigid arm with these pin-to-pin lengths (see
/// `arm_core::kinematics::angles_from_lengths_batch`): the branch of the reference pose
/// `alpha_ref_deg`, one row for all or one per row. A joint turned by a rotary drive has no
/// length: its column must be NaN, and the joint keeps the reference pose's relative angle.
/// With `nan_on_failure`, rows that cannot close get NaN instead of an error.
#[pyfunction(name = "angles_from_lengths")]
#[pyo3(signature = (arm, length_mm, alpha_ref_deg, nan_on_failure=false))]
pub(crate) fn py_angles_from_lengths<'py>(
    py: Python<'py>,
    arm: &CoreArm,
    length_mm: PyReadonlyArray2<'py, f64>,
    alpha_ref_deg: PyReadonlyArray2<'py, f64>,
    nan_on_failure: bool,
) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
    let arm = &arm.inner;
    let n = arm.n();
    let (len, rows) = matrix(&length_mm, "length_mm", n)?;
    let (aref, rrows) = matrix(&alpha_ref_deg, "alpha_ref_deg", n)?;
    if rrows != rows && rrows != 1 {
        return Err(value_error(format!(
            "alpha_ref_deg: expected 1 or {rows} rows, got {rrows}"
        )));
    }
    let mut out = vec![0.0; rows * n];
    py.detach(|| {
        arm_core::kinematics::angles_from_lengths_batch(arm, len, aref, nan_on_failure, &mut out)
    })
    .map_err(PyArmError)?;
    out.into_pyarray(py).reshape([rows, n])
}

/// Angles (deg) and reachability flags of an inverse-kinematics batch.
type IkOut<'py> = (Bound<'py, numpy::PyArray2<f64>>, Bound<'py, PyArray1<bool>>);

/// Inverse kinematics (3 links): target (N, 3) = load point x, y (mm) and α₃ (deg).
/// Returns (alpha_deg (N, 3), reachable (N,)); unreachable rows are NaN.
#[pyfunction(name = "inverse_kinematics")]
pub(crate) fn py_inverse_kinematics<'py>(
    py: Python<'py>,
    arm: &CoreArm,
    target: PyReadonlyArray2<'py, f64>,
    elbow: f64,
) -> PyResult<IkOut<'py>> {
    let arm = &arm.inner;
    let (t, rows) = matrix(&target, "target", 3)?;
    let mut out = vec![f64::NAN; rows * 3];
    let mut ok = vec![false; rows];
    py.detach(|| -> Result<(), ArmError> {
        for row in 0..rows {
            let tr = [t[3 * row], t[3 * row + 1], t[3 * row + 2].to_radians()];
            if !tr.iter().all(|v| v.is_finite()) {
                return Err(ArmError::NonFinite {
                    row,
                    what: "target",
                });
            }
            let dst = &mut out[3 * row..3 * row + 3];
            if inverse_kinematics(arm, tr, elbow, dst)? {
                ok[row] = true;
                for v in dst.iter_mut() {
                    *v = v.to_degrees();
                }
            }
        }
        Ok(())
    })
    .map_err(PyArmError)?;
    Ok((
        out.into_pyarray(py).reshape([rows, 3])?,
        ok.into_pyarray(py),
    ))
}
