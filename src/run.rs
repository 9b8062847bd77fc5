//! What every problem kind shares at run time: the CLI's run options, the result summary written
//! as `result.json`, and the files a run produces.
//!
//! Each module exposes `load(path) -> Result<Problem, InputError>` (parse + validate) and
//! `run(&Problem, &RunOptions) -> Result<Outcome, Error>`; the CLI and the golden tests call the
//! same functions. Modules never touch the filesystem: they return [`Artifact`]s, which
//! [`crate::io`] writes atomically.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use serde::Serialize;

use crate::error::Error;
use crate::solver::derivatives::DerivativeReport;
use crate::solver::log::{LogTarget, ObjectiveUnit};
use crate::solver::{EvalError, Evaluations, Nlp, Options, Solution, Status};
use crate::spec::SolverSpec;

/// The problem kinds, one per module.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// [`crate::gait`].
    Gait,
    /// [`crate::truss`].
    Truss,
    /// [`crate::cmc`].
    Cmc,
}

impl Kind {
    /// The name used on the command line and in result files.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Gait => "gait",
            Kind::Truss => "truss",
            Kind::Cmc => "cmc",
        }
    }
}

/// Options from the command line that apply to every kind.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Output folder; `None` means `out/<problem name>/`.
    pub out_dir: Option<PathBuf>,
    /// Suppress the live log.
    pub quiet: bool,
    /// More detail in the live log.
    pub verbose: bool,
    /// Only parse, validate, build the model and check derivatives against finite differences.
    pub check: bool,
    /// Overrides `[solver] max_iterations`.
    pub max_iter: Option<usize>,
    /// Seed for every random choice (ground structures, random starts, annealing).
    pub seed: u64,
    /// `seed` was given explicitly (`--seed`): it overrides a problem file's own `seed`.
    pub seed_given: bool,
    /// Worker threads for parallel parts (trials, multistart); `None` = all cores.
    pub threads: Option<usize>,
    /// Gait: run only this trial (1-based).
    pub trial: Option<usize>,
    /// Truss: number of topology rounds.
    pub rounds: Option<usize>,
    /// Set by Ctrl-C; solvers stop at the end of the current iteration.
    pub interrupt: Option<Arc<AtomicBool>>,
    /// Where the live log goes (the command line passes stderr; default: nowhere).
    pub log: LogTarget,
}

impl RunOptions {
    /// Solver options for one solve: the problem file's `[solver]` table, then the command
    /// line on top (`--max-iter`, `--quiet` → silent log, `--verbose` → detailed log, Ctrl-C).
    pub fn solver_options(&self, spec: &SolverSpec) -> Options {
        let mut options = spec.options();
        options.log = self.log.clone();
        if let Some(n) = self.max_iter {
            options.max_iterations = n;
        }
        if self.quiet {
            options.verbosity = 0;
            options.log.out = None;
        } else if self.verbose {
            options.verbosity = options.verbosity.max(2);
        }
        options.interrupt = self.interrupt.clone();
        options
    }

    /// A line of the module's own log (round and trial reports), unless `--quiet`.
    pub fn say(&self, text: &str) {
        if !self.quiet {
            self.log.line(text);
        }
    }
}

/// The answer in the user's units: what the objective is, its value and unit (e.g. mass
/// 9673.4 kg; area 854.2 m²; effort 31.5 N²·s).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Headline {
    /// What the number is, e.g. "mass".
    pub name: String,
    /// The value in `unit`.
    pub value: f64,
    /// Its unit, e.g. "kg" (empty for dimensionless).
    pub unit: String,
}

impl Headline {
    /// The headline `name = value unit`.
    pub fn new(name: &str, value: f64, unit: &str) -> Self {
        Headline {
            name: name.into(),
            value,
            unit: unit.into(),
        }
    }

    /// `value` shown in `unit`.
    pub fn of(unit: &ObjectiveUnit, value: f64) -> Self {
        Headline::new(&unit.name, value, &unit.unit)
    }

    /// "mass 9.673e3 kg".
    pub fn text(&self) -> String {
        let value = format!("{:.6e}", self.value);
        if self.unit.is_empty() {
            format!("{} {value}", self.name)
        } else {
            format!("{} {value} {}", self.name, self.unit)
        }
    }
}

/// The `result.json` summary: common figures plus module-specific ones under `figures`.
#[derive(Debug, Clone, Serialize)]
pub struct ResultSummary {
    /// Problem name (file's `name` key, or its stem).
    pub problem: String,
    /// "gait", "truss" or "cmc".
    pub kind: String,
    /// Solver status name, e.g. "Optimal"; "Checked" for `--check` runs.
    pub status: String,
    /// The status explained in one sentence.
    pub status_message: String,
    /// The answer in the user's units (mass in kg, area in m², effort in N²·s, ...).
    pub headline: Headline,
    /// Final objective value as the model states it (possibly nondimensional; `headline` is
    /// the same number in the user's units).
    pub objective: f64,
    /// Largest bound or constraint violation.
    pub max_violation: f64,
    /// Major iterations (summed over rounds, trials or starts).
    pub iterations: usize,
    /// Evaluation counts (summed likewise).
    pub evaluations: Evaluations,
    /// Wall time per phase in seconds ("build", "solve", "export", ...).
    pub timings: BTreeMap<String, f64>,
    /// The seed used.
    pub seed: u64,
    /// Module-specific figures (areas, masses, trial tables, ...).
    pub figures: serde_json::Value,
}

