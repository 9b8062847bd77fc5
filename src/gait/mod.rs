//! Reduced-gradient spacetime optimization of articulated characters (seed chapter 3).
//!
//! - [`spatial`]: 6-D spatial algebra; [`character`]: the link tree; [`aba`]: forward dynamics;
//! - [`contact`]: the seed's ground spring and friction; [`sim`]: RK4 rollouts.

pub mod aba;
pub mod character;
pub mod contact;
pub mod sim;
pub mod spatial;
pub mod spec;
pub mod task;
