//! Kinematics of the rigid arm: `forward`, `angles_from_lengths`, `inverse_kinematics`.

use crate::convert::{matrix, CoreArm};
use crate::errors::{value_error, PyArmError};
use arm_core::kinematics::{inverse_kinematics, Frames};
use arm_core::{ArmError, V2};
use numpy::{IntoPyArray, PyArray1, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Global points of N poses: O (N, n+1, 2), A, B, C (N, n, 2), measure (N, 2), length_mm (N, n).
#[pyfunction]
pub(crate) fn forward<'py>(
    py: Python<'py>,
    arm: &CoreArm,
    alpha_deg: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let arm = &arm.inner;
    let n = arm.n();
    let (alpha, rows) = matrix(&alpha_deg, "alpha_deg", n)?;
    let mut o = vec![0.0; rows * (n + 1) * 2];
    let mut a = vec![0.0; rows * n * 2];
    let mut b = vec![0.0; rows * n * 2];
    let mut c = vec![0.0; rows * n * 2];
    let mut m = vec![0.0; rows * 2];
    let mut len = vec![0.0; rows * n];
    py.detach(|| -> Result<(), ArmError> {
        let mut fr = Frames::new(n);
        let mut rad = vec![0.0; n];
        for row in 0..rows {
            let src = &alpha[row * n..(row + 1) * n];
            if !src.iter().all(|v| v.is_finite()) {
                return Err(ArmError::NonFinite {
                    row,
                    what: "alpha_deg",
                });
            }
            for (r, d) in rad.iter_mut().zip(src) {
                *r = d.to_radians();
            }
            fr.fill(arm, &rad);
            let put = |dst: &mut [f64], k: usize, p: V2| {
                dst[2 * k] = p.x;
                dst[2 * k + 1] = p.y;
            };
            for i in 0..=n {
                put(&mut o, row * (n + 1) + i, fr.joint[i]);
            }
            for i in 0..n {
                put(&mut a, row * n + i, fr.a[i]);
                put(&mut b, row * n + i, fr.b[i]);
                put(&mut c, row * n + i, fr.c[i]);
                len[row * n + i] = fr.length(i);
            }
            put(&mut m, row, fr.measure);
        }
        Ok(())
    })
    .map_err(PyArmError)?;
    let out = PyDict::new(py);
    out.set_item("O", o.into_pyarray(py).reshape([rows, n + 1, 2])?)?;
    out.set_item("A", a.into_pyarray(py).reshape([rows, n, 2])?)?;
    out.set_item("B", b.into_pyarray(py).reshape([rows, n, 2])?)?;
    out.set_item("C", c.into_pyarray(py).reshape([rows, n, 2])?)?;
    out.set_item("measure", m.into_pyarray(py).reshape([rows, 2])?)?;
    out.set_item("length_mm", len.into_pyarray(py).reshape([rows, n])?)?;
    Ok(out)
}

/// Absolute angles (N, n), degrees, of the rigid arm with these pin-to-pin lengths (see
/// `arm_core::kinematics::angles_from_lengths_batch`): the branch of the reference pose
/// `alpha_ref_deg`, one row for all or one per row. With `nan_on_failure`, rows that cannot
/// close get NaN instead of an error.
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
