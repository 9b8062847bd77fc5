//! End-to-end checks of the global methods and the finite-difference fallback with the real
//! SQP solver.

use optimize::solver::derivatives::{
    FiniteDifferenceNlp, FiniteDifferenceOptions, solve_forward_then_central,
};
use optimize::solver::global::{
    AnnealOptions, MultistartOptions, StartGenerator, StartKind, multistart, optimize,
};
use optimize::solver::{Dims, EvalError, Nlp, Options, solve};
use optimize::spec::{GlobalSpec, Key, Source};

#[path = "common/hs.rs"]
mod hs;

/// Two wells along x0 (the left one deeper) inside a disk:
/// min (x0² − 1)² + 0.3·x0 + (x1 − 0.5)²  s.t.  x0² + x1² ≤ 4,  −2 ≤ x ≤ 2; start (0.9, 0).
struct WellsInDisk;

impl Nlp for WellsInDisk {
    fn dims(&self) -> Dims {
        Dims {
            n: 2,
            m: 1,
            jac_nnz: 2,
            hess_nnz: 0,
        }
    }
    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        xl.fill(-2.0);
        xu.fill(2.0);
        cl[0] = f64::NEG_INFINITY;
        cu[0] = 4.0;
    }
    fn start(&self, x: &mut [f64]) {
        x.copy_from_slice(&[0.9, 0.0]);
    }
    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        rows.copy_from_slice(&[0, 0]);
        cols.copy_from_slice(&[0, 1]);
    }
    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        *f = (x[0] * x[0] - 1.0).powi(2) + 0.3 * x[0] + (x[1] - 0.5).powi(2);
        c[0] = x[0] * x[0] + x[1] * x[1];
        Ok(())
    }
    fn eval_derivatives(&self, x: &[f64], g: &mut [f64], j: &mut [f64]) -> Result<(), EvalError> {
        g[0] = 4.0 * x[0] * (x[0] * x[0] - 1.0) + 0.3;
        g[1] = 2.0 * (x[1] - 0.5);
        j[0] = 2.0 * x[0];
        j[1] = 2.0 * x[1];
        Ok(())
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

fn quiet() -> Options {
    Options {
        verbosity: 0,
        ..Options::default()
    }
}

#[test]

fn multistart_with_sqp_finds_the_deeper_well() {
    // The deeper well: 4x(x² − 1) + 0.3 = 0 on the left branch, x1 = 0.5.
    let mut left = -1.0f64;
    for _ in 0..50 {
        left -= (4.0 * left * (left * left - 1.0) + 0.3) / (12.0 * left * left - 4.0);
    }
    let global = (left * left - 1.0).powi(2) + 0.3 * left;
    let settings = MultistartOptions {
        starts: 6,
        seed: 1,
        ..Default::default()
    };
    let result = multistart(&WellsInDisk, &settings, &quiet());
    let s = &result.solution;
    assert!(s.status.is_success(), "{:?}", s.status);
    assert!(
        (s.x[0] - left).abs() < 1e-6 && (s.x[1] - 0.5).abs() < 1e-6,
        "{:?}",
        s.x
    );
    assert!((s.objective - global).abs() <= 1e-6 * global.abs().max(1.0));
    // The problem's own start lies in the shallow well (x0 = 0.9, downhill to x0 ≈ 0.96).
    assert!(result.runs.iter().all(|r| r.objective >= s.objective));
}

#[test]

fn hybrid_with_sqp_solves_a_constrained_problem_from_an_infeasible_start() {
    let settings = MultistartOptions {
        starts: 2,
        seed: 5,
        generator: StartGenerator::Anneal(AnnealOptions {
            max_evaluations: 2000,
            ..Default::default()
        }),
        ..Default::default()
    };
    let result = multistart(&Corner, &settings, &quiet());
    let s = &result.solution;
    assert!(s.status.is_success(), "{:?}", s.status);
    assert!((s.objective - 1.0).abs() <= 1e-6 && s.max_violation <= 1e-6);
    assert_eq!(result.anneal.len(), 2);
    assert!(
        result.runs[1..]
            .iter()
            .all(|r| r.kind == StartKind::Annealed)
    );
}

#[test]

fn finite_difference_fallback_solves_hs071() {
    // Hock–Schittkowski 71 of the HS set: f* = 17.0140173 at (1, 4.7429994, 3.8211503,
    // 1.3794082); its exact derivatives are replaced by finite differences.
    let problem = hs::all()
        .into_iter()
        .find(|p| p.name == "HS71")
        .expect("HS71 is in the set");
    let nlp = problem.nlp(false);
    let fd = FiniteDifferenceNlp::new(&nlp, FiniteDifferenceOptions::default());
    let options = quiet();
    let s = solve_forward_then_central(&fd, |p| solve(p, &options));
    assert!(s.status.is_success(), "{:?}", s.status);
    assert!(
        (s.objective - 17.0140173).abs() <= 1e-6 * 17.0140173,
        "f = {}",
        s.objective
    );
    assert!(s.max_violation <= 1e-6);
    assert!(fd.difference_evaluations() > 0);
}

#[test]

fn global_table_drives_a_run() {
    let source = Source {
        path: "wells.toml".into(),
        text: "[global]\nmethod = \"multistart\"\nstarts = 6\nperturbation = 0.25\n".into(),
    };
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct File {
        global: GlobalSpec,
    }
    let file: File = source.parse().unwrap();
    file.global
        .validate(&source, &[Key::Name("global")])
        .unwrap();
    let result = optimize(&WellsInDisk, &file.global.options(1), &quiet());
    assert!(result.solution.status.is_success());
    assert!(result.solution.x[0] < -1.0);
}
