//! `maamplan` from Python: the collision evaluator, the planner and the
//! simulator with numpy arrays in and out. A thin layer over the library
//! crate: each call does what its command does (`check`, `plan`,
//! `simulate`), through the same library functions, with the same
//! defaults; the Python package `maamplan` (python/maamplan) re-exports
//! what this module defines.

mod inputs;
mod plan;
mod progress;
mod scene;
mod simulate;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use std::error::Error;

create_exception!(
    _maamplan,
    MaamplanError,
    PyException,
    "Base class of every error maamplan raises; its message is the command line's one-line message."
);
create_exception!(
    _maamplan,
    InputError,
    MaamplanError,
    "A problem with an input or an argument the user can fix (the command line's exit code 2)."
);
create_exception!(
    _maamplan,
    InternalError,
    MaamplanError,
    "A failure inside maamplan (the command line's exit code 1)."
);

/// `e` as the Python exception the command line's exit code corresponds
/// to, carrying its one-line message (each cause after the last, `: `
/// between them, as `maamplan` prints it).
pub(crate) fn raise(e: &(dyn Error + 'static)) -> PyErr {
    let mut chain: Vec<&(dyn Error + 'static)> = vec![e];
    while let Some(c) = chain[chain.len() - 1].source() {
        chain.push(c);
    }
    let message = chain
        .iter()
        .map(|c| c.to_string())
        .collect::<Vec<_>>()
        .join(": ");
    let user = chain
        .iter()
        .find_map(|c| maamplan::errors::user_can_fix(*c))
        .unwrap_or(false);
    if user {
        InputError::new_err(message)
    } else {
        InternalError::new_err(message)
    }
}

/// An argument out of its range or of the wrong kind (the command line's
/// usage errors, exit code 2).
pub(crate) fn usage(message: impl Into<String>) -> PyErr {
    InputError::new_err(message.into())
}

/// The extension module.
#[pymodule]
fn _maamplan(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("MaamplanError", py.get_type::<MaamplanError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("InternalError", py.get_type::<InternalError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<scene::Toolpath>()?;
    m.add_class::<scene::Scene>()?;
    m.add_class::<scene::Evaluator>()?;
    m.add_class::<plan::Plan>()?;
    m.add_class::<simulate::Simulation>()?;
    m.add_function(wrap_pyfunction!(plan::plan, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(default_machine, m)?)?;
    Ok(())
}

/// The built-in machine (the data set's B/C rotary-table printer) as a
/// machine file's TOML text, to start a machine file from (`plan
/// --write-machine`).
#[pyfunction]
fn default_machine() -> String {
    maamplan::kinematics::Machine::default().to_toml()
}
