//! Atomic output of a whole run: a run's files are all produced in memory first
//! ([`crate::outcome::Artifact`]); [`write_run`] writes them into a fresh hidden folder next to
//! the target (every file written, `result.json` last, then every file synced) and then moves
//! that folder into place as a whole, so a folder holding a `result.json` always holds exactly
//! one complete run, whatever fails: a failed write leaves the older run untouched and no
//! temporary behind.
//!
//! Replacing an existing run folder takes two renames (old folder aside, new folder in), then
//! the old folder is removed; its `check/` subfolder (the last `--check` report) is carried
//! over. A target that exists and holds anything else than a run is refused rather than
//! replaced, so `-o` never deletes unrelated files.
//!
//! Tests of the whole binary inject a write failure through the environment variable
//! [`FAIL_WRITE_AFTER`]; it is unset in normal use.

use std::borrow::Borrow;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::Error;
use crate::outcome::Artifact;

/// The subfolder of a run folder that `--check` writes into, carried over when a new run
/// replaces the folder.
pub const CHECK_FOLDER: &str = "check";

/// The file that marks a folder as a complete run (written last).
pub const SUMMARY: &str = "result.json";

/// Environment variable injecting a write failure (for tests): with `N` set, writing a run's
/// folder fails after its first N files, or, N being at least the number of files, when the
/// complete new folder is moved into place after the old run was moved aside.
pub const FAIL_WRITE_AFTER: &str = "OPTIMIZE_FAIL_WRITE_AFTER";

/// The injected failure of step `step` of a write (file `step` of the staging, or the move
/// into place as step `files`), if [`FAIL_WRITE_AFTER`] asks for it.
fn injected_failure(step: usize, files: usize) -> std::io::Result<()> {
    let after = std::env::var(FAIL_WRITE_AFTER).ok();
    match after.and_then(|n| n.parse::<usize>().ok()) {
        Some(n) if n.min(files) == step => Err(std::io::Error::other(format!(
            "write failure injected by {FAIL_WRITE_AFTER}"
        ))),
        _ => Ok(()),
    }
}

fn io_error(path: &Path) -> impl Fn(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes `bytes` to a new file at `path`, returning it open for the sync.
fn create_written(path: &Path, bytes: &[u8]) -> std::io::Result<fs::File> {
    let mut f = fs::File::create_new(path)?;
    f.write_all(bytes)?;
    Ok(f)
}

/// A sibling of `dir` named `.{name}.{tag}-{pid}-{n}` that does not exist yet.
fn sibling(dir: &Path, tag: &str) -> PathBuf {
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "run".into());
    (0..)
        .map(|n| dir.with_file_name(format!(".{name}.{tag}-{}-{n}", std::process::id())))
        .find(|p| fs::symlink_metadata(p).is_err())
        .expect("an unused name")
}

/// Whether `dir` may be replaced by a new run: it does not exist, is empty, holds a run's
/// `result.json`, or holds only a `check/` subfolder.
fn replaceable(dir: &Path) -> Result<bool, Error> {
    let entries = match fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(true),
        Err(e) => return Err(io_error(dir)(e)),
    };
    let names: Vec<_> = entries
        .map(|e| e.map(|e| e.file_name()))
        .collect::<Result<_, _>>()
        .map_err(io_error(dir))?;
    Ok(names.iter().all(|n| n == CHECK_FOLDER) || names.iter().any(|n| n == SUMMARY))
}

/// Writes one run's `artifacts` (`result.json` among them, last) as the folder `dir`, replacing
/// a previous run there as a whole (module header). Returns the paths written, in order.
pub fn write_run<A: Borrow<Artifact>>(dir: &Path, artifacts: &[A]) -> Result<Vec<PathBuf>, Error> {
    if !replaceable(dir)? {
        return Err(Error::Io {
            path: dir.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::AlreadyExists,
                "the folder holds files that are not a run's; choose another output folder",
            ),
        });
    }
    if let Some(parent) = dir.parent().filter(|p| !p.as_os_str().is_empty()) {
        fs::create_dir_all(parent).map_err(io_error(parent))?;
    }
    let staging = sibling(dir, "new");
    let files = artifacts.len();
    let staged = stage(&staging, artifacts).and_then(|()| replace(dir, &staging, files));
    if staged.is_err() {
        let _ = fs::remove_dir_all(&staging);
    }
    staged?;
    Ok(artifacts
        .iter()
        .map(|a| dir.join(&a.borrow().name))
        .collect())
}

