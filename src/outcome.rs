//! What every problem kind shares at run time, one floor below the modules: the problem kinds,
//! the command line's run options, the result summary written as `result.json`, and the files a
//! run produces. Modules build these; [`crate::io`] writes them; nothing here knows a module.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Serialize;

use crate::solver::log::{LogTarget, ObjectiveUnit};
use crate::solver::{Evaluations, Interrupt, Options, Solution, Status};
use crate::spec::overrides::Override;

/// The problem kinds, one per module.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// Spacetime motion of articulated characters (module `gait`).
    Gait,
    /// Trusses on a ground structure (module `truss`).
    Truss,
    /// Constant-mean-curvature meshes (module `cmc`).
    Cmc,
}

impl Kind {
    /// Every kind, in command-line order.
    pub const ALL: [Kind; 3] = [Kind::Gait, Kind::Truss, Kind::Cmc];

    /// The name used on the command line and in result files.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Gait => "gait",
            Kind::Truss => "truss",
            Kind::Cmc => "cmc",
        }
    }

    /// The kind called `name` on the command line, if any.
    pub fn from_name(name: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.name() == name)
    }
}

impl std::fmt::Display for Kind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
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
    /// `--set key.path=value` overrides of problem-file values, in command-line order.
    pub overrides: Vec<Override>,
    /// `--start FILE`: a previous run's `result.json` to start from.
    pub start_file: Option<PathBuf>,
    /// The previous result read from `start_file` (filled in before the kind runs, after its
    /// problem and kind were checked against the problem's).
    pub start: Option<std::sync::Arc<Previous>>,
    /// Raised by Ctrl-C: every solve, evaluation, rollout and check polls it
    /// ([`crate::solver::interrupt`]) and the run ends with the best point so far.
    pub interrupt: Interrupt,
    /// Where the live log goes (the command line passes stderr; default: nowhere).
    pub log: LogTarget,
}

impl RunOptions {
    /// Solver options for one solve: the problem file's `[solver]` table, then the command
    /// line on top (`--max-iter`, `--quiet` → silent log, `--verbose` → detailed log, Ctrl-C).
    pub fn solver_options(&self, file: &Options) -> Options {
        let mut options = file.clone();
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
        options.interrupt = Some(self.interrupt.flag());
        options
    }

    /// A line of the module's own log (round and trial reports), unless `--quiet`.
    pub fn say(&self, text: &str) {
        if !self.quiet {
            self.log.line(text);
        }
    }
}

/// A previous run's `result.json`, read to start a run from its answer (`--start`).
#[derive(Debug, Clone)]
pub struct Previous {
    /// The file as the user named it.
    pub path: PathBuf,
    /// Its contents.
    pub result: serde_json::Value,
}

impl Previous {
    /// The entry `figures.<key>` of the previous result, or an error naming the file when it is
    /// missing (a result written before that figure existed).
    pub fn figure(&self, key: &str) -> Result<&serde_json::Value, crate::error::InputError> {
        self.result["figures"].get(key).ok_or_else(|| {
            crate::error::InputError::whole_file(
                &self.path,
                format!("no `figures.{key}` to start from (written by an older version?)"),
            )
        })
    }

