//! The contract every problem kind implements ([`Application`]: load → check or run →
//! outcome with its artifacts) and the one `--check` path they share ([`check`]).
//!
//! A module loads and validates its problem file (positioned [`InputError`]s), and then either
//! solves it ([`Application::run`]) or sets up a derivative check ([`Application::check_case`]:
//! the NLP, the point, the checker's options and the model's figures); [`execute`] picks
//! between the two and [`check`] runs every kind's check the same way. Modules never touch
//! the filesystem: they return [`Artifact`]s, which [`crate::io`] writes as one run.
//!
//! [`InputError`]: crate::error::InputError

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use crate::error::{Error, InputError};
use crate::outcome::{Artifact, Headline, Kind, Outcome, Previous, ResultSummary, RunOptions};
use crate::solver::derivatives::{CheckOptions, DerivativeReport, check_derivatives};
use crate::solver::{Bounds, Evaluations, Interrupt, Interruptible, Nlp, Status};
use crate::spec::Source;
use crate::spec::overrides;

/// A problem kind: how its files are loaded, checked and solved.
pub trait Application {
    /// The kind, as named on the command line and in `result.json`.
    const KIND: Kind;
    /// A loaded, validated problem.
    type Problem;

    /// Parses and validates a problem file's text (errors positioned in the file).
    fn load(source: Source) -> Result<Self::Problem, Error>;

    /// The problem's name (the file's `name`, or its stem): names `out/<name>/`.
    fn name(problem: &Self::Problem) -> &str;

    /// The derivative check `--check` runs: the model built, the point and the options.
    fn check_case<'p>(
        problem: &'p Self::Problem,
        opts: &RunOptions,
    ) -> Result<CheckCase<'p>, Error>;

    /// Solves the problem; the outcome carries the status, summary and files.
    fn run(problem: &Self::Problem, opts: &RunOptions) -> Result<Outcome, Error>;
}

/// A model set up for the derivative check.
pub struct CheckCase<'p> {
    /// The problem's NLP.
    pub nlp: Box<dyn Nlp + 'p>,
    /// The point the derivatives are compared at.
    pub x: Vec<f64>,
    /// The checker's options (tolerance, steps, columns).
    pub options: CheckOptions,
    /// The seed the model and point were drawn with.
    pub seed: u64,
    /// The model's figures (sizes, start figures), merged into `result.json` figures.
    pub figures: serde_json::Map<String, serde_json::Value>,
    /// Objective to report instead of the NLP's at `x`, in the module's units (e.g. the
    /// start's area in m²), if any.
    pub objective: Option<Headline>,
    /// Time spent building the model, s (`timings.build`).
    pub build_seconds: Option<f64>,
    /// Files the check writes besides `result.json` (e.g. a preview of the start).
    pub artifacts: Vec<Artifact>,
}

impl<'p> CheckCase<'p> {
    /// A case with the NLP, point and options, and no figures or files yet.
    pub fn new(nlp: Box<dyn Nlp + 'p>, x: Vec<f64>, options: CheckOptions, seed: u64) -> Self {
        let d = nlp.dims();
        let mut figures = serde_json::Map::new();
        figures.insert("variables".into(), d.n.into());
        figures.insert("constraints".into(), d.m.into());
        figures.insert("jacobian_nonzeros".into(), d.jac_nnz.into());
        CheckCase {
            nlp,
            x,
            options,
            seed,
            figures,
            objective: None,
            build_seconds: None,
            artifacts: Vec::new(),
        }
    }

    /// Adds one figure.
    pub fn figure(mut self, key: &str, value: impl Into<serde_json::Value>) -> Self {
        self.figures.insert(key.to_string(), value.into());
        self
    }
}

/// Loads a problem file of application `A` and checks or solves it (`opts.check`): the one
/// entry point of every kind. Returns the problem's name and the outcome; writes nothing.
///
/// The `--set` overrides (`opts.overrides`) are spliced into the file's text before it is
/// parsed; errors are positioned in the file as written, or name the `--set` argument they come
/// from; `result.json` lists the overrides.
pub fn execute<A: Application>(path: &Path, opts: &RunOptions) -> Result<(String, Outcome), Error> {
    let edited = overrides::apply(Source::read(path)?, &opts.overrides)?;
    let relocate = |e: Error| match e {
        Error::Input(e) => Error::Input(edited.relocate(e)),
        other => other,
    };
    let problem = A::load(edited.source.clone()).map_err(relocate)?;
    let mut opts = opts.clone();
    if let Some(file) = &opts.start_file {
        opts.start = Some(Arc::new(read_start(file, A::KIND, A::name(&problem))?));
    }
    let mut outcome = run_problem::<A>(&problem, &opts).map_err(relocate)?;
    outcome.summary.overrides = opts.overrides.iter().map(|o| o.argument.clone()).collect();
    Ok((A::name(&problem).to_string(), outcome))
}

