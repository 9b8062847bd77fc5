//! Annealing and multistart on multimodal test functions with known global minima.

use super::*;
use crate::solver::{Dims, EvalError, Evaluations, Nlp, Solution, Status};

/// A bound-constrained problem given by plain functions.
struct BoxProblem {
    f: fn(&[f64]) -> f64,
    grad: fn(&[f64], &mut [f64]),
    xl: Vec<f64>,
    xu: Vec<f64>,
    x0: Vec<f64>,
}

impl Nlp for BoxProblem {
    fn dims(&self) -> Dims {
        Dims {
            n: self.x0.len(),
            m: 0,
            jac_nnz: 0,
            hess_nnz: 0,
        }
    }
    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], _: &mut [f64], _: &mut [f64]) {
        xl.copy_from_slice(&self.xl);
        xu.copy_from_slice(&self.xu);
    }
    fn start(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.x0);
    }
    fn jacobian_structure(&self, _: &mut [usize], _: &mut [usize]) {}
    fn eval(&self, x: &[f64], f: &mut f64, _: &mut [f64]) -> Result<(), EvalError> {
        *f = (self.f)(x);
        Ok(())
    }
    fn eval_derivatives(&self, x: &[f64], g: &mut [f64], _: &mut [f64]) -> Result<(), EvalError> {
        (self.grad)(x, g);
        Ok(())
    }
}

/// Six-hump camel: global minimum −1.031628453489877 at ±(0.08984201, −0.71265640).
fn camel(x: &[f64]) -> f64 {
    let (a, b) = (x[0], x[1]);
    (4.0 - 2.1 * a * a + a.powi(4) / 3.0) * a * a + a * b + (-4.0 + 4.0 * b * b) * b * b
}

fn camel_grad(x: &[f64], g: &mut [f64]) {
    let (a, b) = (x[0], x[1]);
    g[0] = 8.0 * a - 8.4 * a.powi(3) + 2.0 * a.powi(5) + b;
    g[1] = a - 8.0 * b + 16.0 * b.powi(3);
}

const CAMEL_MIN: f64 = -1.031628453489877;

/// The camel from its worst local minimum (f ≈ 2.104).
fn camel_problem() -> BoxProblem {
    BoxProblem {
        f: camel,
        grad: camel_grad,
        xl: vec![-3.0, -2.0],
        xu: vec![3.0, 2.0],
        x0: vec![-1.6071, -0.5687],
    }
}

/// Two wells along x0, the left one deeper: f = (x0² − 1)² + 0.3·x0 + (x1 − 0.5)².
fn wells(x: &[f64]) -> f64 {
    (x[0] * x[0] - 1.0).powi(2) + 0.3 * x[0] + (x[1] - 0.5).powi(2)
}

fn wells_grad(x: &[f64], g: &mut [f64]) {
    g[0] = 4.0 * x[0] * (x[0] * x[0] - 1.0) + 0.3;
    g[1] = 2.0 * (x[1] - 0.5);
}

fn wells_problem() -> BoxProblem {
    BoxProblem {
        f: wells,
        grad: wells_grad,
        xl: vec![-2.0, -2.0],
        xu: vec![2.0, 2.0],
        x0: vec![0.9, 0.0],
    }
}

/// Projected gradient with Armijo backtracking, for bound-constrained problems (m = 0):
/// the stand-in local solver of these tests.
fn projected_gradient(nlp: &dyn Nlp) -> Solution {
    let n = nlp.dims().n;
    let (mut xl, mut xu) = (vec![0.0; n], vec![0.0; n]);
    nlp.bounds(&mut xl, &mut xu, &mut [], &mut []);
    let mut x = vec![0.0; n];
    nlp.start(&mut x);
    let project = |v: Vec<f64>| -> Vec<f64> {
        v.iter()
            .enumerate()
            .map(|(j, &vj)| vj.clamp(xl[j], xu[j]))
            .collect()
    };
    let value = |x: &[f64]| {
        let mut f = 0.0;
        nlp.eval(x, &mut f, &mut []).unwrap();
        f
    };
    let mut g = vec![0.0; n];
    let mut f = value(&x);
    let mut evaluations = Evaluations::default();
    let mut status = Status::IterationLimit;
    let mut iterations = 0;
    let mut measure = f64::INFINITY;
    while iterations < 10_000 {
        nlp.eval_derivatives(&x, &mut g, &mut []).unwrap();
        evaluations.derivatives += 1;
        let step: Vec<f64> = project(x.iter().zip(&g).map(|(a, b)| a - b).collect());
        measure = step
            .iter()
            .zip(&x)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if measure < 1e-7 {
            status = Status::Optimal;
            break;
        }
        let mut alpha = 1.0;
        loop {
            let trial = project(x.iter().zip(&g).map(|(a, b)| a - alpha * b).collect());
            let ft = value(&trial);
            evaluations.functions += 1;
            let decrease: f64 = g
                .iter()
                .zip(trial.iter().zip(&x))
                .map(|(g, (t, x))| g * (x - t))
                .sum();
            if ft <= f - 1e-4 * decrease || alpha < 1e-12 {
                x = trial;
                f = ft;
                break;
            }
            alpha *= 0.5;
        }
        iterations += 1;
    }
    Solution {
        status,
        z: vec![0.0; n],
        lambda: Vec::new(),
        objective: f,
        constraints: Vec::new(),
        max_violation: 0.0,
        optimality: measure,
        iterations,
        evaluations,
        seconds: 0.0,
        log: Vec::new(),
        x,
    }
}

