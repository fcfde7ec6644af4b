//! An optional Python progress callback, called from whichever thread the
//! work is on while the call runs without the GIL: it takes the GIL for
//! each event; the first exception it raises is kept and raised when the
//! call returns.

use maamplan::plan::Progress as PlanProgress;
use pyo3::prelude::*;
use std::sync::Mutex;

/// `progress(stage, done, total)`, or nobody.
pub struct Callback {
    function: Option<Py<PyAny>>,
    stage: Mutex<String>,
    error: Mutex<Option<PyErr>>,
}

impl Callback {
    /// Listen with `function` (None: nobody listens).
    pub fn new(function: Option<Py<PyAny>>) -> Self {
        Callback {
            function,
            stage: Mutex::new(String::new()),
            error: Mutex::new(None),
        }
    }

    /// A stage begins.
    pub fn stage(&self, name: &str) {
        *self.stage.lock().expect("stage") = name.to_string();
        self.call(0, 0);
    }

    /// `done` of `total` collision queries of the current stage answered.
    pub fn queries(&self, done: u64, total: u64) {
        self.call(done, total);
    }

    /// The planner's events.
    pub fn on(&self, p: PlanProgress) {
        match p {
            PlanProgress::Stage(name) => self.stage(name.as_str()),
            PlanProgress::Queries { done, total } => self.queries(done, total),
            PlanProgress::Done(_) => {}
        }
    }

    fn call(&self, done: u64, total: u64) {
        let Some(f) = &self.function else {
            return;
        };
        if self.error.lock().expect("error").is_some() {
            return;
        }
        let stage = self.stage.lock().expect("stage").clone();
        Python::attach(|py| {
            if let Err(e) = f.call1(py, (stage, done, total)) {
                *self.error.lock().expect("error") = Some(e);
            }
        });
    }

    /// The callback's first exception, if it raised one.
    pub fn finish(self) -> PyResult<()> {
        match self.error.into_inner().expect("error") {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}
