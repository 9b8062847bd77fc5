//! Tests of multiple shooting: single shooting is one plain rollout, segments started on that
//! rollout reproduce it exactly, and the exact Jacobian (including the start-state columns and
//! the continuity rows) matches the dual-number oracle and extrapolated central differences.

use super::Reduced;
use super::tests::{central_difference, gap_to_oracle, ridders_gradient, shortened};
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

/// The exact Jacobian values at `x` (pattern order), asserted equal to the dual-number
/// oracle's to 1e-9 (relative, see `gap_to_oracle`) or, where the motion amplifies round-off
/// beyond that, to within the measured round-off floor ([`roundoff_floor`]).
fn jacobian_matching_the_oracle(nlp: &Reduced<'_>, x: &[f64], what: &str) -> Vec<f64> {
    let (fast, oracle) = exact_and_oracle(nlp, x);
    let gap = gap_to_oracle(&fast, &oracle);
    if gap >= 1e-9 {
        let absolute = largest_difference(&fast, &oracle);
        let floor = roundoff_floor(nlp, x, &fast, &oracle);
        println!(
            "{what}: sensitivities vs duals {gap:.2e} relative, {absolute:.2e} absolute; round-off floor {floor:.2e}"
        );
        assert!(
            absolute <= floor,
            "{what}: sensitivities vs duals {gap} relative, {absolute:.3e} absolute, above the round-off floor {floor:.3e}"
        );
    }
    fast
}

/// The exact (sensitivity) and dual-number Jacobian values at `x`, pattern order.
fn exact_and_oracle(nlp: &Reduced<'_>, x: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let d = nlp.dims();
    let (mut grad, mut fast, mut oracle) =
        (vec![0.0; d.n], vec![0.0; d.jac_nnz], vec![0.0; d.jac_nnz]);
    nlp.eval_derivatives(x, &mut grad, &mut fast).unwrap();
    let mut oracle_grad = vec![0.0; d.n];
    nlp.jacobian_by_parameter_duals(x, &mut oracle, &mut oracle_grad)
        .unwrap();
    (fast, oracle)
}

/// Largest entry-wise |a − b|.
fn largest_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max)
}

/// Round-off floor of the two exact Jacobians at `x` (values `fast` and `oracle` there): the
/// largest change of either when every variable is moved by a relative 1e-15 (a few ulps, three
/// seeded draws). Both methods round at every RK4 step; a motion that amplifies a perturbation of
/// the state's last digits (stiff servos near a contact switch, docs/notes/gait.md, "the servo
/// biped's derivative gap") amplifies that rounding as much, so two correct methods can differ
/// by up to this much, while a missing term of the sensitivities gives a gap orders above it.
fn roundoff_floor(nlp: &Reduced<'_>, x: &[f64], fast: &[f64], oracle: &[f64]) -> f64 {
    (0..3u64)
        .map(|s| {
            let mut rng = ChaCha8Rng::seed_from_u64(100 + s);
            let y: Vec<f64> = x
                .iter()
                .map(|v| v * (1.0 + rng.random_range(-1e-15..1e-15)))
                .collect();
            let (f2, o2) = exact_and_oracle(nlp, &y);
            largest_difference(fast, &f2).max(largest_difference(oracle, &o2))
        })
        .fold(0.0, f64::max)
}

/// Fills the segment start states of `x` from the rollout, then moves each by up to ±1e-6
/// (seeded), so the continuity rows have nonzero defects.
fn start_states_off_the_rollout(nlp: &Reduced<'_>, x: &mut [f64], seed: u64) {
    nlp.fill_states(x);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for v in &mut x[nlp.parameters()..] {
        *v += rng.random_range(-1e-6..1e-6);
    }
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

/// Segments started on the rollout of the same controls have zero continuity defects and the
/// single-shooting constraint values, exactly (the same arithmetic, step for step), and the
/// same effort to round-off.
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
        // The servo effort is summed per segment: the same terms, another summation order.
        assert!((f - f1).abs() <= 1e-12 * f1.abs(), "S = {s}: {f} vs {f1}");
        assert_eq!(c[..c1.len()], c1[..], "S = {s}");
        assert!(c[c1.len()..].iter().all(|&v| v == 0.0), "S = {s}");
    }
}

