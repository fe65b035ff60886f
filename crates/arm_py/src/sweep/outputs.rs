//! The output arrays of a sweep: fresh ones, or the caller's `out` dict borrowed for writing.

use crate::errors::value_error;
use arm_core::sweep::CellFields;
use numpy::{PyArrayDyn, PyArrayMethods, PyReadwriteArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The five cell fields of a sweep, in the order of `arm_core::sweep::CellFields`.
pub(crate) const CELL_KEYS: [&str; 5] = ["force_n", "dx_mm", "dy_mm", "dalpha_deg", "dl_mm"];
/// The per-pose outputs of a sweep (each optional in `out`).
pub(crate) const POSE_KEYS: [&str; 4] =
    ["length_mm", "reachable", "effector_x_mm", "effector_y_mm"];

/// Borrows `out[key]` for writing: a numpy array of dtype `T` (`dtype` names it in errors);
/// `None` when the key is absent and not `required`.
pub(crate) fn out_array<'py, T: numpy::Element>(
    out: &Bound<'py, PyDict>,
    key: &str,
    dtype: &str,
    required: bool,
) -> PyResult<Option<PyReadwriteArrayDyn<'py, T>>> {
    let Some(item) = out.get_item(key)? else {
        if required {
            return Err(value_error(format!("out: missing the array '{key}'")));
        }
        return Ok(None);
    };
    let arr = item.cast_into::<PyArrayDyn<T>>().map_err(|_| {
        value_error(format!(
            "out['{key}']: expected a numpy array of dtype {dtype}"
        ))
    })?;
    let rw = arr.try_readwrite().map_err(|_| {
        value_error(format!(
            "out['{key}']: the array is read-only or is borrowed elsewhere (given twice?)"
        ))
    })?;
    Ok(Some(rw))
}

/// The mutable contents of a borrowed output array (empty when absent).
pub(crate) fn out_slice<'a, T: numpy::Element>(
    a: &'a mut Option<PyReadwriteArrayDyn<'_, T>>,
    key: &str,
) -> PyResult<&'a mut [T]> {
    match a {
        None => Ok(&mut []),
        Some(a) => a
            .as_slice_mut()
            .map_err(|_| value_error(format!("out['{key}']: array must be C-contiguous"))),
    }
}

/// The five cell arrays of `out`, borrowed for writing.
pub(crate) type CellGuards<'py, T> = [Option<PyReadwriteArrayDyn<'py, T>>; 5];

pub(crate) fn cell_guards<'py, T: numpy::Element>(
    out: &Bound<'py, PyDict>,
    dtype: &str,
) -> PyResult<CellGuards<'py, T>> {
    let mut g: CellGuards<'py, T> = Default::default();
    for (slot, key) in g.iter_mut().zip(CELL_KEYS) {
        *slot = out_array(out, key, dtype, true)?;
    }
    Ok(g)
}

pub(crate) fn cell_fields<'a, T: numpy::Element>(
    g: &'a mut CellGuards<'_, T>,
) -> PyResult<CellFields<'a, T>> {
    let [f, x, y, a, l] = g;
    Ok(CellFields {
        force_n: out_slice(f, CELL_KEYS[0])?,
        dx_mm: out_slice(x, CELL_KEYS[1])?,
        dy_mm: out_slice(y, CELL_KEYS[2])?,
        dalpha_deg: out_slice(a, CELL_KEYS[3])?,
        dl_mm: out_slice(l, CELL_KEYS[4])?,
    })
}

/// A dict of fresh output arrays of a sweep: cell fields `lead` (+ `n`), `ok` and `status`
/// `lead`,
/// per-pose outputs for `poses` poses. Uninitialised (`numpy.empty`): no zeroing pass over
/// memory that the core overwrites anyway, and the arrays of one dtype are views of one
/// buffer, for which numpy asks the kernel for huge pages (ten separate arrays, none
/// aligned to 2 MB, would leave tens of MB on 4 kB pages and their page faults). The core
/// writes every element before the arrays are returned.
pub(crate) fn new_outputs<'py>(
    py: Python<'py>,
    lead: &[usize],
    poses: usize,
    n: usize,
    arg: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let empty = py.import("numpy")?.getattr("empty")?;
    let mut wide = lead.to_vec();
    wide.push(n);
    let cell_dtype = if arg { "int64" } else { "float64" };
    let mut arrays: Vec<(&str, Vec<usize>, &str)> = CELL_KEYS
        .iter()
        .map(|&key| {
            let shape = if matches!(key, "dx_mm" | "dy_mm") {
                lead.to_vec()
            } else {
                wide.clone()
            };
            (key, shape, cell_dtype)
        })
        .collect();
    arrays.push(("ok", lead.to_vec(), "bool"));
    arrays.push(("status", lead.to_vec(), "uint8"));
    arrays.push(("length_mm", vec![poses, n], "float64"));
    arrays.push(("reachable", vec![poses], "bool"));
    arrays.push(("effector_x_mm", vec![poses], "float64"));
    arrays.push(("effector_y_mm", vec![poses], "float64"));
    let out = PyDict::new(py);
    for dtype in ["float64", "int64", "bool", "uint8"] {
        let part: Vec<_> = arrays.iter().filter(|a| a.2 == dtype).collect();
        let total: usize = part.iter().map(|a| a.1.iter().product::<usize>()).sum();
        if part.is_empty() {
            continue;
        }
        let buf = empty.call1((total, dtype))?;
        let mut at = 0;
        for (key, shape, _) in part {
            let size: usize = shape.iter().product();
            let view = buf.get_item(pyo3::types::PySlice::new(
                py,
                isize::try_from(at)?,
                isize::try_from(at + size)?,
                1,
            ))?;
            out.set_item(*key, view.call_method1("reshape", (shape.clone(),))?)?;
            at += size;
        }
    }
    Ok(out)
}
