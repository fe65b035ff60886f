//! `eodarm._core`: the private native module. Only conversions live here (arrays in, arrays
//! out, core errors to Python exceptions); every function is one call into `arm_core`.

use arm_core::effects::{Effect, EffectSet};
use arm_core::fem::batch::extra_sizes;
use arm_core::fem::{fem_solve_batch, FemBatchBuffers, FemModel, FemOptions, LinkSection};
use arm_core::kinematics::{inverse_kinematics, Frames};
use arm_core::sensitivity::{jacobian_batch, n_channels, Place};
use arm_core::sweep::{CellFields, Cells, Grid, Poses, Reduce, ReduceOp, SweepOptions, SweepOut};
use arm_core::{Actuator, Arm, ArmError, BatchBuffers, BatchInput, Link, SolveOptions, V2};
use numpy::{
    IntoPyArray, PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyReadwriteArrayDyn, PyUntypedArrayMethods,
};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Mutex;

create_exception!(
    _core,
    CoreError,
    PyValueError,
    "Invalid input refused by the compiled core."
);

/// Newtype carrying a core error across the boundary as a `CoreError` (a `ValueError`).
struct PyArmError(ArmError);

impl From<PyArmError> for PyErr {
    fn from(e: PyArmError) -> Self {
        CoreError::new_err(e.0.to_string())
    }
}

impl From<ArmError> for PyArmError {
    fn from(e: ArmError) -> Self {
        Self(e)
    }
}

fn value_error(msg: String) -> PyErr {
    CoreError::new_err(msg)
}

/// Borrows a C-contiguous float64 array of shape `(rows, cols)` as a slice.
fn matrix<'a>(
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

fn vector<'a>(a: &'a PyReadonlyArray1<'_, f64>, name: &str, len: usize) -> PyResult<&'a [f64]> {
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

fn opt(v: f64) -> Option<f64> {
    (!v.is_nan()).then_some(v)
}

/// An arm in the core's form, built from the arrays of `eodarm.Arm.arrays()`.
#[pyclass(frozen, name = "CoreArm", module = "eodarm._core")]
struct CoreArm {
    inner: Arm,
}

#[pymethods]
impl CoreArm {
    /// Builds and validates the arm; optional limits are NaN when absent.
    #[new]
    #[pyo3(signature = (g, o1, b0, pivot, next, a, b, c, link_mass, measure, stiffness, act_mass, min_length, max_length, max_force))]
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
        let actuators = (0..n)
            .map(|i| Actuator {
                stiffness: k[i],
                mass_kg: m[i],
                min_length: opt(lo[i]),
                max_length: opt(hi[i]),
                max_force: opt(fmax[i]),
            })
            .collect();
        let v = |q: [f64; 2]| V2::new(q[0], q[1]);
        let inner = Arm::new(g, v(o1), v(b0), v(pivot), links, actuators, v(measure))
            .map_err(PyArmError)?;
        Ok(Self { inner })
    }

    /// Number of links.
    #[getter]
    fn n(&self) -> usize {
        self.inner.n()
    }
}

/// The effects of the arrays; `checked: false` leaves the parameter values to the caller (the
/// FE model takes an infinite stiffness as rigid, the fit's θ = 0).
fn effect_set(
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
/// of float64 arrays: `force_n`, `dforce_n`, `dalpha_deg`, `dl_mm`, `dlength_mm`, `length_mm`
/// (rows, n), `reaction_n` (rows, n, 2), `dx_mm`, `dy_mm` (rows,).
fn solve_dict<'py>(
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
    out.set_item("dx_mm", b.dx_mm.into_pyarray(py))?;
    out.set_item("dy_mm", b.dy_mm.into_pyarray(py))?;
    out.set_item("dalpha_deg", per_link(b.dalpha_deg)?)?;
    out.set_item("dl_mm", per_link(b.dl_mm)?)?;
    out.set_item("dlength_mm", per_link(b.dlength_mm)?)?;
    out.set_item("length_mm", per_link(b.length_mm)?)?;
    Ok(out)
}

/// The poses (N × n angles) and payloads (N × 2) of a solve, checked to have the same rows.
fn poses_and_payloads<'a>(
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

/// Solves N poses; returns a dict of float64 arrays (see `eodarm.solve`).
#[pyfunction]
#[pyo3(signature = (arm, alpha_deg, payload_n, codes, places, values, self_weight, nan_on_failure=false))]
#[allow(clippy::too_many_arguments)]
fn solve<'py>(
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

