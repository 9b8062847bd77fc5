//! File formats, written atomically: result files, glTF models, SVG previews, CSV tables.
//! `io` knows formats, not physics: modules hand it meshes, nodes, animations and numbers.

pub mod atomic;
pub mod gltf;
pub mod gltf_read;
pub mod plot;
pub mod result;
pub mod shapes;
pub mod svg;

use std::path::{Path, PathBuf};

use crate::error::Error;
use crate::outcome::{Artifact, Outcome};

/// Writes a run's files as the folder `dir`: the module's artifacts, then `summary` (its
/// `result.json`, [`result::summary_json`] of the outcome's summary), into a fresh folder moved
/// into place as a whole ([`atomic::write_run`]), so a folder holding a `result.json` always
/// holds exactly one complete run.
pub fn write_outcome(
    dir: &Path,
    outcome: &Outcome,
    summary: &Artifact,
) -> Result<Vec<PathBuf>, Error> {
    let files: Vec<&Artifact> = outcome.artifacts.iter().chain([summary]).collect();
    atomic::write_run(dir, &files)
}
