//! Constant-mean-curvature surfaces (seed chapter 5).

pub mod area;
pub mod curvature;
pub mod generators;
pub mod mesh;
pub mod volume;

#[cfg(test)]
mod testing;
