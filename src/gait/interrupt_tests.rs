//! Ctrl-C inside a gait run: the interrupt flag stops a rollout within a few RK4 steps, and a
//! whole run stops within a second with status `Interrupted` (exit 130) and its best point.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use super::reduced::Reduced;
use super::{Gait, GaitProblem, load};
use crate::application::run_problem;
use crate::outcome::RunOptions;
use crate::solver::interrupt::INTERRUPTED;
use crate::solver::{EvalError, Interrupt, Nlp, Status};

fn shipped(name: &str) -> super::Problem {
    load(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("problems/gait/{name}.toml")))
        .unwrap()
}

/// Raises `interrupt` after `delay` on another thread while `work` runs; returns the work's
/// result and the time from raising the flag to its end.
fn interrupted_after<T: Send>(
    interrupt: &Interrupt,
    delay: Duration,
    work: impl FnOnce() -> T + Send,
) -> (T, Duration) {
    std::thread::scope(|scope| {
        let raised = scope.spawn(|| {
            std::thread::sleep(delay);
            interrupt.raise();
            Instant::now()
        });
        let result = work();
        let end = Instant::now();
        let raised = raised.join().unwrap();
        (result, end.saturating_duration_since(raised))
    })
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn a_raised_flag_stops_a_long_rollout_within_a_few_steps() {
    let mut problem = shipped("luxo_leap");
    let nlp = Reduced::new(&problem);
    let d = nlp.dims();
    let mut x = vec![0.0; d.n];
    nlp.start(&mut x);
    let (mut g, mut jac) = (vec![0.0; d.n], vec![0.0; d.jac_nnz]);
    let clock = Instant::now();
    nlp.eval_derivatives(&x, &mut g, &mut jac).unwrap();
    let whole = clock.elapsed();
    assert!(
        whole > Duration::from_millis(20),
        "a long rollout: {whole:?}"
    );

    problem.interrupt = Interrupt::new();
    let nlp = Reduced::new(&problem);
    let (result, latency) = interrupted_after(&problem.interrupt, whole / 4, || {
        nlp.eval_derivatives(&x, &mut g, &mut jac)
    });
    assert_eq!(result, Err(EvalError::Fatal(INTERRUPTED.into())));
    assert!(
        latency < whole / 4 && latency < Duration::from_millis(100),
        "stopped {latency:?} after the flag (whole rollout {whole:?})"
    );
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn an_interrupted_run_stops_within_a_second_with_its_best_point() {
    let problem = GaitProblem::Reduced(Box::new(shipped("pogo_crouch")));
    let opts = RunOptions {
        quiet: true,
        ..RunOptions::default()
    };
    let (outcome, latency) =
        interrupted_after(&opts.interrupt, Duration::from_millis(1500), || {
            run_problem::<Gait>(&problem, &opts)
        });
    let outcome = outcome.unwrap();
    assert!(
        latency < Duration::from_secs(1),
        "stopped after {latency:?}"
    );
    assert_eq!(outcome.status, Some(Status::Interrupted));
    assert_eq!(outcome.summary.status, "Interrupted");
    assert_eq!(outcome.exit_code(), 130);
    let names: Vec<&str> = outcome.artifacts.iter().map(|a| a.name.as_str()).collect();
    assert!(names.contains(&"model.glb"), "{names:?}");
}

#[test]
fn an_interrupted_check_reports_interrupted() {
    let problem = GaitProblem::Reduced(Box::new(shipped("pogo_crouch")));
    let opts = RunOptions {
        check: true,
        ..RunOptions::default()
    };
    opts.interrupt.raise();
    let outcome = run_problem::<Gait>(&problem, &opts).unwrap();
    assert_eq!(outcome.status, Some(Status::Interrupted));
    assert_eq!(outcome.check_passed, None);
    assert_eq!(outcome.exit_code(), 130);
}
