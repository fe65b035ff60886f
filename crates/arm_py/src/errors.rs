//! Core errors as Python exceptions: `CoreError`, a `ValueError` subclass, and the newtype
//! that carries an `arm_core::ArmError` across the boundary.

use arm_core::ArmError;
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

create_exception!(
    _core,
    CoreError,
    PyValueError,
    "Invalid input refused by the compiled core."
);

/// Newtype carrying a core error across the boundary as a `CoreError` (a `ValueError`).
pub(crate) struct PyArmError(pub(crate) ArmError);

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

/// A `CoreError` with this message (input refused at the boundary, before the core).
pub(crate) fn value_error(msg: String) -> PyErr {
    CoreError::new_err(msg)
}
