//! Reduced-gradient spacetime optimization of articulated characters (seed chapter 3).
//!
//! A character (a tree of rigid links) is simulated forward from actuator force trajectories;
//! pose constraints are read off the simulated motion at key times.
//! - [`spatial`]: 6-D spatial algebra; [`character`]: the link tree; [`aba`]: forward dynamics;
//! - [`contact`]: the seed's ground spring and friction; [`sim`]: RK4 rollouts;
//! - [`spline`]: Hermite force splines and the closed-form objective; [`task`]: pose
//!   constraints; [`reduced`]: the reduced-gradient NLP with exact dual-number derivatives;
//! - [`spec`]: the problem file.

pub mod aba;
pub mod character;
pub mod contact;
pub mod reduced;
pub mod sim;
pub mod spatial;
pub mod spec;
pub mod spline;
pub mod task;

#[cfg(test)]
mod truth_tests;

use std::path::Path;

use crate::error::InputError;
use crate::spec::Source;

pub use spec::Problem;

/// Reads, parses and validates a gait problem file.
pub fn load(path: &Path) -> Result<Problem, InputError> {
    spec::load_source(&Source::read(path)?)
}

impl Problem {
    /// The problem's name (the file's `name`, or its stem).
    pub fn name(&self) -> &str {
        &self.name
    }
}
