//! File formats: result files, glTF, previews; atomic writes.
