//! Which of the library's errors the user can fix (an input, a setting,
//! a missing driver) and which are internal: the command line exits 2 or
//! 1 on them, the Python binding raises `InputError` or `InternalError`.

use crate::collide::CollideError;
use crate::generate::GenerateError;
use crate::io::InputError;
use crate::job::JobError;
use crate::kinematics::MachineError;
use crate::report::plan_files::OutputError;
use crate::scene::SceneError;
use std::error::Error;

/// `Some(true)` when `cause` (one link of an error's chain) is the
/// user's to fix, `Some(false)` when it is internal, `None` when this
/// link does not say (look at the next one).
pub fn user_can_fix(cause: &(dyn Error + 'static)) -> Option<bool> {
    if cause.is::<InputError>()
        || cause.is::<MachineError>()
        || cause.is::<GenerateError>()
        || cause.is::<OutputError>()
        || matches!(cause.downcast_ref(), Some(CollideError::NoGpu))
    {
        return Some(true);
    }
    if let Some(j) = cause.downcast_ref::<JobError>() {
        return Some(!matches!(
            j,
            JobError::Scene {
                source: SceneError::Internal(_),
                ..
            }
        ));
    }
    if let Some(s) = cause.downcast_ref::<SceneError>() {
        return Some(!matches!(s, SceneError::Internal(_)));
    }
    None
}
