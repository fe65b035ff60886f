//! `fem_solve`: the finite-element model over N poses, with its pin forces, moments and shape.

use crate::convert::{effect_set, opt, poses_and_payloads, solve_dict, vector, CoreArm};
use crate::errors::PyArmError;
use arm_core::fem::batch::extra_sizes;
use arm_core::fem::{fem_solve_batch, FemBatchBuffers, FemModel, FemOptions, LinkSection};
use arm_core::SolveOptions;
use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Solves N poses with the finite-element model; the keys of `solve` plus pin forces,
/// bending moments and the deformed shape (see `eodarm.solve(model="fem")`).
#[pyfunction]
#[pyo3(signature = (arm, alpha_deg, payload_n, codes, places, values, self_weight, elements_per_link, link_ei, link_ea, moment_samples=101, nan_on_failure=false))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn fem_solve<'py>(
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
