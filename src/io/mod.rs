//! File formats, written atomically: result files, glTF models, SVG previews, CSV tables.
//! `io` knows formats, not physics: modules hand it meshes, nodes, animations and numbers.

pub mod atomic;
pub mod gltf;
pub mod plot;
pub mod result;
pub mod shapes;
pub mod svg;

use std::path::{Path, PathBuf};

use crate::error::Error;
use crate::run::Outcome;

/// Writes a run's files into `dir`: the module's artifacts first, then `result.json`, so a
/// folder holding a `result.json` always holds the whole result of that run.
pub fn write_outcome(dir: &Path, outcome: &Outcome) -> Result<Vec<PathBuf>, Error> {
    let mut paths = atomic::write_all(dir, &outcome.artifacts)?;
    paths.extend(atomic::write_all(
        dir,
        &[result::summary_json(&outcome.summary)],
    )?);
    Ok(paths)
}
