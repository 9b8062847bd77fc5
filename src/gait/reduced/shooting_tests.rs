//! Tests of multiple shooting: single shooting is one plain rollout, segments started on that
//! rollout reproduce it exactly, and the exact Jacobian (including the start-state columns and
//! the continuity rows) matches the dual-number oracle and extrapolated central differences.

use super::Reduced;
use super::tests::shortened;
use crate::gait::sim::Simulator;
use crate::gait::spline::SplineControls;
use crate::solver::Nlp;
use crate::solver::derivatives::check_derivatives;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Random spline parameters within a third of the force bounds; slopes up to ±20.
fn random_parameters(nlp: &Reduced<'_>, seed: u64) -> Vec<f64> {
    let crate::solver::Bounds { xl, xu, .. } = crate::solver::Bounds::of(nlp);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..nlp.parameters())
        .map(|j| {
            let span = if xl[j].is_finite() {
                (xu[j] - xl[j]) / 6.0
            } else {
                20.0
            };
            rng.random_range(-span..span)
        })
        .collect()
}

/// `S = 1` has the spline parameters as its only variables and its constraint values are, bit
/// for bit, those of one `Simulator::rollout` read at the key times.
#[test]
fn one_segment_is_a_plain_rollout() {
    let p = shortened("luxo_leap", 0.3);
    let nlp = Reduced::with_segments(&p, 1);
    let d = nlp.dims();
    assert_eq!(d.n, nlp.parameters());
    assert_eq!(d.m, p.constraints.len());
    let x = random_parameters(&nlp, 1);
    let (mut f, mut c) = (0.0, vec![0.0; d.m]);
    nlp.eval(&x, &mut f, &mut c).unwrap();
    let mut steps: Vec<usize> = p.constraints.iter().map(|c| c.step).collect();
    steps.dedup();
    let controls = SplineControls {
        grid: nlp.grid(),
        params: x.clone(),
    };
    let mut state = p.initial.clone();
    let mut sim = Simulator::<f64>::new(&p.model);
    let mut expected = vec![f64::NAN; d.m];
    sim.rollout(&mut state, p.dt, &steps, &controls, |k, s, sim| {
        for (r, con) in p.constraints.iter().enumerate() {
            if con.step == steps[k] {
                expected[r] = con.quantity.value(&p.model, s, &sim.dynamics);
            }
        }
    })
    .unwrap();
    assert_eq!(c, expected);
}

/// Segments started on the rollout of the same forces have zero continuity defects and the
/// single-shooting constraint values, exactly (the same arithmetic, step for step).
#[test]
fn segments_on_the_rollout_reproduce_single_shooting() {
    let p = shortened("luxo_leap", 0.3);
    let single = Reduced::with_segments(&p, 1);
    let x = random_parameters(&single, 2);
    let (mut f1, mut c1) = (0.0, vec![0.0; single.dims().m]);
    single.eval(&x, &mut f1, &mut c1).unwrap();
    for s in [2, 3, 5] {
        let nlp = Reduced::with_segments(&p, s);
        let d = nlp.dims();
        let nx = p.model.nq + p.model.nv;
        assert_eq!(nlp.segments(), s);
        assert_eq!(d.n, nlp.parameters() + (s - 1) * nx);
        assert_eq!(d.m, c1.len() + (s - 1) * nx);
        let mut z = x.clone();
        z.resize(d.n, f64::NAN);
        nlp.fill_states(&mut z);
        let (mut f, mut c) = (0.0, vec![0.0; d.m]);
        nlp.eval(&z, &mut f, &mut c).unwrap();
        assert_eq!(f, f1);
        assert_eq!(c[..c1.len()], c1[..], "S = {s}");
        assert!(c[c1.len()..].iter().all(|&v| v == 0.0), "S = {s}");
    }
}

/// The multiple-shooting Jacobian agrees with the dual-number oracle and, through the shared
/// checker with Richardson extrapolation, with central differences, at start states perturbed
/// by up to 1e-6 off the rollout (nonzero defects). Larger moves put the stiff contact spring
/// within the difference steps: at 1e-3 one entry's extrapolated estimate was 5e-5 off while
/// the dual-number oracle agreed to 1e-9.
#[test]
fn multiple_shooting_derivatives_match_central_differences() {
    for (name, factor, segments) in [("luxo_leap", 0.2, 3), ("biped_hop", 0.05, 2)] {
        let p = shortened(name, factor);
        let nlp = Reduced::with_segments(&p, segments);
        let d = nlp.dims();
        let mut x = random_parameters(&nlp, 3);
        x.resize(d.n, 0.0);
        nlp.fill_states(&mut x);
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        for v in &mut x[nlp.parameters()..] {
            *v += rng.random_range(-1e-6..1e-6);
        }
        let (mut grad, mut fast, mut oracle) =
            (vec![0.0; d.n], vec![0.0; d.jac_nnz], vec![0.0; d.jac_nnz]);
        nlp.eval_derivatives(&x, &mut grad, &mut fast).unwrap();
        nlp.jacobian_by_parameter_duals(&x, &mut oracle).unwrap();
        let largest = oracle.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        let gap = fast
            .iter()
            .zip(&oracle)
            .map(|(a, b)| (a - b).abs() / b.abs().max(1e-3 * largest))
            .fold(0.0, f64::max);
        assert!(gap < 1e-9, "{name}: sensitivities vs duals {gap}");
        let report = check_derivatives(&nlp, &x, &crate::gait::check_options()).unwrap();
        println!(
            "{name}, S = {segments}: n = {}, m = {}, max error {:.2e} (checked {}, failed {})",
            d.n, d.m, report.jacobian.max_error, report.jacobian.checked, report.jacobian.failed
        );
        assert!(report.passed(), "{name}: {:?}", report.worst_per_function);
        assert!(report.jacobian.checked >= d.jac_nnz);
    }
}
