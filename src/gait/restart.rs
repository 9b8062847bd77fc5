//! Starting a gait run from a previous result (`--start out/<name>/result.json`).
//!
//! A run writes its best trial's optimized spline parameters under `figures.knots` of
//! `result.json` ([`knots_json`]): `parameters` (physical units: each actuator's knot forces in
//! N·m or N and their slopes, in the formulation's order, plus the initial state when it is a
//! variable), with the number of actuators and knots per actuator. [`trial_from`] solves one
//! trial from them (shaping, feasibility phase and restarts as the file says, no global phase):
//! from a converged result that trial ends at once. A result of another size is refused with a
//! one-line error.

use serde::Deserialize;
use serde_json::{Value, json};

use super::Problem;
use super::formulation::Formulation;
use super::trials::{self, TrialResult};
use crate::error::InputError;
use crate::outcome::Previous;
use crate::solver::Options;

/// The best trial's parameters as written under `figures.knots`.
pub fn knots_json(problem: &Problem, parameters: &[f64]) -> Value {
    json!({
        "actuators": problem.model.actuators.len(),
        "knots": problem.start.first().map_or(0, Vec::len),
        "parameters": parameters,
    })
}

#[derive(Deserialize)]
struct Saved {
    actuators: usize,
    knots: usize,
    parameters: Vec<f64>,
}

/// Trial 1 of `problem` solved from the previous result's parameters.
pub fn trial_from(
    problem: &Problem,
    previous: &Previous,
    options: &Options,
) -> Result<TrialResult, InputError> {
    let saved: Saved = serde_json::from_value(previous.figure("knots")?.clone())
        .map_err(|e| previous.mismatch(format!("figures.knots: {e}")))?;
    let f = Formulation::new(problem);
    let expected = f.reduced().parameters();
    let ours = knots_json(problem, &[]);
    if saved.parameters.len() != expected
        || ours["actuators"] != saved.actuators
        || ours["knots"] != saved.knots
    {
        return Err(previous.mismatch(format!(
            "has {} actuator(s) × {} knots ({} parameters); this problem has {} × {} ({expected})",
            saved.actuators,
            saved.knots,
            saved.parameters.len(),
            ours["actuators"],
            ours["knots"]
        )));
    }
    let mut result = trials::solve_trial(problem, &f, 1, &saved.parameters, options);
    result.origin = "result".into();
    Ok(result)
}
