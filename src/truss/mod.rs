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
pub mod member_adding;
pub mod model;
pub mod nlp;
pub mod plastic;
pub mod quality;
pub mod restart;
pub mod rounds;
pub mod simplex;
pub mod spec;
pub mod start;
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

use crate::application::{Application, CheckCase};
use crate::error::{Error, InputError};
use crate::outcome::{Artifact, Headline, Kind, Outcome, ResultSummary, RunOptions};
use crate::solver::derivatives::CheckOptions;
use crate::solver::{Interrupt, Nlp};
use crate::spec::{Key, Source};

use build::Model;
use design::Design;
use nlp::{SetupError, TrussNlp};
use quality::Quality;
use spec::{StartForces, TrussSpec};
use start::LpReport;
use topology::{Crossings, RoundSettings};

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
    load_source(Source::read(path)?)
}

/// [`load`] from a file's text (with any `--set` overrides already applied).
pub fn load_source(source: Source) -> Result<Problem, InputError> {
    let path = source.path.clone();
    let spec: TrussSpec = source.parse()?;
    spec::validate(&spec, &source)?;
    let name = spec.name.clone().unwrap_or_else(|| {
        path.file_stem().map_or_else(
            || Kind::Truss.name().into(),
            |s| s.to_string_lossy().into_owned(),
        )
    });
    let model = build::build(&spec, &source, spec.seed.unwrap_or(0))?;
    let problem = Problem {
        source,
        spec,
        name,
        model,
    };
    // The NLP's setup checks at load time (bad input fails before the run starts).
    let model = &problem.model;
    nlp::check_setup(&model.structure, &model.settings).map_err(|e| problem.setup_error(&e))?;
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

    /// The seed a run uses: an explicit `--seed`, else the file's `seed`, else the run's (0).
    pub fn seed(&self, opts: &RunOptions) -> u64 {
        match self.spec.seed {
            Some(seed) if !opts.seed_given => seed,
            _ => opts.seed,
        }
    }

    /// The model for a seed (rebuilt only when random generation depends on it).
    pub fn model_for(&self, seed: u64) -> Result<Model, InputError> {
        if seed == self.spec.seed.unwrap_or(0) {
            Ok(self.model.clone())
        } else {
            build::build(&self.spec, &self.source, seed)
        }
    }

    /// The NLP of a model's whole ground structure, with start forces drawn from `seed` (random
    /// also for the `layout` start, which [`Problem::staged_nlp`] computes).
    pub fn nlp(&self, model: &Model, seed: u64) -> Result<TrussNlp, InputError> {
        let cases = model.settings.load_cases.len();
        let forces = match self.spec.start_forces {
            StartForces::Random | StartForces::Layout => {
                TrussNlp::random_start_forces(&model.structure, cases, seed)
            }
            StartForces::Zero => vec![0.0; cases * model.structure.beams.len()],
        };
        TrussNlp::new(model.structure.clone(), model.settings.clone(), forces)
            .map_err(|e| self.setup_error(&e))
    }

    /// The NLP the first solve starts from. With the `layout` start: the layout LP's forces on
    /// the ground structure without its idle beams ([`start::layout_start`]); should that LP have
    /// no solution or be interrupted (`interrupt` raised), the random start on the whole ground
    /// structure. Also returns a description of the start for result.json.
    pub fn staged_nlp(
        &self,
        model: &Model,
        seed: u64,
        interrupt: &Interrupt,
    ) -> Result<(TrussNlp, serde_json::Value, Option<LpReport>), InputError> {
        if self.spec.start_forces != StartForces::Layout {
            let method = match self.spec.start_forces {
                StartForces::Zero => "zero",
                _ => "random",
            };
            return Ok((self.nlp(model, seed)?, json!({ "method": method }), None));
        }
        let full = model.full.as_ref();
        let layout = start::layout_start(&model.structure, &model.settings, full, interrupt)
            .map_err(|e| e.to_string())
            .and_then(|layout| {
                let report = json!({
                    "method": "layout",
                    "lp_cost": layout.lp.cost,
                    "lp": layout.lp,
                    "dropped_beams": layout.dropped_beams,
                    "dropped_joints": layout.dropped_joints,
                });
                // Pruning can separate a mirror pair the symmetrized forces left unbalanced.
                TrussNlp::with_parts(
                    layout.structure,
                    model.settings.clone(),
                    layout.forces,
                    layout.parts,
                )
                .map(|nlp| (nlp, report, Some(layout.lp)))
                .map_err(|e| e.to_string())
            });
        match layout {
            Ok(staged) => Ok(staged),
            Err(e) => Ok((
                self.nlp(model, seed)?,
                json!({ "method": "random", "layout_failed": e }),
                None,
            )),
        }
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
            crossings: if self.spec.rounds.remove_crossings {
                Crossings::Remove
            } else if self.spec.rounds.split_crossings {
                Crossings::Split
            } else {
                Crossings::Keep
            },
            max_length: self.spec.max_length,
            merge: true,
            compression_runs: self.model.settings.compression_linear_in_length(),
        }
    }
}

