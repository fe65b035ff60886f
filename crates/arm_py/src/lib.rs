//! `eodarm._core`: the private native module. Only conversions live here (arrays in, arrays
//! out, core errors to Python exceptions); every function is one call into `arm_core`.
//!
//! One module per thing exposed: [`convert`] (arrays, the arm, effects), [`errors`],
//! [`solve`] (and `statics`), [`fem`], [`sweep`], [`kinematics`], [`jacobian`]; this file only registers them.

mod compensate;
mod convert;
mod errors;
mod fem;
mod jacobian;
mod kinematics;
mod sequence;
mod solve;
mod sweep;

use pyo3::prelude::*;

/// The private native module of eodarm.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("CoreError", m.py().get_type::<errors::CoreError>())?;
    m.add_class::<convert::CoreArm>()?;
    m.add_function(wrap_pyfunction!(solve::solve, m)?)?;
    m.add_function(wrap_pyfunction!(solve::statics, m)?)?;
    m.add_function(wrap_pyfunction!(sequence::solve_sequence, m)?)?;
    m.add_function(wrap_pyfunction!(sequence::cycle_returns, m)?)?;
    m.add_function(wrap_pyfunction!(fem::fem_solve, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::py_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(kinematics::forward, m)?)?;
    m.add_function(wrap_pyfunction!(kinematics::py_angles_from_lengths, m)?)?;
    m.add_function(wrap_pyfunction!(kinematics::py_inverse_kinematics, m)?)?;
    m.add_function(wrap_pyfunction!(jacobian::jacobian, m)?)?;
    m.add_function(wrap_pyfunction!(compensate::compensate, m)?)?;
    m.add("COMPENSATE_STATUSES", compensate::status_names())?;
    Ok(())
}
