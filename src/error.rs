//! Error types shared by the library and the CLI.
//!
//! Three families, each with its own exit code (see README):
//! - [`InputError`]: the problem file is missing, malformed or invalid (exit 2). It always names
//!   the file and, where one applies, the line and column, so the CLI prints one line such as
//!   `problems/x.toml:3:1: unknown key `tolerence` in [solver]; did you mean `tolerance`?`.
//! - [`Error::Io`]: writing results failed (exit 1).
//! - [`Error::Runtime`]: the model could not be built or evaluated (exit 1).
//!
//! Not converging is not an error: it is a [`crate::solver::Status`] in the solution.

use std::fmt;
use std::path::{Path, PathBuf};

/// A problem-file error: where it is (file, 1-based line and column when known) and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InputError {
    /// The problem file as the user named it.
    pub file: PathBuf,
    /// 1-based line and column of the offending text, when the error points into the file.
    pub position: Option<(usize, usize)>,
    /// What is wrong, in one sentence without a trailing period.
    pub message: String,
}

impl InputError {
    /// An error about the file as a whole (missing, unreadable).
    pub fn whole_file(file: &Path, message: impl Into<String>) -> Self {
        InputError {
            file: file.to_path_buf(),
            position: None,
            message: message.into(),
        }
    }

    /// An error at a byte offset into `text`, the file's contents.
    pub fn at_offset(file: &Path, text: &str, offset: usize, message: impl Into<String>) -> Self {
        InputError {
            file: file.to_path_buf(),
            position: Some(line_col(text, offset)),
            message: message.into(),
        }
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.position {
            Some((line, col)) => {
                write!(f, "{}:{line}:{col}: {}", self.file.display(), self.message)
            }
            None => write!(f, "{}: {}", self.file.display(), self.message),
        }
    }
}

impl std::error::Error for InputError {}

/// 1-based (line, column) of a byte offset; the column counts characters, not bytes.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..text.floor_char_boundary(offset)];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let col = before[line_start..].chars().count() + 1;
    (line, col)
}

/// Every failure the library reports.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The problem file is missing, malformed or invalid.
    #[error("{0}")]
    Input(#[from] InputError),
    /// Reading or writing a file other than the problem file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder concerned.
        path: PathBuf,
        /// The operating system's report.
        source: std::io::Error,
    },
    /// The model could not be built or evaluated.
    #[error("{0}")]
    Runtime(String),
}

impl Error {
    /// The process exit code documented in README: 2 for problem-file errors, 1 otherwise.
    pub fn exit_code(&self) -> u8 {
        match self {
            Error::Input(_) => 2,
            Error::Io { .. } | Error::Runtime(_) => 1,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_col_counts_from_one() {
        let text = "a = 1\nbé = 2\n";
        assert_eq!(line_col(text, 0), (1, 1));
        assert_eq!(line_col(text, 6), (2, 1));
        // 'é' is two bytes but one column.
        assert_eq!(line_col(text, 9), (2, 3));
    }
}