/// min (x − 2)² + (y − 1)²  s.t.  x² − y ≤ 0,  x + y ≤ 2,  −3 ≤ x, y ≤ 3: optimum (1, 1), f = 1.
struct Corner;

impl Nlp for Corner {
    fn dims(&self) -> Dims {
        Dims {
            n: 2,
            m: 2,
            jac_nnz: 4,
            hess_nnz: 0,
        }
    }
    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        xl.fill(-3.0);
        xu.fill(3.0);
        cl.fill(f64::NEG_INFINITY);
        cu.copy_from_slice(&[0.0, 2.0]);
    }
    fn start(&self, x: &mut [f64]) {
        x.copy_from_slice(&[-2.0, -2.0]);
    }
    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        rows.copy_from_slice(&[0, 0, 1, 1]);
        cols.copy_from_slice(&[0, 1, 0, 1]);
    }
    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        *f = (x[0] - 2.0).powi(2) + (x[1] - 1.0).powi(2);
        c[0] = x[0] * x[0] - x[1];
        c[1] = x[0] + x[1];
        Ok(())
    }
    fn eval_derivatives(&self, x: &[f64], g: &mut [f64], j: &mut [f64]) -> Result<(), EvalError> {
        g[0] = 2.0 * (x[0] - 2.0);
        g[1] = 2.0 * (x[1] - 1.0);
        j.copy_from_slice(&[2.0 * x[0], -1.0, 1.0, 1.0]);
        Ok(())
    }
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn in_pool<T: Send>(threads: usize, job: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(job)
}

#[test]
fn annealing_finds_the_camel_global_basin_from_a_bad_start() {
    let problem = camel_problem();
    let options = AnnealOptions {
        seed: 7,
        max_evaluations: 20_000,
        ..Default::default()
    };
    let run = anneal(&problem, &options);
    let s = &run.solution;
    assert!(s.objective < CAMEL_MIN + 1e-3, "f = {}", s.objective);
    let near = |a: f64, b: f64| ((s.x[0] - a).powi(2) + (s.x[1] - b).powi(2)).sqrt() < 0.05;
    assert!(near(0.0898, -0.7127) || near(-0.0898, 0.7127), "{:?}", s.x);
    assert!(s.x.iter().zip([3.0, 2.0]).all(|(x, b)| x.abs() <= b));
    // The search froze (best cost repeated) before the budget ran out: reported as Stalled.
    assert_eq!(run.stats.stop, AnnealStop::CostRepeat);
    assert_eq!(s.status, Status::Stalled);
    assert!(run.stats.generated < 20_000);
    assert_eq!(s.evaluations.functions, 1 + 5 + run.stats.generated);
    assert_eq!(s.iterations, run.stats.generated);
}

#[test]
fn annealing_is_deterministic_for_a_seed() {
    let problem = camel_problem();
    let options = AnnealOptions {
        seed: 3,
        max_evaluations: 3000,
        ..Default::default()
    };
    let a = anneal(&problem, &options);
    let b = in_pool(3, || anneal(&problem, &options));
    assert_eq!(bits(&a.solution.x), bits(&b.solution.x));
    assert_eq!(a.stats, b.stats);
    let other = anneal(&problem, &AnnealOptions { seed: 4, ..options });
    assert_ne!(bits(&a.solution.x), bits(&other.solution.x));
}

