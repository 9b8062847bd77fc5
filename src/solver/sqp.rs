//! SQP outer loop. (Scaffolding: replaced by the real solver.)

use super::{Nlp, Options, Solution};

/// Solves `nlp` from its starting point.
pub fn solve(_nlp: &dyn Nlp, _options: &Options) -> Solution {
    unimplemented!("the SQP solver is being written")
}
