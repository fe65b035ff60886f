//! `sweep`: N poses × M payload masses written into (possibly caller-given) output arrays,
//! with progress reports and Ctrl-C between the core's chunks.

mod outputs;

use crate::convert::{effect_set, matrix, CoreArm};
use crate::errors::{value_error, PyArmError};
use arm_core::sweep::{Cells, Grid, Poses, Reduce, ReduceOp, SweepOptions, SweepOut};
use arm_core::ArmError;
use numpy::{PyReadonlyArray1, PyReadonlyArray2};
use outputs::{cell_fields, cell_guards, new_outputs, out_array, out_slice, POSE_KEYS};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Mutex;

/// A sweep's `grid` argument: (axes, links, start, count).
type GridArg<'py> = (Vec<PyReadonlyArray1<'py, f64>>, Vec<usize>, usize, usize);

/// Seconds between two calls of a sweep's `progress` callback.
const PROGRESS_EVERY_S: f64 = 0.1;

/// Sweeps N poses × M payload masses (see `arm_core::sweep`); returns a dict of arrays.
///
/// The poses are `alpha_deg` (N × n), or `grid = (axes, links, start, count)`: flat poses
/// `start .. start + count` of the C-order grid of the 1-D `axes` (dimension d sets the angle
/// of link `links[d]`), generated in the core chunk by chunk. Cell arrays are (N, M[, n]), or
/// (N·M/group[, n]) with `reduce` ("max", "min", "argmax", "argmin"; the arg reductions give
/// int64 offsets within each group, −1 where the group has no value).
///
/// Every cell gets a `status` (uint8, `arm_core::validity` codes; reduced: 0 when every cell
/// of the group is ok, else the lowest code among those that are not); `ok` is status == 0,
/// and the values of cells that are not ok are NaN and skipped by the reductions.
///
/// `out`: a dict of C-contiguous arrays to write into instead (any shape with the right
/// number of elements; the cell arrays and `ok` required, `status` and the per-pose arrays
/// optional; with a
/// reduction over whole poses, `reachable` may hold one value per group: any pose of it
/// reachable); it is returned. `mask_unreachable`: cells of poses out of stroke are not
/// solved. `progress(done_poses)` is called before the first chunk (with 0), then every 0.1 s or so. `chunk_rows`: rows per chunk
/// of the core (default `arm_core::sweep::CHUNK_ROWS`, less for small sweeps). The GIL is released while the
/// core works; Ctrl-C (or an exception in `progress`) stops it between chunks.
#[pyfunction(name = "sweep")]
#[pyo3(signature = (arm, alpha_deg, mass_kg, codes, places, values, self_weight, reduce=None, group=1, threads=None, *, grid=None, out=None, mask_unreachable=false, progress=None, chunk_rows=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn py_sweep<'py>(
    py: Python<'py>,
    arm: &CoreArm,
    alpha_deg: Option<PyReadonlyArray2<'py, f64>>,
    mass_kg: PyReadonlyArray1<'py, f64>,
    codes: PyReadonlyArray1<'py, i64>,
    places: PyReadonlyArray1<'py, i64>,
    values: PyReadonlyArray1<'py, f64>,
    self_weight: bool,
    reduce: Option<&str>,
    group: i64,
    threads: Option<i64>,
    grid: Option<GridArg<'py>>,
    out: Option<Bound<'py, PyDict>>,
    mask_unreachable: bool,
    progress: Option<Py<PyAny>>,
    chunk_rows: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let arm = &arm.inner;
    let n = arm.n();
    let mass = mass_kg
        .as_slice()
        .map_err(|_| value_error("mass_kg: array must be contiguous".into()))?;
    let effects = effect_set(arm, &codes, &places, &values, true)?;
    let op = match reduce {
        None => None,
        Some("max") => Some(ReduceOp::Max),
        Some("min") => Some(ReduceOp::Min),
        Some("argmax") => Some(ReduceOp::ArgMax),
        Some("argmin") => Some(ReduceOp::ArgMin),
        Some(other) => {
            return Err(value_error(format!(
                "reduce: expected 'max', 'min', 'argmax' or 'argmin', got {other:?}"
            )))
        }
    };
    let group = usize::try_from(group)
        .ok()
        .filter(|&g| g >= 1)
        .ok_or_else(|| value_error(format!("group must be >= 1, got {group}")))?;
    let threads = match threads {
        None => None,
        Some(k) => Some(
            usize::try_from(k)
                .ok()
                .filter(|&k| k >= 1)
                .ok_or_else(|| value_error(format!("threads must be >= 1, got {k}")))?,
        ),
    };
    let opts = SweepOptions {
        self_weight,
        reduce: op.map(|op| Reduce { op, group }),
        threads,
        mask_unreachable,
        chunk_rows,
        ..Default::default()
    };
    // The poses: rows, or a grid (its axes borrowed for the whole call).
    let (rows_in, grid_axes) = match (&alpha_deg, &grid) {
        (Some(a), None) => (Some(matrix(a, "alpha_deg", n)?), None),
        (None, Some((axes, links, start, count))) => {
            let mut views = Vec::with_capacity(axes.len());
            for (d, a) in axes.iter().enumerate() {
                views.push(
                    a.as_slice()
                        .map_err(|_| value_error(format!("grid axis {d}: must be contiguous")))?,
                );
            }
            (None, Some((views, links.as_slice(), *start, *count)))
        }
        _ => return Err(value_error(
            "sweep: give exactly one of alpha_deg (an array) and grid=(axes, links, start, count)"
                .into(),
        )),
    };
    let poses = match (&rows_in, &grid_axes) {
        (Some((_, p)), _) => *p,
        (_, Some((_, _, _, count))) => *count,
        _ => 0,
    };
    let arg = op.is_some_and(ReduceOp::is_arg);
    let out = match out {
        Some(o) => o,
        None => {
            let rows = poses * mass.len() / if op.is_some() { group } else { 1 };
            let lead: Vec<usize> = if op.is_some() {
                vec![rows]
            } else {
                vec![poses, mass.len()]
            };
            new_outputs(py, &lead, poses, n, arg)?
        }
    };
    let interrupt: Mutex<Option<PyErr>> = Mutex::new(None);
    // The first report comes at the first check, then one per PROGRESS_EVERY_S.
    let last_report: Mutex<Option<std::time::Instant>> = Mutex::new(None);
    let cancel = |done: usize| {
        Python::attach(|py| {
            let mut r = py.check_signals();
            if let (Ok(()), Some(cb)) = (&r, &progress) {
                let mut last = last_report.lock().unwrap_or_else(|e| e.into_inner());
                if last.is_none_or(|t| t.elapsed().as_secs_f64() >= PROGRESS_EVERY_S) {
                    *last = Some(std::time::Instant::now());
                    r = cb.call1(py, (done,)).map(|_| ());
                }
            }
            match r {
                Ok(()) => false,
                Err(e) => {
                    if let Ok(mut slot) = interrupt.lock() {
                        *slot = Some(e);
                    }
                    true
                }
            }
        })
    };
    let result = {
        let (mut vg, mut ig) = if arg {
            (Default::default(), cell_guards::<i64>(&out, "int64")?)
        } else {
            (cell_guards::<f64>(&out, "float64")?, Default::default())
        };
        let cells = if arg {
            Cells::Indices(cell_fields(&mut ig)?)
        } else {
            Cells::Values(cell_fields(&mut vg)?)
        };
        let mut okg = out_array::<bool>(&out, "ok", "bool", true)?;
        let mut sg = out_array::<u8>(&out, "status", "uint8", false)?;
        let mut lg = out_array::<f64>(&out, POSE_KEYS[0], "float64", false)?;
        let mut rg = out_array::<bool>(&out, POSE_KEYS[1], "bool", false)?;
        let mut xg = out_array::<f64>(&out, POSE_KEYS[2], "float64", false)?;
        let mut yg = out_array::<f64>(&out, POSE_KEYS[3], "float64", false)?;
        let sweep_out = SweepOut {
            cells,
            ok: out_slice(&mut okg, "ok")?,
            status: out_slice(&mut sg, "status")?,
            length_mm: out_slice(&mut lg, POSE_KEYS[0])?,
            reachable: out_slice(&mut rg, POSE_KEYS[1])?,
            effector_x_mm: out_slice(&mut xg, POSE_KEYS[2])?,
            effector_y_mm: out_slice(&mut yg, POSE_KEYS[3])?,
        };
        let grid_src = grid_axes.as_ref().map(|(views, links, start, count)| Grid {
            axes: views,
            links,
            start: *start,
            count: *count,
        });
        let src = match (&rows_in, grid_src) {
            (Some((a, _)), _) => Poses::Rows(a),
            (None, Some(g)) => Poses::Grid(g),
            (None, None) => return Err(value_error("sweep: no poses".into())),
        };
        py.detach(|| {
            arm_core::sweep::sweep_poses(arm, &effects, src, mass, opts, sweep_out, &cancel)
        })
    };
    match result {
        Ok(()) => Ok(out),
        Err(ArmError::Cancelled) => {
            let e = interrupt.into_inner().ok().flatten();
            Err(e.unwrap_or_else(|| value_error("sweep cancelled".into())))
        }
        Err(e) => Err(PyArmError(e).into()),
    }
}
