//! Tests of the collocation formulation: Hermite basis and every constant derivative against
//! central differences, the knot grid, input errors, and the physics of a solved ball (closed-
//! form free fall, impulse balance, RK4 re-simulation, wall clearance).

use std::path::PathBuf;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::nlp::Phase;
use super::*;
use crate::solver::{Options, Status};

fn ball_source() -> Source {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/gait/ball.toml");
    Source::read(&path).expect("ball.toml is readable")
}

fn ball() -> Problem {
    load_source(&ball_source()).expect("ball.toml loads")
}

#[test]
fn the_shipped_file_selects_collocation() {
    assert!(spec::selects_collocation(&ball_source()));
    let other = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/gait/pogo_jump.toml");
    assert!(!spec::selects_collocation(&Source::read(&other).unwrap()));
}

#[test]
fn hermite_basis_derivatives_match_central_differences() {
    let p = ball();
    let l = Layout::new(&p);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let x: Vec<f64> = (0..l.n).map(|_| rng.random_range(-2.0..2.0)).collect();
    for s in [0, 5, l.segments() - 1] {
        let (t0, t1) = (l.times[s], l.times[s + 1]);
        for tau in [0.1, 0.5, 0.9] {
            let t = t0 + tau * (t1 - t0);
            let h = 1e-5 * (t1 - t0);
            for axis in 0..2 {
                for order in 0..2 {
                    let fd = (l.eval(&x, axis, order, t + h) - l.eval(&x, axis, order, t - h))
                        / (2.0 * h);
                    let exact = l.eval(&x, axis, order + 1, t);
                    assert!(
                        (fd - exact).abs() < 1e-6 * exact.abs().max(1.0),
                        "segment {s}, τ {tau}, order {order}: {fd} vs {exact}"
                    );
                }
            }
        }
    }
    // Interpolation: the spline passes through the knot values and slopes.
    let i = 7;
    for axis in 0..2 {
        let t = l.times[i];
        assert!((l.eval(&x, axis, 0, t) - x[l.var(i, axis, false)]).abs() < 1e-12);
        assert!((l.eval(&x, axis, 1, t) - x[l.var(i, axis, true)]).abs() < 1e-12);
    }
}

#[test]
fn exact_derivatives_match_central_differences() {
    let p = ball();
    let nlp = Collocation::new(&p);
    let d = nlp.dims();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let x: Vec<f64> = (0..d.n).map(|_| rng.random_range(-5.0..5.0)).collect();
    let report = crate::solver::derivatives::check_derivatives(&nlp, &x, &check_options()).unwrap();
    assert!(report.passed(), "{report}");
    assert!(report.hessian.is_some(), "the Hessian is checked too");
    assert!(report.jacobian.checked > 0 && report.gradient.checked > 0);
    // The gradient is not trivially zero at a random point.
    let (mut g, mut j) = (vec![0.0; d.n], vec![0.0; d.jac_nnz]);
    nlp.eval_derivatives(&x, &mut g, &mut j).unwrap();
    assert!(g.iter().any(|v| v.abs() > 1e-3));
}

#[test]
fn knots_sit_on_frames_and_contact_times() {
    let p = ball();
    let l = Layout::new(&p);
    let (a, b) = p.contacts[0];
    let at = |t: f64| l.times.iter().position(|&s| s == t).expect("a knot");
    assert_eq!(l.contact[at(a)], Phase::TouchDown);
    assert_eq!(l.contact[at(b)], Phase::TakeOff);
    assert_eq!(l.times[0], 0.0);
    assert_eq!(*l.times.last().unwrap(), p.duration);
    // 0.65 s is within a tenth of a frame of no frame (0.6333, 0.6667): both are inserted
    // knots, so 61 frames + 2 contact times.
    assert_eq!(l.times.len(), 63);
    assert!(
        l.times
            .windows(2)
            .all(|w| w[1] - w[0] > 0.1 / p.fps - 1e-12)
    );
    let forces = l.force.iter().filter(|f| f.is_some()).count();
    assert_eq!(
        forces,
        l.contact.iter().filter(|&&c| c == Phase::Contact).count()
    );
    assert_eq!(l.n, 4 * l.times.len() + 2 * forces);
}

#[test]
fn bad_input_is_an_error_at_the_key() {
    let base = ball_source();
    let cases = [
        ("axis = \"x\"", "axis = \"z\"", "`axis`"),
        ("mass = 1.0", "mass = -1.0", "`mass`"),
        ("end = 0.65", "end = 0.46", "two frames"),
        ("fps = 30", "fps = 0", "`fps`"),
    ];
    for (from, to, expect) in cases {
        assert!(base.text.contains(from), "{from}");
        let source = Source {
            path: base.path.clone(),
            text: base.text.replacen(from, to, 1),
        };
        let e = load_source(&source).expect_err(to).to_string();
        assert!(e.contains(expect), "{to}: {e}");
    }
}

/// Solves the shipped ball and checks the motion against physics the optimizer never saw.
#[test]
fn the_solved_ball_is_physically_valid() {
    let p = ball();
    let nlp = Collocation::new(&p);
    let options = Options {
        verbosity: 0,
        ..p.solver.clone()
    };
    let sol = solve(&nlp, &options);
    assert_eq!(sol.status, Status::Optimal, "{:?}", sol.status);
    let l = &nlp.layout;
    let x = &sol.x;
    // Free fall from rest at 1 m: y(t) = 1 + g t²/2 before touch-down, exactly.
    for (i, &t) in l.times.iter().enumerate() {
        if t <= p.contacts[0].0 {
            let y = x[l.var(i, 1, false)];
            assert!(
                (y - (1.0 + 0.5 * p.gravity * t * t)).abs() < 1e-7,
                "t = {t}: y = {y}"
            );
            assert!((x[l.var(i, 0, false)] + 2.0).abs() < 1e-7);
        }
    }
    // Flight after take-off is ballistic: constant horizontal velocity.
    let take_off = p.contacts[0].1;
    let vx: Vec<f64> = (0..l.times.len())
        .filter(|&i| l.times[i] >= take_off)
        .map(|i| x[l.var(i, 0, true)])
        .collect();
    assert!(vx.iter().all(|v| (v - vx[0]).abs() < 1e-6), "{vx:?}");
    let v = validate(&p, l, x);
    assert!(v.newton_residual < 1e-5, "{v:?}");
    assert!(v.resimulation_gap < 1e-5, "{v:?}");
    assert!(v.impulse_gap < 1e-6, "{v:?}");
    assert!(v.lowest_flight > -1e-6, "{v:?}");
    assert!(v.least_normal_force >= -1e-9, "{v:?}");
    assert!(v.friction_ratio <= p.friction.unwrap() + 1e-6, "{v:?}");
    let clearance = v.wall_clearance.expect("the ball crosses the wall");
    assert!(clearance > 0.0, "{v:?}");
    // The wall is crossed on the take-off parabola: closed form from the take-off state.
    let i0 = l.times.iter().position(|&t| t == take_off).unwrap();
    let (x0, vx0, vy0) = (
        x[l.var(i0, 0, false)],
        x[l.var(i0, 0, true)],
        x[l.var(i0, 1, true)],
    );
    let tc = (p.wall.unwrap().x - x0) / vx0;
    let y_cross = vy0 * tc + 0.5 * p.gravity * tc * tc;
    assert!((y_cross - p.wall.unwrap().height - clearance).abs() < 1e-6);
}
