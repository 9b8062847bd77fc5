//! Truss geometry and sizing optimization on a ground structure (seed chapter 4).
//!
//! Data flow: problem file ([`spec`]) → model ([`build`]: user joints, load cases, generated
//! ground structure from [`ground`]) → [`nlp::TrussNlp`] (seed eq. 4.8 with exact derivatives,
//! masses from [`mass`], segment distances from [`geometry`]) → `crate::solver::solve` →
//! [`design::Design`] → clean-up rounds ([`topology`]) → outputs ([`export`]).
//! [`plastic`] holds the references the `linear` mass option is compared with: the plastic
//! layout-optimization LP (solved by [`lp`]) and Michell's closed forms.
//!
//! Units: m, N, kg; y up; λ positive in compression.

pub mod build;
pub mod design;
pub mod export;
pub mod geometry;
pub mod ground;
pub mod lp;
pub mod mass;
pub mod model;
pub mod nlp;
pub mod plastic;
pub mod spec;
pub mod topology;

#[cfg(test)]
mod nlp_tests;
#[cfg(test)]
mod problem_tests;
#[cfg(test)]
mod solve_tests;
#[cfg(test)]
mod testing;

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use serde_json::json;

use crate::error::{Error, InputError};
use crate::run::{Artifact, Outcome, ResultSummary, RunOptions};
use crate::solver::derivatives::{CheckOptions, check_derivatives};
use crate::solver::{Evaluations, Nlp, Solution};
use crate::spec::{Key, Source};

use build::Model;
use design::Design;
use nlp::{SetupError, TrussNlp};
use spec::{StartForces, TrussSpec};
use topology::RoundSettings;

/// A loaded, validated truss problem.
#[derive(Debug, Clone)]
pub struct Problem {
    source: Source,
    spec: TrussSpec,
    name: String,
    /// The model built with the file's seed (or 0), kept to report sizes without rebuilding.
    model: Model,
}

/// Reads, parses and validates a truss problem file, and builds its ground structure and NLP once
/// so that every problem-file error is reported here, positioned in the file.
pub fn load(path: &Path) -> Result<Problem, InputError> {
    let source = Source::read(path)?;
    let spec: TrussSpec = source.parse()?;
    spec::validate(&spec, &source)?;
    let name = spec.name.clone().unwrap_or_else(|| {
        path.file_stem()
            .map_or_else(|| "truss".to_string(), |s| s.to_string_lossy().into_owned())
    });
    let model = build::build(&spec, &source, spec.seed.unwrap_or(0))?;
    let problem = Problem {
        source,
        spec,
        name,
        model,
    };
    problem.nlp(&problem.model, 0)?;
    Ok(problem)
}

impl Problem {
    /// The problem's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The parsed problem file.
    pub fn spec(&self) -> &TrussSpec {
        &self.spec
    }

    /// The model built at load time (seed from the file, or 0).
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The seed a run uses: the file's `seed`, else the run's.
    pub fn seed(&self, opts: &RunOptions) -> u64 {
        self.spec.seed.unwrap_or(opts.seed)
    }

    /// The model for a seed (rebuilt only when random generation depends on it).
    pub fn model_for(&self, seed: u64) -> Result<Model, InputError> {
        if seed == self.spec.seed.unwrap_or(0) {
            Ok(self.model.clone())
        } else {
            build::build(&self.spec, &self.source, seed)
        }
    }

    /// The NLP of a model, with start forces drawn from `seed`.
    pub fn nlp(&self, model: &Model, seed: u64) -> Result<TrussNlp, InputError> {
        let cases = model.settings.load_cases.len();
        let forces = match self.spec.start_forces {
            StartForces::Random => TrussNlp::random_start_forces(&model.structure, cases, seed),
            StartForces::Zero => vec![0.0; cases * model.structure.beams.len()],
        };
        TrussNlp::new(model.structure.clone(), model.settings.clone(), forces)
            .map_err(|e| self.setup_error(&e))
    }

    fn setup_error(&self, e: &SetupError) -> InputError {
        match e {
            SetupError::Asymmetric { mirror, .. } => self.source.error_at(
                &[Key::Name("symmetry"), Key::Index(*mirror)],
                format!("{e}; symmetry needs a mirror-symmetric ground structure"),
            ),
            SetupError::NoBeams => self.source.error_at(&[Key::Name("connect")], e.to_string()),
        }
    }

    fn round_settings(&self) -> RoundSettings {
        RoundSettings {
            min_length: self.spec.min_length,
            merge_tolerance: self.spec.rounds.merge_tolerance,
            prune: self.spec.rounds.prune,
            remove_crossings: self.spec.rounds.remove_crossings,
        }
    }
}