/// The five cell fields of a sweep, in the order of `arm_core::sweep::CellFields`.
const CELL_KEYS: [&str; 5] = ["force_n", "dx_mm", "dy_mm", "dalpha_deg", "dl_mm"];
/// The per-pose outputs of a sweep (each optional in `out`).
const POSE_KEYS: [&str; 4] = ["length_mm", "reachable", "effector_x_mm", "effector_y_mm"];

/// Borrows `out[key]` for writing: a numpy array of dtype `T` (`dtype` names it in errors);
/// `None` when the key is absent and not `required`.
fn out_array<'py, T: numpy::Element>(
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
fn out_slice<'a, T: numpy::Element>(
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
type CellGuards<'py, T> = [Option<PyReadwriteArrayDyn<'py, T>>; 5];

fn cell_guards<'py, T: numpy::Element>(
    out: &Bound<'py, PyDict>,
    dtype: &str,
) -> PyResult<CellGuards<'py, T>> {
    let mut g: CellGuards<'py, T> = Default::default();
    for (slot, key) in g.iter_mut().zip(CELL_KEYS) {
        *slot = out_array(out, key, dtype, true)?;
    }
    Ok(g)
}

fn cell_fields<'a, T: numpy::Element>(g: &'a mut CellGuards<'_, T>) -> PyResult<CellFields<'a, T>> {
    let [f, x, y, a, l] = g;
    Ok(CellFields {
        force_n: out_slice(f, CELL_KEYS[0])?,
        dx_mm: out_slice(x, CELL_KEYS[1])?,
        dy_mm: out_slice(y, CELL_KEYS[2])?,
        dalpha_deg: out_slice(a, CELL_KEYS[3])?,
        dl_mm: out_slice(l, CELL_KEYS[4])?,
    })
}

