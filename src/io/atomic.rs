//! Atomic output: every file is written to a temporary name in its folder and renamed into
//! place, so a reader never sees a half-written result. A run's files are all produced in
//! memory first ([`crate::run::Artifact`]); [`write_all`] then writes them one by one.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::Error;
use crate::run::Artifact;

/// Writes `bytes` to `path` through a temporary file and a rename.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let result = (|| {
        let mut f = fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result.map_err(io)
}

/// Creates `dir` (and parents) and writes every artifact into it atomically.
/// Returns the paths written, in order.
pub fn write_all(dir: &Path, artifacts: &[Artifact]) -> Result<Vec<PathBuf>, Error> {
    fs::create_dir_all(dir).map_err(|source| Error::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    artifacts
        .iter()
        .map(|a| {
            let path = dir.join(&a.name);
            write_file(&path, &a.bytes).map(|()| path)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_replace_and_leave_no_temporaries() {
        let dir = std::env::temp_dir().join(format!("optimize-atomic-{}", std::process::id()));
        let files = [
            Artifact {
                name: "a.txt".into(),
                bytes: b"one".to_vec(),
            },
            Artifact {
                name: "b.txt".into(),
                bytes: b"two".to_vec(),
            },
        ];
        write_all(&dir, &files).unwrap();
        write_file(&dir.join("a.txt"), b"three").unwrap();
        assert_eq!(fs::read(dir.join("a.txt")).unwrap(), b"three");
        let names: Vec<_> = fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn unwritable_destination_is_an_io_error() {
        let file = std::env::temp_dir().join(format!("optimize-notadir-{}", std::process::id()));
        fs::write(&file, b"x").unwrap();
        let err = write_all(&file.join("sub"), &[]).unwrap_err();
        assert_eq!(err.exit_code(), 1);
        fs::remove_file(&file).unwrap();
    }
}
