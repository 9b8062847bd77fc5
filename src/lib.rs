//! `optimize`: physically valid motion and structures by constrained nonlinear optimization.
//!
//! - [`solver`]: a hand-written sparse SQP solver with quasi-Newton Hessians and global methods.
//! - [`gait`]: reduced-gradient spacetime optimization over a Featherstone simulator.
//! - [`truss`]: ground-structure geometry and sizing optimization of trusses.
//! - [`cmc`]: constant-mean-curvature triangle meshes (soap films, bubbles, tents).
//!
//! Data flows one way: problem file → spec → model → [`solver::Nlp`] → [`solver::Solution`] →
//! module result → files. See `docs/architecture.md`.

pub mod application;
pub mod cli;
pub mod cmc;
pub mod error;
pub mod gait;
pub mod io;
pub mod outcome;
pub mod run;
pub mod solver;
pub mod spec;
pub mod truss;
