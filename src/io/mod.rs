//! File formats, written atomically: result files, glTF models, SVG previews, CSV tables.
//! `io` knows formats, not physics: modules hand it meshes, nodes, animations and numbers.

pub mod atomic;
pub mod gltf;
pub mod result;
pub mod shapes;
pub mod svg;