    /// A mismatch between this result and the problem it should start: one line naming the
    /// file.
    pub fn mismatch(&self, message: impl Into<String>) -> crate::error::InputError {
        crate::error::InputError::whole_file(&self.path, message)
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

    /// "mass 9673.430 kg": seven significant digits, in plain notation from 0.01 to 1e7 and
    /// in scientific notation outside (`area 1.184597e-3 m²`).
    pub fn text(&self) -> String {
        let value = readable(self.value, 7);
        if self.unit.is_empty() {
            format!("{} {value}", self.name)
        } else {
            format!("{} {value} {}", self.name, self.unit)
        }
    }
}

/// `value` to `digits` significant digits (at least 1) for people: plain from 0.01 to 1e7 (and
/// 0), scientific outside (`readable(961.70536, 7)` = "961.7054", `readable(1.1846e-3, 4)` =
/// "1.185e-3").
pub fn readable(value: f64, digits: usize) -> String {
    let digits = digits.max(1);
    let magnitude = value.abs().log10().floor();
    if value == 0.0 {
        "0".into()
    } else if value.is_finite() && (-2.0..7.0).contains(&magnitude) {
        let decimals = (digits as f64 - 1.0 - magnitude).max(0.0) as usize;
        format!("{value:.decimals$}")
    } else {
        format!("{value:.*e}", digits - 1)
    }
}

/// The `result.json` summary: common figures plus module-specific ones under `figures`.
#[derive(Debug, Clone, Serialize)]
pub struct ResultSummary {
    /// Problem name (file's `name` key, or its stem).
    pub problem: String,
    /// The problem kind ("gait", "truss" or "cmc" in the file).
    pub kind: Kind,
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
    /// The `--set` overrides the run was given (`key.path=value`, in order); absent when none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub overrides: Vec<String>,
    /// Module-specific figures (areas, masses, trial tables, ...).
    pub figures: serde_json::Value,
}

impl ResultSummary {
    /// A summary with the given status and message and no figures yet.
    pub fn new(problem: &str, kind: Kind, seed: u64, status: String, message: String) -> Self {
        ResultSummary {
            problem: problem.to_string(),
            kind,
            status,
            status_message: message,
            headline: Headline::new("objective", f64::NAN, ""),
            objective: f64::NAN,
            max_violation: f64::NAN,
            iterations: 0,
            evaluations: Evaluations::default(),
            timings: BTreeMap::new(),
            seed,
            overrides: Vec::new(),
            figures: serde_json::Value::Object(Default::default()),
        }
    }

    /// Fills the common solver fields from a solution.
    pub fn from_solution(problem: &str, kind: Kind, seed: u64, solution: &Solution) -> Self {
        ResultSummary {
            headline: Headline::new("objective", solution.objective, ""),
            objective: solution.objective,
            max_violation: solution.max_violation,
            iterations: solution.iterations,
            evaluations: solution.evaluations,
            ..ResultSummary::new(
                problem,
                kind,
                seed,
                format!("{:?}", solution.status),
                solution.status.sentence().to_string(),
            )
        }
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
    /// How the run ended; decides the exit code. `None` for a completed `--check` run
    /// (`Interrupted` for an interrupted one).
    pub status: Option<Status>,
    /// Whether `--check` found the derivatives consistent (only for completed `--check` runs).
    pub check_passed: Option<bool>,
    /// Other files: `iterations.csv`, `model.glb`, previews, CSVs.
    pub artifacts: Vec<Artifact>,
}

impl Outcome {
    /// Marks a run during which the interrupt flag was raised: status `Interrupted` (exit 130)
    /// whatever its last solve reported (e.g. an earlier round's `Optimal` kept as the result),
    /// the summary's message naming both.
    pub fn mark_interrupted(&mut self) {
        let status = Status::Interrupted;
        if self.status == Some(status) && self.summary.status == format!("{status:?}") {
            return;
        }
        self.summary.status_message = format!(
            "{} Result so far: {}",
            status.sentence(),
            self.summary.status_message
        );
        self.summary.status = format!("{status:?}");
        self.status = Some(status);
        self.check_passed = None;
    }

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

#[cfg(test)]
mod tests {
    use super::Headline;

    #[test]
    fn headlines_read_as_plain_numbers_in_the_working_range() {
        let text = |v: f64, unit: &str| Headline::new("x", v, unit).text();
        assert_eq!(text(9673.43012, "kg"), "x 9673.430 kg");
        assert_eq!(text(961.70536, "kg"), "x 961.7054 kg");
        assert_eq!(text(0.0123456789, ""), "x 0.01234568");
        assert_eq!(text(1.1845968e-3, "m²"), "x 1.184597e-3 m²");
        assert_eq!(text(2.5e7, "N²·s"), "x 2.500000e7 N²·s");
        assert_eq!(text(-31.5, "N²·s"), "x -31.50000 N²·s");
        assert_eq!(text(0.0, "kg"), "x 0 kg");
        assert_eq!(text(f64::NAN, "kg"), "x NaN kg");
        assert_eq!(super::readable(98_856.0, 3), "98856");
        assert_eq!(super::readable(988.56, 4), "988.6");
    }
}