/// Truss problems as an [`Application`].
pub struct Truss;

impl Application for Truss {
    const KIND: Kind = Kind::Truss;
    type Problem = Problem;

    fn load(source: Source) -> Result<Problem, Error> {
        Ok(load_source(source)?)
    }

    fn name(problem: &Problem) -> &str {
        problem.name()
    }

    /// The model built with the run's seed, checked at [`check_point`] with the difference
    /// scale of [`check_options`].
    fn check_case<'p>(problem: &'p Problem, opts: &RunOptions) -> Result<CheckCase<'p>, Error> {
        let seed = problem.seed(opts);
        let started = Instant::now();
        let nlp = problem.nlp(&problem.model_for(seed)?, seed)?;
        let build_seconds = started.elapsed().as_secs_f64();
        let (x, options) = (check_point(&nlp, seed), check_options(&nlp));
        let (hess_nnz, joints, beams) = (
            nlp.dims().hess_nnz,
            nlp.structure().joints.len(),
            nlp.structure().beams.len(),
        );
        let mut case = CheckCase::new(Box::new(nlp), x, options, seed)
            .figure("hessian_nonzeros", hess_nnz)
            .figure("joints", joints)
            .figure("beams", beams);
        case.build_seconds = Some(build_seconds);
        Ok(case)
    }

    fn run(problem: &Problem, opts: &RunOptions) -> Result<Outcome, Error> {
        run(problem, opts)
    }
}

/// Runs the problem: solve, clean up and re-solve for the requested rounds, then report.
pub fn run(problem: &Problem, opts: &RunOptions) -> Result<Outcome, Error> {
    let seed = problem.seed(opts);
    let started = Instant::now();
    let model = problem.model_for(seed)?;
    let mut timings = BTreeMap::new();
    let (nlp, start_report, lp) = match &opts.start {
        Some(previous) => (
            restart::nlp_from(previous, &model)?,
            json!({ "method": "result", "file": previous.path }),
            None,
        ),
        None => problem.staged_nlp(&model, seed, &opts.interrupt)?,
    };
    let start = quality::Point::start(&nlp)
        .ok()
        .map(|point| (nlp.clone(), point));
    timings.insert("build".to_string(), started.elapsed().as_secs_f64());
    let initial = (model.structure.joints.len(), model.structure.beams.len());
    let options = opts.solver_options(&problem.spec.solver);
    let count = opts.rounds.or(problem.spec.rounds.count);
    let solve_start = Instant::now();
    let rounds::Rounds {
        mut nlp,
        mut solution,
        reports,
        rounds_run,
        result_round,
        iterations,
        evaluations,
        logs,
    } = rounds::solve_rounds(nlp, &options, count, &problem.round_settings())?;
    let unit = nlp.objective_unit();
    let final_value = solution.objective * unit.scale;
    let mut kept_start = false;
    let start_figures = start.map(|(start_nlp, point)| {
        let feasible = point.violation <= options.constraint_tolerance;
        let start_value = point.objective * start_nlp.objective_unit().scale;
        if quality::keeps_start(&point, solution.objective, options.constraint_tolerance) {
            kept_start = true;
            nlp = start_nlp;
            solution.x = point.x;
            solution.objective = point.objective;
            solution.constraints = point.constraints;
            solution.max_violation = point.violation;
        }
        (start_value, feasible)
    });
    timings.insert("solve".to_string(), solve_start.elapsed().as_secs_f64());

    let export_start = Instant::now();
    let design = Design::from_point(&nlp, &solution.x);
    let figures = design.figures(nlp.settings());
    let mut summary = ResultSummary::from_solution(problem.name(), Kind::Truss, seed, &solution);
    summary.headline = Headline::of(&unit, solution.objective * unit.scale);
    let quality = start_figures.map(|(start_value, feasible)| {
        let q = Quality::new(
            nlp.settings(),
            lp.as_ref(),
            &unit.unit,
            final_value,
            start_value,
            feasible,
            kept_start,
        );
        summary.status_message = format!("{} {}", summary.status_message, q.sentence());
        q
    });
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
        "start": start_report,
        "quality": quality,
        "rounds": reports,
        "rounds_run": rounds_run,
        "result_round": result_round,
        "design": restart::design_json(&design),
    });
    let caption = format!(
        "{}: {}, {} beams; {}",
        problem.name(),
        summary.headline.text(),
        figures.active_beams,
        solution.status.sentence()
    );
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
            bytes: export::preview_svg(&design, &caption).into_bytes(),
        },
    ];
    // One iteration log for all rounds (its `stage` column names the round).
    artifacts.extend(crate::io::result::iteration_files(
        problem.name(),
        &summary.headline,
        &logs.concat(),
    ));
    timings.insert("export".to_string(), export_start.elapsed().as_secs_f64());
    summary.timings = timings;
    Ok(Outcome {
        status: Some(solution.status),
        summary,
        check_passed: None,
        artifacts,
    })
}