/// Writes every artifact into the new folder `staging`, then syncs them all (one pass of
/// writes, then one of syncs: the first sync commits the creation of every file at once,
/// where syncing each file after its write committed one file at a time).
fn stage<A: Borrow<Artifact>>(staging: &Path, artifacts: &[A]) -> Result<(), Error> {
    fs::create_dir(staging).map_err(io_error(staging))?;
    let mut written = Vec::with_capacity(artifacts.len());
    for (k, a) in artifacts.iter().map(Borrow::borrow).enumerate() {
        let path = staging.join(&a.name);
        injected_failure(k, artifacts.len()).map_err(io_error(&path))?;
        let file = create_written(&path, &a.bytes).map_err(io_error(&path))?;
        written.push((path, file));
    }
    for (path, file) in &written {
        file.sync_all().map_err(io_error(path))?;
    }
    Ok(())
}

/// Moves the complete folder `staging` (of `files` files) to `dir`, carrying over the old
/// folder's `check/`.
fn replace(dir: &Path, staging: &Path, files: usize) -> Result<(), Error> {
    if fs::symlink_metadata(dir).is_err() {
        return fs::rename(staging, dir).map_err(io_error(dir));
    }
    let old = sibling(dir, "old");
    fs::rename(dir, &old).map_err(io_error(dir))?;
    let moved = injected_failure(files, files).and_then(|()| fs::rename(staging, dir));
    if let Err(e) = moved {
        let _ = fs::rename(&old, dir);
        return Err(io_error(dir)(e));
    }
    let check = old.join(CHECK_FOLDER);
    if check.is_dir() {
        let _ = fs::rename(&check, dir.join(CHECK_FOLDER));
    }
    let _ = fs::remove_dir_all(&old);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn artifact(name: &str, bytes: &[u8]) -> Artifact {
        Artifact {
            name: name.into(),
            bytes: bytes.to_vec(),
        }
    }

    fn scratch(tag: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("optimize-atomic-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_new_run_replaces_the_old_one_as_a_whole_and_keeps_its_check() {
        let root = scratch("replace");
        let dir = root.join("run");
        write_run(
            &dir,
            &[artifact("extra.csv", b"old"), artifact(SUMMARY, b"1")],
        )
        .unwrap();
        write_run(&dir.join(CHECK_FOLDER), &[artifact(SUMMARY, b"checked")]).unwrap();
        write_run(
            &dir,
            &[artifact("model.glb", b"new"), artifact(SUMMARY, b"2")],
        )
        .unwrap();
        assert_eq!(names(&dir), [CHECK_FOLDER, "model.glb", SUMMARY]);
        assert_eq!(fs::read(dir.join(SUMMARY)).unwrap(), b"2");
        assert_eq!(
            fs::read(dir.join(CHECK_FOLDER).join(SUMMARY)).unwrap(),
            b"checked"
        );
        assert_eq!(names(&root), ["run"], "no temporaries left");
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_write_failing_part_way_leaves_the_older_run_intact() {
        let root = scratch("fail");
        let dir = root.join("run");
        let old = [
            artifact("model.glb", b"old model"),
            artifact(SUMMARY, b"old"),
        ];
        write_run(&dir, &old).unwrap();
        // The second file cannot be created (its folder does not exist): the write fails after
        // the first file of the new run was written.
        let new = [
            artifact("model.glb", b"new model"),
            artifact("missing/beams.csv", b"new"),
            artifact(SUMMARY, b"new"),
        ];
        let err = write_run(&dir, &new).unwrap_err();
        assert_eq!(err.exit_code(), 1);
        assert_eq!(names(&dir), ["model.glb", SUMMARY]);
        assert_eq!(fs::read(dir.join("model.glb")).unwrap(), b"old model");
        assert_eq!(fs::read(dir.join(SUMMARY)).unwrap(), b"old");
        assert_eq!(names(&root), ["run"], "no temporaries left");
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_folder_of_other_files_is_refused_not_replaced() {
        let root = scratch("foreign");
        fs::write(root.join("notes.txt"), b"mine").unwrap();
        let err = write_run(&root, &[artifact(SUMMARY, b"x")]).unwrap_err();
        assert_eq!(err.exit_code(), 1);
        assert_eq!(names(&root), ["notes.txt"]);
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn unwritable_destination_is_an_io_error() {
        let file = std::env::temp_dir().join(format!("optimize-notadir-{}", std::process::id()));
        fs::write(&file, b"x").unwrap();
        let err = write_run::<Artifact>(&file.join("sub"), &[]).unwrap_err();
        assert_eq!(err.exit_code(), 1);
        fs::remove_file(&file).unwrap();
    }
}