#[test]
fn annealing_with_penalty_reaches_the_constrained_optimum() {
    let options = AnnealOptions {
        seed: 11,
        max_evaluations: 50_000,
        ..Default::default()
    };
    let run = anneal(&Corner, &options);
    let s = &run.solution;
    assert!(s.max_violation <= 1e-6, "violation {}", s.max_violation);
    assert!(
        s.objective < 1.0 + 1e-6 && s.objective >= 1.0 - 1e-6,
        "f = {}",
        s.objective
    );
    assert!(
        (s.x[0] - 1.0).abs() < 1e-4 && (s.x[1] - 1.0).abs() < 1e-4,
        "{:?}",
        s.x
    );
    assert_eq!(s.status, Status::Stalled);
    // The log starts at the infeasible start and ends at the best state.
    assert!(s.log[0].infeasibility > 1.0);
    assert_eq!(s.log.last().unwrap().objective, s.objective);
}

#[test]
fn annealing_reports_an_infeasible_best_as_infeasible() {
    // x² + y² ≤ −1 cannot hold.
    struct Impossible;
    impl Nlp for Impossible {
        fn dims(&self) -> Dims {
            Dims {
                n: 2,
                m: 1,
                jac_nnz: 2,
                hess_nnz: 0,
            }
        }
        fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
            xl.fill(-1.0);
            xu.fill(1.0);
            cl[0] = f64::NEG_INFINITY;
            cu[0] = -1.0;
        }
        fn start(&self, x: &mut [f64]) {
            x.fill(0.5);
        }
        fn jacobian_structure(&self, r: &mut [usize], c: &mut [usize]) {
            r.copy_from_slice(&[0, 0]);
            c.copy_from_slice(&[0, 1]);
        }
        fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
            *f = x[0] + x[1];
            c[0] = x[0] * x[0] + x[1] * x[1];
            Ok(())
        }
        fn eval_derivatives(
            &self,
            _: &[f64],
            _: &mut [f64],
            _: &mut [f64],
        ) -> Result<(), EvalError> {
            unreachable!()
        }
    }
    let run = anneal(
        &Impossible,
        &AnnealOptions {
            max_evaluations: 2000,
            ..Default::default()
        },
    );
    assert_eq!(run.solution.status, Status::Infeasible);
    // The least-infeasible state is near the origin, violation ≈ 1.
    assert!((run.solution.max_violation - 1.0).abs() < 1e-2);
    assert!(
        run.stats.penalty > 10.0 * 10.0,
        "penalty grew: {}",
        run.stats.penalty
    );
}

#[test]
fn annealing_stops_when_the_best_cost_repeats() {
    // A flat function: the best cost never changes.
    let flat = BoxProblem {
        f: |_| 1.0,
        grad: |_, g| g.fill(0.0),
        xl: vec![0.0],
        xu: vec![1.0],
        x0: vec![0.5],
    };
    let run = anneal(&flat, &AnnealOptions::default());
    assert_eq!(run.stats.stop, AnnealStop::CostRepeat);
    assert_eq!(run.stats.accepted, 500);
    assert_eq!(run.solution.status, Status::Stalled);
}

#[test]
fn multistart_picks_the_deeper_well() {
    let problem = wells_problem();
    let alone = projected_gradient(&problem);
    assert!(alone.x[0] > 0.9, "the given start lies in the shallow well");
    let settings = MultistartOptions {
        starts: 6,
        seed: 1,
        ..Default::default()
    };
    let result = multistart_with(&problem, &settings, projected_gradient);
    assert_eq!(result.runs.len(), 7);
    assert_eq!(result.runs[0].kind, StartKind::Given);
    assert_ne!(result.best_start, 0);
    let s = &result.solution;
    assert!(s.x[0] < -1.0 && (s.x[1] - 0.5).abs() < 1e-6, "{:?}", s.x);
    // Stationary (to the local solver's tolerance): 4x(x² − 1) + 0.3 = 0 on the left branch.
    assert!((4.0 * s.x[0] * (s.x[0] * s.x[0] - 1.0) + 0.3).abs() < 1e-6);
    assert!(s.objective < alone.objective - 0.5);
    // The best is the lowest objective, ties to the lowest index.
    for run in &result.runs {
        assert!(run.objective >= s.objective);
        if run.objective == s.objective {
            assert!(run.index >= result.best_start);
        }
    }
}

