//! Truss geometry and sizing optimization on a ground structure (seed chapter 4).

pub mod build;
pub mod geometry;
pub mod ground;
pub mod mass;
pub mod model;
pub mod nlp;
#[cfg(test)]
mod nlp_tests;
pub mod spec;
#[cfg(test)]
mod testing;