/// The multiple-shooting Jacobian agrees with the dual-number oracle and, through the shared
/// checker with Richardson extrapolation ([`fine_check_options`]), with central differences,
/// and the effort's gradient with Ridders' differences, at start states perturbed by up to 1e-6
/// off the rollout (nonzero defects). Larger moves put the stiff contact spring within the
/// difference steps: at 1e-3 one entry's extrapolated estimate was 5e-5 off while the
/// dual-number oracle agreed to 1e-9.
#[test]
fn multiple_shooting_derivatives_match_central_differences() {
    for (name, factor, segments) in [("luxo_leap", 0.2, 3), ("biped_hop", 0.05, 2)] {
        let p = shortened(name, factor);
        let nlp = Reduced::with_segments(&p, segments);
        let d = nlp.dims();
        let mut x = random_parameters(&nlp, 3);
        x.resize(d.n, 0.0);
        start_states_off_the_rollout(&nlp, &mut x, 4);
        jacobian_matching_the_oracle(&nlp, &x, name);
        let report = check_derivatives(&nlp, &x, &fine_check_options()).unwrap();
        // The effort's gradient against a step-adaptive reference (see `ridders_gradient`):
        // no one step serves its columns.
        let mut grad = vec![0.0; d.n];
        nlp.eval_derivatives(&x, &mut grad, &mut vec![0.0; d.jac_nnz])
            .unwrap();
        let worst_g = (0..d.n)
            .map(|j| (ridders_gradient(&nlp, &x, j) - grad[j]).abs() / grad[j].abs().max(1.0))
            .fold(0.0, f64::max);
        println!(
            "{name}, S = {segments}: n = {}, m = {}, max error {:.2e} (checked {}, failed {}), gradient {worst_g:.2e}",
            d.n, d.m, report.jacobian.max_error, report.jacobian.checked, report.jacobian.failed
        );
        assert_eq!(
            report.jacobian.failed, 0,
            "{name}: {:?}",
            report.worst_per_function
        );
        assert!(report.jacobian.checked >= d.jac_nnz);
        assert!(
            worst_g < crate::gait::CHECK_TOLERANCE,
            "{name}: gradient {worst_g}"
        );
    }
}

/// `--check`'s options with the characteristic scale of the functions (the distance over which
/// they change, [`crate::solver::derivatives::FiniteDifferenceOptions`]) set to 0.01 (m, rad,
/// m/s) instead of `1 + |x_j|`: the feet stand 2.3 mm deep in the contact springs and the servos
/// hold to a fraction of a degree, so the rollouts curve over millimetres and milliradians. The
/// central step is then ≈ 1e-6 instead of ≈ 1e-4 (Richardson-extrapolated from h and h/2); at
/// 1e-4 the servo biped's extrapolated differences are still truncation-limited (one continuity
/// entry off by 1.3e-3) and they converge to the exact values as the step shrinks
/// (docs/notes/gait.md, "the servo biped's derivative gap").
fn fine_check_options() -> crate::solver::derivatives::CheckOptions {
    let mut options = crate::gait::check_options();
    options.differences.characteristic_scale = Some(0.01);
    options
}

/// The Luxo leap shortened to 0.1 s with its initial state as variables, half-widths 5 mm / 0.05 rad in
/// position and 0.1 m/s / 0.1 rad/s in velocity.
fn luxo_with_free_initial_state() -> crate::gait::spec::Problem {
    let mut p = shortened("luxo_leap", 0.1);
    let init: Vec<f64> = p.initial.q.iter().chain(&p.initial.v).copied().collect();
    let nq = p.model.nq;
    let width = |i: usize| match i {
        _ if i >= nq => 0.1,
        1 => 0.005,
        _ => 0.05,
    };
    p.initial_box = Some((
        init.iter().enumerate().map(|(i, v)| v - width(i)).collect(),
        init.iter().enumerate().map(|(i, v)| v + width(i)).collect(),
    ));
    p
}