#[test]
fn multistart_does_not_depend_on_the_thread_count() {
    let problem = camel_problem();
    for generator in [
        StartGenerator::Perturb,
        StartGenerator::Anneal(AnnealOptions {
            max_evaluations: 500,
            ..Default::default()
        }),
    ] {
        let settings = MultistartOptions {
            starts: 5,
            seed: 9,
            generator,
            ..Default::default()
        };
        let one = in_pool(1, || {
            multistart_with(&problem, &settings, projected_gradient)
        });
        let many = in_pool(4, || {
            multistart_with(&problem, &settings, projected_gradient)
        });
        assert_eq!(one.best_start, many.best_start);
        assert_eq!(bits(&one.solution.x), bits(&many.solution.x));
        let objectives = |r: &GlobalResult| {
            r.runs
                .iter()
                .map(|r| r.objective.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(objectives(&one), objectives(&many));
        assert_eq!(one.evaluations, many.evaluations);
    }
}

#[test]
fn hybrid_polishes_annealed_starts_to_the_global_minimum() {
    let problem = camel_problem();
    let settings = MultistartOptions {
        starts: 3,
        seed: 2,
        generator: StartGenerator::Anneal(AnnealOptions {
            max_evaluations: 2000,
            ..Default::default()
        }),
        ..Default::default()
    };
    let result = multistart_with(&problem, &settings, projected_gradient);
    assert_eq!(result.anneal.len(), 3);
    assert!(
        result.runs[1..]
            .iter()
            .all(|r| r.kind == StartKind::Annealed)
    );
    assert!(
        (result.solution.objective - CAMEL_MIN).abs() < 1e-9,
        "{}",
        result.solution.objective
    );
    assert_eq!(result.solution.status, Status::Optimal);
    // Annealing evaluations are counted with their start.
    assert!(result.runs[1].evaluations.functions > 2000);
}

#[test]
fn ranking_puts_feasibility_first_then_objective_then_index() {
    let make = |objective: f64, max_violation: f64| Solution {
        status: Status::Optimal,
        x: vec![],
        lambda: vec![],
        z: vec![],
        objective,
        constraints: vec![],
        max_violation,
        optimality: 0.0,
        iterations: 0,
        evaluations: Evaluations::default(),
        seconds: 0.0,
        log: vec![],
    };
    let tol = 1e-6;
    let feasible = make(5.0, 1e-7);
    let infeasible = make(-100.0, 1e-3);
    assert!(ranks_before(&feasible, 3, &infeasible, 0, tol));
    assert!(ranks_before(&make(1.0, 0.0), 2, &feasible, 1, tol));
    assert!(ranks_before(&feasible, 1, &make(5.0, 0.0), 2, tol));
    assert!(!ranks_before(&feasible, 2, &make(5.0, 0.0), 1, tol));
    assert!(ranks_before(&make(9.0, 1e-4), 1, &infeasible, 0, tol));
    assert!(ranks_before(
        &make(9.0, 1.0),
        1,
        &make(f64::NAN, 0.0),
        0,
        tol
    ));
    assert!(ranks_before(
        &make(9.0, 1.0),
        1,
        &make(0.0, f64::NAN),
        0,
        tol
    ));
}

#[test]
fn anneal_method_wraps_its_run() {
    let result = optimize_with(
        &camel_problem(),
        &GlobalMethod::Anneal(AnnealOptions {
            max_evaluations: 100,
            ..Default::default()
        }),
        &crate::solver::Options::default(),
        |_| unreachable!("annealing alone runs no local solve"),
    );
    assert_eq!(result.runs.len(), 1);
    assert_eq!(result.anneal.len(), 1);
    assert_eq!(result.solution.iterations, 100);
}

/// 2-D Rastrigin: 20 + Σ (x² − 10·cos 2πx), global minimum 0 at the origin, a local minimum
/// near every integer point.
fn rastrigin(x: &[f64]) -> f64 {
    use std::f64::consts::TAU;
    20.0 + x
        .iter()
        .map(|v| v * v - 10.0 * (TAU * v).cos())
        .sum::<f64>()
}

#[test]
fn annealing_finds_the_rastrigin_origin_for_every_seed_tried() {
    let problem = BoxProblem {
        f: rastrigin,
        grad: |_, _| unreachable!("annealing uses values only"),
        xl: vec![-5.12; 2],
        xu: vec![5.12; 2],
        x0: vec![4.5, -4.5],
    };
    for seed in 0..8 {
        let run = anneal(
            &problem,
            &AnnealOptions {
                seed,
                max_evaluations: 20_000,
                ..Default::default()
            },
        );
        let s = &run.solution;
        assert!(s.objective < 1e-9, "seed {seed}: f = {:e}", s.objective);
        assert!(s.x.iter().all(|v| v.abs() < 1e-6), "seed {seed}: {:?}", s.x);
    }
}