/// Runs the problem: solve, clean up and re-solve for the requested rounds, then report.
/// With `opts.check` the model is built and its derivatives checked instead.
pub fn run(problem: &Problem, opts: &RunOptions) -> Result<Outcome, Error> {
    let seed = problem.seed(opts);
    let started = Instant::now();
    let model = problem.model_for(seed)?;
    let mut nlp = problem.nlp(&model, seed)?;
    let mut timings = BTreeMap::new();
    timings.insert("build".to_string(), started.elapsed().as_secs_f64());
    if opts.check {
        return check(problem, &nlp, seed, timings);
    }
    let mut options = problem.spec.solver.options();
    if let Some(m) = opts.max_iter {
        options.max_iterations = m;
    }
    if opts.quiet {
        options.verbosity = 0;
    }
    options.interrupt = opts.interrupt.clone();
    let rounds = opts.rounds.unwrap_or(problem.spec.rounds.count).max(1);
    let initial = (model.structure.joints.len(), model.structure.beams.len());
    let mut reports = Vec::new();
    let mut iterations = 0;
    let mut evaluations = Evaluations::default();
    let mut logs = Vec::new();
    let solve_start = Instant::now();
    let mut solution: Solution;
    let mut round = 0;
    loop {
        solution = crate::solver::solve(&nlp, &options);
        iterations += solution.iterations;
        evaluations.functions += solution.evaluations.functions;
        evaluations.derivatives += solution.evaluations.derivatives;
        evaluations.hessians += solution.evaluations.hessians;
        logs.push(solution.log.clone());
        round += 1;
        let interrupted = solution.status == crate::solver::Status::Interrupted;
        if round == rounds || interrupted {
            break;
        }
        let (structure, forces, report) = topology::clean(
            nlp.structure(),
            &nlp.positions(&solution.x),
            &nlp.forces(&solution.x),
            &problem.round_settings(),
        );
        reports.push(report);
        nlp = TrussNlp::new(structure, model.settings.clone(), forces)
            .map_err(|e| Error::Runtime(format!("round {round}: {e}")))?;
    }
    timings.insert("solve".to_string(), solve_start.elapsed().as_secs_f64());

    let export_start = Instant::now();
    let design = Design::from_point(&nlp, &solution.x);
    let figures = design.figures(nlp.settings());
    let mut summary = ResultSummary::from_solution(problem.name(), "truss", seed, &solution);
    summary.iterations = iterations;
    summary.evaluations = evaluations;
    summary.figures = json!({
        "mass_kg": figures.mass_kg,
        "length_m": figures.length_m,
        "joints_before": initial.0,
        "beams_before": initial.1,
        "joints_after": figures.joints,
        "beams_after": figures.beams,
        "active_beams": figures.active_beams,
        "max_balance_residual_n": figures.max_balance_residual_n,
        "max_balance_residual_relative": figures.max_balance_residual_relative,
        "max_force_ratio": figures.max_force_ratio,
        "load_cases": nlp.settings().load_cases,
        "rounds": reports,
    });
    let glb = export::model_glb(&design).map_err(|e| Error::Runtime(e.to_string()))?;
    let mut artifacts = vec![
        Artifact {
            name: "model.glb".into(),
            bytes: glb,
        },
        Artifact {
            name: "beams.csv".into(),
            bytes: export::beams_csv(&design).into_bytes(),
        },
        Artifact {
            name: "preview.svg".into(),
            bytes: export::preview_svg(&design).into_bytes(),
        },
    ];
    // One iteration log per round: iterations.csv, then iterations_round2.csv, ...
    for (r, round_log) in logs.iter().enumerate() {
        let file = if r == 0 {
            "iterations.csv".to_string()
        } else {
            format!("iterations_round{}.csv", r + 1)
        };
        artifacts.push(crate::io::result::iterations_csv(&file, round_log));
    }
    timings.insert("export".to_string(), export_start.elapsed().as_secs_f64());
    summary.timings = timings;
    Ok(Outcome {
        status: Some(solution.status),
        summary,
        check_passed: None,
        artifacts,
    })
}

/// `--check`: the model is built and its derivatives are compared with central differences at
/// the start point by the shared checker (`crate::solver::derivatives`). Sphere-obstacle rows
/// whose segment sits exactly at the interior/end-point switch are C¹ there, not C², so a
/// Hessian discrepancy on them is expected; the report lists the worst functions by name.
fn check(
    problem: &Problem,
    nlp: &TrussNlp,
    seed: u64,
    mut timings: BTreeMap<String, f64>,
) -> Result<Outcome, Error> {
    let started = Instant::now();
    let mut x = vec![0.0; nlp.dims().n];
    nlp.start(&mut x);
    let report = check_derivatives(nlp, &x, &CheckOptions::default())
        .map_err(|e| Error::Runtime(format!("derivative check: {e}")))?;
    timings.insert("check".to_string(), started.elapsed().as_secs_f64());
    let d = nlp.dims();
    let mut summary = ResultSummary::checked(problem.name(), "truss", seed, nlp, &x, &report)
        .map_err(|e| Error::Runtime(format!("evaluation at the start point: {e}")))?;
    summary.timings = timings;
    summary.set_figure("variables", d.n);
    summary.set_figure("constraints", d.m);
    summary.set_figure("jacobian_nonzeros", d.jac_nnz);
    summary.set_figure("hessian_nonzeros", d.hess_nnz);
    summary.set_figure("joints", nlp.structure().joints.len());
    summary.set_figure("beams", nlp.structure().beams.len());
    Ok(Outcome {
        summary,
        status: None,
        check_passed: Some(report.passed()),
        artifacts: Vec::new(),
    })
}
