//! How good a design is: its mass against the layout LP on the same joints (the start), and
//! against the LP's certified lower bound.
//!
//! The layout start is a design in its own right: with `linear` mass its forces balance the
//! loads and its own weight exactly, so where it violates no constraint it is a feasible point
//! of the geometry problem whose mass is the LP optimum on those joints. Geometry optimization
//! moves the joints and should end lighter; a run that ends heavier reports the start's design
//! instead ([`keeps_start`]). The LP's lower bound (dual objective, [`super::start::LpReport`])
//! bounds every design on the same joints with fixed geometry: a geometry-optimized design may
//! lie below it, which measures what moving the joints gained.
//!
//! Figures are in the objective's unit (kg for the mass objectives, m for length). The LP's
//! figures are reported for the mass objectives only: with the length objective the LP prices
//! load paths (m·N), not the design's length. With Euler compression the LP prices compression
//! by a secant, so its cost and bound are estimates, not bounds on the Euler mass
//! (`lp_prices_exactly` says which).

use serde::Serialize;

use crate::solver::{EvalError, Nlp};

use super::mass::Compression;
use super::model::{Objective, Settings};
use super::start::LpReport;

/// A point of the NLP: its objective (the NLP's scaled units) and largest violation.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    /// The variables.
    pub x: Vec<f64>,
    /// f(x).
    pub objective: f64,
    /// c(x).
    pub constraints: Vec<f64>,
    /// Largest bound or constraint violation (the solver's unscaled measure).
    pub violation: f64,
}

impl Point {
    /// The NLP's start point, evaluated.
    pub fn start(nlp: &dyn Nlp) -> Result<Point, EvalError> {
        let d = nlp.dims();
        let mut x = vec![0.0; d.n];
        nlp.start(&mut x);
        let mut objective = 0.0;
        let mut constraints = vec![0.0; d.m];
        nlp.eval(&x, &mut objective, &mut constraints)?;
        let b = crate::solver::Bounds::of(nlp);
        let beyond = |v: f64, l: f64, u: f64| (l - v).max(v - u).max(0.0);
        let violation = (x.iter().zip(b.xl.iter().zip(&b.xu)))
            .chain(constraints.iter().zip(b.cl.iter().zip(&b.cu)))
            .map(|(&v, (&l, &u))| beyond(v, l, u))
            .fold(0.0, f64::max);
        Ok(Point {
            x,
            objective,
            constraints,
            violation,
        })
    }
}

/// The comparison reported as `figures.quality` in result.json.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Quality {
    /// Unit of the values below.
    pub unit: String,
    /// The design's value.
    pub final_value: f64,
    /// The layout start's value (the NLP objective at the start point).
    pub start_value: f64,
    /// Whether the start violates no constraint beyond the solver's tolerance.
    pub start_feasible: bool,
    /// (final − start)/start: below zero, geometry optimization beat the layout LP.
    pub gap_to_start: f64,
    /// The LP optimum on the start's joints, largest over the load cases (mass objectives).
    pub lp_value: Option<f64>,
    /// The LP's certified lower bound, largest over the load cases (mass objectives).
    pub lp_lower_bound: Option<f64>,
    /// (final − bound)/bound.
    pub gap_to_lower_bound: Option<f64>,
    /// Whether the LP was over every admissible pair of joints (`[connect] full`) or the
    /// ground structure's beams.
    pub lp_all_pairs: Option<bool>,
    /// Whether the LP prices the design's objective exactly (linear mass, mass objective).
    pub lp_prices_exactly: bool,
    /// Whether the reported design is the start's ([`keeps_start`]).
    pub kept_start: bool,
}

/// Whether a run reports its start instead of its final design: the start is feasible (within
/// `tolerance`) and lighter.
pub fn keeps_start(start: &Point, final_objective: f64, tolerance: f64) -> bool {
    start.violation <= tolerance && start.objective < final_objective
}

impl Quality {
    /// The comparison for a design of value `final_value` from a start of value `start_value`
    /// (both in `unit`), its LP report if the start was the layout LP.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        settings: &Settings,
        lp: Option<&LpReport>,
        unit: &str,
        final_value: f64,
        start_value: f64,
        start_feasible: bool,
        kept_start: bool,
    ) -> Quality {
        let mass_objective = settings.objective != Objective::Length;
        let lp = lp.filter(|_| mass_objective);
        let largest = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let lp_value = lp.map(|l| largest(&l.cost));
        let lp_lower_bound = lp.map(|l| largest(&l.lower_bound));
        Quality {
            unit: unit.to_string(),
            final_value,
            start_value,
            start_feasible,
            gap_to_start: (final_value - start_value) / start_value,
            lp_value,
            lp_lower_bound,
            gap_to_lower_bound: lp_lower_bound.map(|b| (final_value - b) / b),
            lp_all_pairs: lp.map(|l| l.all_pairs),
            lp_prices_exactly: settings.objective == Objective::Mass
                && matches!(settings.mass.compression, Compression::Linear { .. }),
            kept_start,
        }
    }

    /// One sentence for the run's summary.
    pub fn sentence(&self) -> String {
        let unit = &self.unit;
        let mut text = if self.kept_start {
            format!(
                "The layout start's design is reported ({:.6} {unit}): geometry optimization ended heavier ({:.6} {unit}).",
                self.start_value, self.final_value
            )
        } else {
            format!(
                "{:.6} {unit}, {:+.2}% against the layout start ({:.6} {unit}).",
                self.final_value,
                100.0 * self.gap_to_start,
                self.start_value
            )
        };
        if let (Some(bound), Some(gap), Some(all)) = (
            self.lp_lower_bound,
            self.gap_to_lower_bound,
            self.lp_all_pairs,
        ) && self.lp_prices_exactly
        {
            let over = if all {
                "every pair of its joints"
            } else {
                "its ground structure"
            };
            text.push_str(&format!(
                " Layout LP lower bound over {over}: {bound:.6} {unit} ({:+.2}%).",
                100.0 * gap
            ));
        }
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_heavier_end_keeps_a_feasible_start_only() {
        let start = Point {
            x: vec![],
            objective: 1.0,
            constraints: vec![],
            violation: 1e-9,
        };
        assert!(keeps_start(&start, 1.01, 1e-6));
        assert!(!keeps_start(&start, 0.99, 1e-6));
        let infeasible = Point {
            violation: 1e-3,
            ..start
        };
        assert!(!keeps_start(&infeasible, 1.01, 1e-6));
    }
}