/// Motion parameters with random forces and a random initial state inside its box.
fn random_motion(nlp: &Reduced<'_>, seed: u64) -> Vec<f64> {
    let crate::solver::Bounds { xl, xu, .. } = crate::solver::Bounds::of(nlp);
    let mut x = random_parameters(nlp, seed);
    let mut rng = ChaCha8Rng::seed_from_u64(seed + 100);
    let n = x.len();
    let first = n - (nlp.problem.model.nq + nlp.problem.model.nv);
    for j in first..n {
        x[j] = rng.random_range(xl[j]..=xu[j]);
    }
    x
}

/// With the initial state as variables set to the file's initial state, the constraint values
/// are bit for bit those of the fixed-initial-state problem; the variables follow the spline
/// parameters, with the box of `initial_box`.
#[test]
fn initial_state_variables_at_the_file_state_change_nothing() {
    let free = luxo_with_free_initial_state();
    let fixed = shortened("luxo_leap", 0.1);
    let a = Reduced::new(&free);
    let b = Reduced::new(&fixed);
    let nx = free.model.nq + free.model.nv;
    assert_eq!(a.parameters(), b.parameters() + nx);
    assert_eq!(a.dims().n, b.dims().n + nx);
    assert_eq!(free.motion_parameters(), a.parameters());
    let (mut za, mut zb) = (vec![0.0; a.dims().n], vec![0.0; b.dims().n]);
    a.start(&mut za);
    b.start(&mut zb);
    assert_eq!(za[..b.parameters()], zb[..]);
    assert_eq!(free.initial_of(&za).q, free.initial.q);
    let crate::solver::Bounds { xl, xu, .. } = crate::solver::Bounds::of(&a);
    let (lo, hi) = free.initial_box.clone().unwrap();
    assert_eq!(xl[b.parameters()..], lo[..]);
    assert_eq!(xu[b.parameters()..], hi[..]);
    let (mut fa, mut ca, mut fb, mut cb) = (0.0, vec![0.0; a.dims().m], 0.0, vec![0.0; b.dims().m]);
    a.eval(&za, &mut fa, &mut ca).unwrap();
    b.eval(&zb, &mut fb, &mut cb).unwrap();
    assert_eq!((fa, ca), (fb, cb));
}

/// Segments split at given steps: the boundaries are those steps, and segments started on the
/// rollout (from a moved initial state) reproduce single shooting from that state exactly.
#[test]
fn segments_at_given_steps_reproduce_single_shooting_from_a_free_initial_state() {
    let p = luxo_with_free_initial_state();
    let single = Reduced::with_segments(&p, 1);
    let x = random_motion(&single, 6);
    let (mut f1, mut c1) = (0.0, vec![0.0; single.dims().m]);
    single.eval(&x, &mut f1, &mut c1).unwrap();
    let last = p.constraints.last().unwrap().step;
    let nlp = Reduced::with_boundaries(&p, &[0, 50, 50, 120, last, last + 7]);
    assert_eq!(nlp.boundaries(), &[0, 50, 120, last]);
    let d = nlp.dims();
    let nx = p.model.nq + p.model.nv;
    assert_eq!(d.n, nlp.parameters() + 2 * nx);
    let mut z = x.clone();
    z.resize(d.n, f64::NAN);
    nlp.fill_states(&mut z);
    let (mut f, mut c) = (0.0, vec![0.0; d.m]);
    nlp.eval(&z, &mut f, &mut c).unwrap();
    // The servo effort is summed per segment: the same terms, another summation order.
    assert!((f - f1).abs() <= 1e-12 * f1.abs(), "{f} vs {f1}");
    assert_eq!(c[..c1.len()], c1[..]);
    assert!(c[c1.len()..].iter().all(|&v| v == 0.0));
}