/// The point a derivative check uses: the start, with every free-joint coordinate moved by a
/// seeded uniform offset of at most 5% of the shortest beam. A generated lattice puts many
/// segments exactly where their closest point to a sphere obstacle switches between an end and
/// the interior; there the squared distance is C¹ but its second derivative jumps, so central
/// differences straddling the switch match neither side. Joints of segments whose closest-point
/// parameter t is still within `SWITCH_MARGIN` of 0 or 1 get new offsets until none is (the
/// difference steps move t by about 1e-4).
pub fn check_point(nlp: &TrussNlp, seed: u64) -> Vec<f64> {
    use rand::{RngExt, SeedableRng};
    const SWITCH_MARGIN: f64 = 1e-2;
    let mut start = vec![0.0; nlp.dims().n];
    nlp.start(&mut start);
    let shortest = (0..nlp.structure().beams.len())
        .map(|j| nlp.structure().length(j))
        .fold(f64::INFINITY, f64::min);
    let amplitude = 0.05 * shortest / nlp.length_scale();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut x = start.clone();
    let mut redraw: Vec<usize> = nlp.position_variables().collect();
    for _ in 0..100 {
        for &v in &redraw {
            x[v] = start[v] + amplitude * (2.0 * rng.random::<f64>() - 1.0);
        }
        let p = nlp.positions(&x);
        redraw.clear();
        for (_, j, center, _) in nlp.sphere_rows() {
            let [a, b] = nlp.structure().beams[j].ends;
            let u = p[b] - p[a];
            let t = -(p[a] - center).dot(&u) / u.norm_squared();
            if t.abs() < SWITCH_MARGIN || (t - 1.0).abs() < SWITCH_MARGIN {
                for end in [a, b] {
                    redraw.extend(nlp.joint_variables(end).into_iter().flatten());
                }
            }
        }
        if redraw.is_empty() {
            break;
        }
    }
    x
}

/// Checker options for a truss NLP: central differences over the characteristic scale
/// s = (shortest beam)/D in the scaled variables, instead of 1 + |x|. Positions are O(1) after
/// division by the span D, but the functions vary over one beam length: with s = 1 + |x| the
/// step is a sizeable fraction of the shortest beam and the O(h²) truncation error of the
/// Hessian differences reaches 1e-5 on bridges with 6 m panels in a 72 m span.
pub fn check_options(nlp: &TrussNlp) -> CheckOptions {
    let shortest = (0..nlp.structure().beams.len())
        .map(|j| nlp.structure().length(j))
        .fold(f64::INFINITY, f64::min);
    let mut options = CheckOptions::default();
    options.differences.characteristic_scale =
        Some((shortest / nlp.length_scale()).clamp(1e-3, 1.0));
    options
}
