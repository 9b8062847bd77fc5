//! The dispatcher: a problem kind's [`Application`](crate::application::Application) runs its file. The one entry point shared
//! by the command line and the golden tests; the shared run types live in
//! [`crate::outcome`], the shared load → check → run contract in [`crate::application`].

use std::path::Path;

use crate::application::execute as execute_application;
use crate::error::Error;
use crate::outcome::{Kind, Outcome, RunOptions};

/// Loads, validates and checks or runs a problem file of the given kind. Returns the problem's
/// name and the outcome; writes nothing.
pub fn execute(kind: Kind, path: &Path, opts: &RunOptions) -> Result<(String, Outcome), Error> {
    match kind {
        Kind::Gait => execute_application::<crate::gait::Gait>(path, opts),
        Kind::Truss => execute_application::<crate::truss::Truss>(path, opts),
        Kind::Cmc => execute_application::<crate::cmc::Cmc>(path, opts),
    }
}