/// The Jacobian columns of the initial-state variables (single shooting, and segments at given
/// steps with perturbed start states) agree with the dual-number oracle and with central
/// differences. The step is 1e-7 (relative): the base-plate height column meets the
/// e^(−700·y) contact spring, where the differences converge quadratically (at y = 5 mm, one
/// entry: 1.3e-3 off at step 1e-5, 1.1e-5 at 1e-6, 1.6e-7 at 1e-7) and the shared checker's
/// larger steps were 3e-2 off.
#[test]
fn initial_state_derivatives_match_central_differences() {
    let p = luxo_with_free_initial_state();
    let last = p.constraints.last().unwrap().step;
    for interior in [vec![], vec![last / 3, 2 * last / 3]] {
        let nlp = Reduced::with_boundaries(&p, &interior);
        let d = nlp.dims();
        let mut x = random_motion(&nlp, 7);
        x.resize(d.n, 0.0);
        start_states_off_the_rollout(&nlp, &mut x, 8);
        let fast = jacobian_matching_the_oracle(&nlp, &x, &format!("{interior:?}"));
        let (mut rows, mut cols) = (vec![0; d.jac_nnz], vec![0; d.jac_nnz]);
        nlp.jacobian_structure(&mut rows, &mut cols);
        let mut dense = vec![0.0; d.m * d.n];
        for k in 0..d.jac_nnz {
            dense[rows[k] * d.n + cols[k]] = fast[k];
        }
        let first = nlp.parameters() - p.model.nq - p.model.nv;
        assert!((first..nlp.parameters()).any(|j| (0..d.m).any(|r| dense[r * d.n + j] != 0.0)));
        let mut worst: f64 = 0.0;
        for j in 0..d.n {
            let h = 1e-7 * x[j].abs().max(1.0);
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[j] += h;
            xm[j] -= h;
            let (mut f, mut cp, mut cm) = (0.0, vec![0.0; d.m], vec![0.0; d.m]);
            nlp.eval(&xp, &mut f, &mut cp).unwrap();
            nlp.eval(&xm, &mut f, &mut cm).unwrap();
            for r in 0..d.m {
                let fd = (cp[r] - cm[r]) / (2.0 * h);
                let exact = dense[r * d.n + j];
                worst = worst.max((fd - exact).abs() / exact.abs().max(1.0));
            }
        }
        println!(
            "luxo 0.1 s, initial state free, boundaries {:?}: n = {}, m = {}, max relative |exact − central| = {worst:.2e}",
            nlp.boundaries(),
            d.n,
            d.m
        );
        assert!(worst < 1e-5, "{interior:?}: {worst}");
    }
}

/// With servo actuators (the shipped Luxo) the effort is integrated along the rollout: its
/// gradient from the forward sensitivities equals the dual-number oracle's, and both the
/// gradient and the Jacobian match central differences, for one and for three segments
/// (start-state columns included).
#[test]
fn servo_effort_gradient_matches_the_oracle_and_central_differences() {
    let p = shortened("luxo_leap", 0.2);
    assert!(p.model.has_servos());
    for segments in [1, 3] {
        let nlp = Reduced::with_segments(&p, segments);
        let d = nlp.dims();
        let mut x = vec![0.0; d.n];
        x[..nlp.parameters()].copy_from_slice(&random_parameters(&nlp, 5));
        nlp.fill_states(&mut x);
        let (mut grad, mut jac) = (vec![0.0; d.n], vec![0.0; d.jac_nnz]);
        nlp.eval_derivatives(&x, &mut grad, &mut jac).unwrap();
        let (mut oracle_grad, mut oracle) = (vec![0.0; d.n], vec![0.0; d.jac_nnz]);
        nlp.jacobian_by_parameter_duals(&x, &mut oracle, &mut oracle_grad)
            .unwrap();
        let gap = gap_to_oracle(&grad, &oracle_grad);
        assert!(gap < 1e-9, "{segments} segments: gradient vs duals {gap}");
        assert!(gap_to_oracle(&jac, &oracle) < 1e-9, "{segments} segments");
        assert!(grad.iter().any(|g| g.abs() > 1e-3), "a zero gradient");
        let (mut f, mut c) = (0.0, vec![0.0; d.m]);
        nlp.eval(&x, &mut f, &mut c).unwrap();
        let mut worst: f64 = 0.0;
        for (j, g) in grad.iter().enumerate() {
            let (fd, _) = central_difference(&nlp, &x, j);
            worst = worst.max((fd - g).abs() / g.abs().max(1.0));
        }
        println!("{segments} segments: effort {f:.4} N²·s, gradient vs central {worst:.2e}");
        assert!(
            worst < 1e-6,
            "{segments} segments: gradient vs central {worst}"
        );
    }
}
