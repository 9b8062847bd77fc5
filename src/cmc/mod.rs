//! Constant-mean-curvature surfaces (seed chapter 5).

pub mod area;
pub mod curvature;
pub mod generators;
pub mod mesh;
pub mod volume;

pub mod check;
pub mod nlp;
#[cfg(test)]
mod testing;
