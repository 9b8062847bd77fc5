//! How a solve ended.

use serde::{Deserialize, Serialize};

/// The outcome of a solve: data, not an error. [`Status::sentence`] explains it to a person.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Status {
    /// KKT conditions hold to the requested tolerances.
    Optimal,
    /// KKT conditions hold to 100× the requested tolerances but progress stopped.
    Acceptable,
    /// The constraints could not be satisfied; the least-infeasible point found is returned.
    Infeasible,
    /// The objective decreases without bound on the feasible set.
    Unbounded,
    /// The major-iteration limit was reached.
    IterationLimit,
    /// The wall-clock limit was reached.
    TimeLimit,
    /// No further progress was possible before meeting the tolerances.
    Stalled,
    /// Feasible, but the objective fell by less than `progress_tolerance` (relative) over the
    /// last `progress_window` iterations (a creep; off by default).
    SlowProgress,
    /// The problem's functions failed and backing off did not help.
    EvaluationError,
    /// Stopped from outside (Ctrl-C); the best point so far is returned.
    Interrupted,
    /// Converged, but the model judged the answer's geometry degenerate (a cmc film whose
    /// triangles collapsed, [`crate::cmc::rescue`]); the answer is returned for inspection.
    Degenerate,
}

impl Status {
    /// One sentence for logs and result files.
    pub fn sentence(self) -> &'static str {
        match self {
            Status::Optimal => {
                "Optimal: the optimality conditions hold to the requested tolerances."
            }
            Status::Acceptable => {
                "Acceptable: the optimality conditions hold to a looser tolerance, and progress stopped."
            }
            Status::Infeasible => {
                "Infeasible: the constraints cannot be satisfied near here; the least-infeasible point is returned."
            }
            Status::Unbounded => {
                "Unbounded: the objective decreases without limit on the feasible set."
            }
            Status::IterationLimit => {
                "Iteration limit: stopped before converging; the best point is returned."
            }
            Status::TimeLimit => {
                "Time limit: stopped before converging; the best point is returned."
            }
            Status::Stalled => {
                "Stalled: no step makes progress, though the tolerances are not met."
            }
            Status::SlowProgress => {
                "Slow progress: feasible, but the objective has nearly stopped falling; the last point is returned."
            }
            Status::EvaluationError => {
                "Evaluation error: the problem's functions failed and backing off did not help."
            }
            Status::Interrupted => {
                "Interrupted: stopped by the user; the best point so far is returned."
            }
            Status::Degenerate => {
                "Degenerate: converged, but on a degenerate geometry (collapsed triangles); the answer is not to be trusted."
            }
        }
    }

    /// Whether this counts as converged (exit code 0).
    pub fn is_success(self) -> bool {
        matches!(self, Status::Optimal | Status::Acceptable)
    }
}