/// Reads `--start`'s `result.json` and checks that it is a solved result of the problem `name`
/// of `kind`: anything else is a one-line error naming the file (exit 2).
fn read_start(path: &Path, kind: Kind, name: &str) -> Result<Previous, Error> {
    let fail = |message: String| Error::Input(InputError::whole_file(path, message));
    let text = std::fs::read_to_string(path)
        .map_err(|e| fail(format!("cannot read the result to start from: {e}")))?;
    let result: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| fail(format!("not a result.json ({e})")))?;
    let (their_kind, their_name) = (result["kind"].as_str(), result["problem"].as_str());
    if their_kind != Some(kind.name()) || their_name != Some(name) {
        return Err(fail(format!(
            "a result of {} problem `{}`, not of {kind} problem `{name}`",
            their_kind.unwrap_or("no"),
            their_name.unwrap_or("?")
        )));
    }
    if result["status"] == "Checked" {
        return Err(fail("a --check report, not a solved result".into()));
    }
    Ok(Previous {
        path: path.to_path_buf(),
        result,
    })
}

/// Checks (`opts.check`) or solves a loaded problem of application `A`.
pub fn run_problem<A: Application>(
    problem: &A::Problem,
    opts: &RunOptions,
) -> Result<Outcome, Error> {
    let mut outcome = if opts.check {
        let case = A::check_case(problem, opts)?;
        check(A::KIND, A::name(problem), case, &opts.interrupt)?
    } else {
        A::run(problem, opts)?
    };
    if opts.interrupt.is_raised() {
        outcome.mark_interrupted();
    }
    Ok(outcome)
}

/// `--check`, the same for every kind: compares the case's exact derivatives with finite
/// differences by the shared checker and reports the verdict (status "Checked", exit 0 when
/// they agree, 1 when they do not) with the objective and largest violation at the checked
/// point and the checker's report under figures `"derivatives"`. A raised `interrupt` stops the
/// check at its next evaluation: status "Interrupted", exit 130, no report.
pub fn check(
    kind: Kind,
    problem: &str,
    case: CheckCase<'_>,
    interrupt: &Interrupt,
) -> Result<Outcome, Error> {
    let clock = Instant::now();
    let nlp = Interruptible::new(&*case.nlp, interrupt);
    let failed = |e| Error::Runtime(format!("{problem}: derivative check: {e}"));
    let report = match check_derivatives(&nlp, &case.x, &case.options) {
        Ok(report) => report,
        Err(_) if interrupt.is_raised() => return Ok(interrupted_check(kind, problem, case.seed)),
        Err(e) => return Err(failed(e)),
    };
    let check_seconds = clock.elapsed().as_secs_f64();
    let (objective, max_violation) = value_at(&*case.nlp, &case.x).map_err(failed)?;
    let mut summary = ResultSummary {
        objective: case.objective.as_ref().map_or(objective, |h| h.value),
        headline: case
            .objective
            .clone()
            .unwrap_or_else(|| Headline::new("objective", objective, "")),
        max_violation,
        evaluations: Evaluations {
            functions: 1 + report.evaluations,
            derivatives: 1,
            ..Evaluations::default()
        },
        ..ResultSummary::new(problem, kind, case.seed, "Checked".into(), verdict(&report))
    };
    summary.timings = BTreeMap::from([("check".to_string(), check_seconds)]);
    if let Some(build) = case.build_seconds {
        summary.timings.insert("build".into(), build);
    }
    for (key, value) in case.figures {
        summary.set_figure(&key, value);
    }
    summary.set_figure(
        "derivatives",
        serde_json::to_value(&report).unwrap_or_default(),
    );
    Ok(Outcome {
        summary,
        status: None,
        check_passed: Some(report.passed()),
        artifacts: case.artifacts,
    })
}

/// The outcome of a check stopped by Ctrl-C.
fn interrupted_check(kind: Kind, problem: &str, seed: u64) -> Outcome {
    let status = Status::Interrupted;
    Outcome {
        summary: ResultSummary::new(
            problem,
            kind,
            seed,
            format!("{status:?}"),
            "Interrupted before the derivative check completed.".into(),
        ),
        status: Some(status),
        check_passed: None,
        artifacts: Vec::new(),
    }
}

/// The objective and the largest bound or constraint violation of `nlp` at `x`.
fn value_at(nlp: &dyn Nlp, x: &[f64]) -> Result<(f64, f64), crate::solver::EvalError> {
    let (mut f, mut c) = (0.0, vec![0.0; nlp.dims().m]);
    nlp.eval(x, &mut f, &mut c)?;
    let Bounds { xl, xu, cl, cu } = Bounds::of(nlp);
    let max_violation = x
        .iter()
        .zip(xl.iter().zip(&xu))
        .chain(c.iter().zip(cl.iter().zip(&cu)))
        .map(|(v, (lo, hi))| (lo - v).max(v - hi).max(0.0))
        .fold(0.0, f64::max);
    Ok((f, max_violation))
}

/// The checker's verdict in one sentence, naming the worst entry when it failed.
fn verdict(report: &DerivativeReport) -> String {
    match report.worst_per_function.first() {
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
    }
}