/// A dict of fresh output arrays of a sweep: cell fields `lead` (+ `n`), `ok` `lead`,
/// per-pose outputs for `poses` poses. Uninitialised (`numpy.empty`): no zeroing pass over
/// memory that the core overwrites anyway, and the arrays of one dtype are views of one
/// buffer, for which numpy asks the kernel for huge pages (ten separate arrays, none
/// aligned to 2 MB, would leave tens of MB on 4 kB pages and their page faults). The core
/// writes every element before the arrays are returned.
fn new_outputs<'py>(
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
    arrays.push(("length_mm", vec![poses, n], "float64"));
    arrays.push(("reachable", vec![poses], "bool"));
    arrays.push(("effector_x_mm", vec![poses], "float64"));
    arrays.push(("effector_y_mm", vec![poses], "float64"));
    let out = PyDict::new(py);
    for dtype in ["float64", "int64", "bool"] {
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
/// `out`: a dict of C-contiguous arrays to write into instead (any shape with the right
/// number of elements; the cell arrays and `ok` required, per-pose arrays optional; with a
/// reduction over whole poses, `reachable` may hold one value per group: any pose of it
/// reachable); it is returned. `mask_unreachable`: cells of poses out of stroke are not
/// solved. `progress(done_poses)` is called after the first chunk, then every 0.1 s or so. `chunk_rows`: rows per chunk
/// of the core (default `arm_core::sweep::CHUNK_ROWS`, less for small sweeps). The GIL is released while the
/// core works; Ctrl-C (or an exception in `progress`) stops it between chunks.
#[pyfunction(name = "sweep")]
#[pyo3(signature = (arm, alpha_deg, mass_kg, codes, places, values, self_weight, reduce=None, group=1, threads=None, *, grid=None, out=None, mask_unreachable=false, progress=None, chunk_rows=None))]
#[allow(clippy::too_many_arguments)]
fn py_sweep<'py>(
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
        let mut lg = out_array::<f64>(&out, POSE_KEYS[0], "float64", false)?;
        let mut rg = out_array::<bool>(&out, POSE_KEYS[1], "bool", false)?;
        let mut xg = out_array::<f64>(&out, POSE_KEYS[2], "float64", false)?;
        let mut yg = out_array::<f64>(&out, POSE_KEYS[3], "float64", false)?;
        let sweep_out = SweepOut {
            cells,
            ok: out_slice(&mut okg, "ok")?,
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

/// Solves N poses with the finite-element model; the keys of `solve` plus pin forces,
/// bending moments and the deformed shape (see `eodarm.solve(model="fem")`).
#[pyfunction]
#[pyo3(signature = (arm, alpha_deg, payload_n, codes, places, values, self_weight, elements_per_link, link_ei, link_ea, moment_samples=101, nan_on_failure=false))]
#[allow(clippy::too_many_arguments)]
fn fem_solve<'py>(
    py: Python<'py>,
    arm: &CoreArm,
    alpha_deg: PyReadonlyArray2<'py, f64>,
    payload_n: PyReadonlyArray2<'py, f64>,
    codes: PyReadonlyArray1<'py, i64>,
    places: PyReadonlyArray1<'py, i64>,
    values: PyReadonlyArray1<'py, f64>,
    self_weight: bool,
    elements_per_link: usize,
    link_ei: PyReadonlyArray1<'py, f64>,
    link_ea: PyReadonlyArray1<'py, f64>,
    moment_samples: usize,
    nan_on_failure: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let arm = &arm.inner;
    let n = arm.n();
    let input = poses_and_payloads(&alpha_deg, &payload_n, n)?;
    let rows = input.payload_n.len() / 2;
    let effects = effect_set(arm, &codes, &places, &values, false)?;
    let ei = vector(&link_ei, "link_ei", n)?;
    let ea = vector(&link_ea, "link_ea", n)?;
    let sections: Vec<LinkSection> = (0..n)
        .map(|i| LinkSection {
            ei: opt(ei[i]),
            ea: opt(ea[i]),
        })
        .collect();
    let options = FemOptions {
        elements_per_link,
        moment_samples,
        ..FemOptions::default()
    };
    let model = py
        .detach(|| FemModel::new(arm, &effects, &sections, options))
        .map_err(PyArmError)?;
    let (_, _, nodes) = extra_sizes(&model);
    let mut arrays = FemBatchBuffers::new(&model, rows);
    py.detach(|| {
        fem_solve_batch(
            &model,
            input,
            SolveOptions {
                self_weight,
                nan_on_failure,
            },
            arrays.out(),
        )
    })
    .map_err(PyArmError)?;
    let FemBatchBuffers {
        base,
        pin_force_n: pin,
        moment_nmm: moment,
        dmoment_nmm: dmoment,
        node_xy,
        node_disp,
    } = arrays;
    let k = moment_samples;
    let n_nodes = nodes / 2;
    let segments: Vec<i64> = model
        .shape
        .segments
        .iter()
        .flat_map(|s| [s[0] as i64, s[1] as i64])
        .collect();
    let kinds: Vec<i64> = model.shape.kinds.iter().map(|&k| k as i64).collect();
    let codes: Vec<i64> = model
        .shape
        .codes(&model.mesh)
        .into_iter()
        .flatten()
        .collect();
    let n_seg = kinds.len();
    let out = solve_dict(py, base, rows, n)?;
    out.set_item(
        "pin_force_n",
        pin.into_pyarray(py).reshape([rows, 2 * n, 2])?,
    )?;
    out.set_item("moment_nmm", moment.into_pyarray(py).reshape([rows, n, k])?)?;
    out.set_item(
        "dmoment_nmm",
        dmoment.into_pyarray(py).reshape([rows, n, k])?,
    )?;
    out.set_item(
        "moment_x_mm",
        model.moment_x.clone().into_pyarray(py).reshape([n, k])?,
    )?;
    out.set_item(
        "node_xy",
        node_xy.into_pyarray(py).reshape([rows, n_nodes, 2])?,
    )?;
    out.set_item(
        "node_disp",
        node_disp.into_pyarray(py).reshape([rows, n_nodes, 2])?,
    )?;
    out.set_item("segments", segments.into_pyarray(py).reshape([n_seg, 2])?)?;
    out.set_item("segment_kind", kinds.into_pyarray(py))?;
    out.set_item("node_kind", codes.into_pyarray(py).reshape([n_nodes, 2])?)?;
    out.set_item("n_dof", model.n_dof())?;
    Ok(out)
}

/// Global points of N poses: O (N, n+1, 2), A, B, C (N, n, 2), measure (N, 2), length_mm (N, n).
#[pyfunction]
fn forward<'py>(
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
fn py_angles_from_lengths<'py>(
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
fn py_inverse_kinematics<'py>(
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
fn jacobian<'py>(
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

/// The private native module of eodarm.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("CoreError", m.py().get_type::<CoreError>())?;
    m.add_class::<CoreArm>()?;
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(fem_solve, m)?)?;
    m.add_function(wrap_pyfunction!(py_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(forward, m)?)?;
    m.add_function(wrap_pyfunction!(py_angles_from_lengths, m)?)?;
    m.add_function(wrap_pyfunction!(py_inverse_kinematics, m)?)?;
    m.add_function(wrap_pyfunction!(jacobian, m)?)?;
    Ok(())
}