impl ResultSummary {
    /// Fills the common solver fields from a solution.
    pub fn from_solution(problem: &str, kind: &str, seed: u64, solution: &Solution) -> Self {
        ResultSummary {
            problem: problem.to_string(),
            kind: kind.to_string(),
            status: format!("{:?}", solution.status),
            status_message: solution.status.sentence().to_string(),
            headline: Headline::new("objective", solution.objective, ""),
            objective: solution.objective,
            max_violation: solution.max_violation,
            iterations: solution.iterations,
            evaluations: solution.evaluations,
            timings: BTreeMap::new(),
            seed,
            figures: serde_json::Value::Object(Default::default()),
        }
    }
}

impl ResultSummary {
    /// The summary of a `--check` run: status "Checked", the checker's verdict in one sentence
    /// (naming the worst entry when it failed), the objective and largest bound or constraint
    /// violation of `nlp` at the checked point `x`, and the report under figures
    /// `"derivatives"`. Modules add their own figures and timings.
    pub fn checked(
        problem: &str,
        kind: &str,
        seed: u64,
        nlp: &dyn Nlp,
        x: &[f64],
        report: &DerivativeReport,
    ) -> Result<Self, EvalError> {
        let d = nlp.dims();
        let (mut f, mut c) = (0.0, vec![0.0; d.m]);
        nlp.eval(x, &mut f, &mut c)?;
        let crate::solver::Bounds { xl, xu, cl, cu } = crate::solver::Bounds::of(nlp);
        let max_violation = x
            .iter()
            .zip(xl.iter().zip(&xu))
            .chain(c.iter().zip(cl.iter().zip(&cu)))
            .map(|(v, (lo, hi))| (lo - v).max(v - hi).max(0.0))
            .fold(0.0, f64::max);
        let status_message = match report.worst_per_function.first() {
            Some(worst) if !report.passed() => {
                let function = match worst.row {
                    Some(r) => format!("{} (row {r})", worst.name),
                    None => worst.name.clone(),
                };
                format!(
                    "Checked: the exact derivatives disagree with finite differences in {} \
                     entries; worst: {function} by x[{}], {:.6e} vs {:.6e} (error {:.2e}).",
                    report.failed(),
                    worst.col,
                    worst.analytic,
                    worst.estimate,
                    worst.error
                )
            }
            _ => format!(
                "Checked: the exact derivatives agree with finite differences \
                 (max error {:.2e}).",
                report.max_error()
            ),
        };
        let mut figures = serde_json::Map::new();
        figures.insert(
            "derivatives".into(),
            serde_json::to_value(report).unwrap_or_default(),
        );
        Ok(ResultSummary {
            problem: problem.to_string(),
            kind: kind.to_string(),
            status: "Checked".into(),
            status_message,
            headline: Headline::new("objective", f, ""),
            objective: f,
            max_violation,
            iterations: 0,
            evaluations: Evaluations {
                functions: 1 + report.evaluations,
                derivatives: 1,
                ..Evaluations::default()
            },
            timings: BTreeMap::new(),
            seed,
            figures: serde_json::Value::Object(figures),
        })
    }

    /// Adds (or replaces) one entry of `figures`, which is always a JSON object.
    pub fn set_figure(&mut self, key: &str, value: impl Into<serde_json::Value>) {
        if !self.figures.is_object() {
            self.figures = serde_json::Value::Object(Default::default());
        }
        if let Some(figures) = self.figures.as_object_mut() {
            figures.insert(key.to_string(), value.into());
        }
    }
}

/// A file a run produces, held in memory until the run is complete.
#[derive(Debug, Clone)]
pub struct Artifact {
    /// File name inside the output folder, e.g. "model.glb".
    pub name: String,
    /// Contents.
    pub bytes: Vec<u8>,
}

/// Everything a run produces.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The summary (written as `result.json`).
    pub summary: ResultSummary,
    /// How the main solve ended; decides the exit code. `None` for `--check` runs.
    pub status: Option<Status>,
    /// Whether `--check` found the derivatives consistent (only for `--check` runs).
    pub check_passed: Option<bool>,
    /// Other files: `iterations.csv`, `model.glb`, previews, CSVs.
    pub artifacts: Vec<Artifact>,
}

impl Outcome {
    /// The process exit code documented in README: 0 converged (or `--check` passed),
    /// 1 evaluation failure or failed derivative check, 3 stopped without converging,
    /// 130 interrupted.
    pub fn exit_code(&self) -> u8 {
        match (self.status, self.check_passed) {
            (_, Some(true)) => 0,
            (_, Some(false)) => 1,
            (Some(s), None) if s.is_success() => 0,
            (Some(Status::Interrupted), None) => 130,
            (Some(Status::EvaluationError), None) => 1,
            _ => 3,
        }
    }
}

/// Loads, validates and runs a problem file of the given kind: the one entry point shared by
/// the command line and the golden tests. Returns the problem's name and the outcome; writes
/// nothing.
pub fn execute(kind: Kind, path: &Path, opts: &RunOptions) -> Result<(String, Outcome), Error> {
    match kind {
        Kind::Gait => crate::gait::execute(path, opts),
        Kind::Truss => {
            let problem = crate::truss::load(path)?;
            let outcome = crate::truss::run(&problem, opts)?;
            Ok((problem.name().to_string(), outcome))
        }
        Kind::Cmc => {
            let problem = crate::cmc::load(path)?;
            let outcome = crate::cmc::run(&problem, opts)?;
            Ok((problem.name().to_string(), outcome))
        }
    }
}
