//! End-to-end solves of the `linear` mass option against certified references: the plastic
//! layout LP of the same ground structure (solved by our own simplex, `super::lp`) and Michell's
//! closed forms. Whole examples are run by the golden tests and the benchmarks.

use super::design::Design;
use super::mass::MassModel;
use super::model::{JointKind, Structure, Support, Vec3};
use super::nlp::TrussNlp;
use super::plastic;
use super::start;
use crate::solver::qp::QpMethod;
use crate::solver::{Interrupt, Nlp, Options};

/// The half-wheel ground structure of plastic.rs's LP test (simple supports at (±1, 0), P = 1 N
/// down at the origin, nodes on a grid of step `h` in y ≥ 0, all pairs connected).
fn half_wheel(h: f64) -> Structure {
    let n = (1.0 / h).round() as usize;
    let mut joints = Vec::new();
    for i in 0..=2 * n {
        for k in 0..=n {
            let q = Vec3::new(-1.0 + i as f64 * h, k as f64 * h, 0.0);
            let (kind, load) = if k == 0 && i == 0 {
                (JointKind::Anchor(Support::Pinned), Vec3::zeros())
            } else if k == 0 && i == 2 * n {
                (
                    JointKind::Anchor(Support::Roller(vec![Vec3::y()])),
                    Vec3::zeros(),
                )
            } else if k == 0 && i == n {
                (JointKind::Load, Vec3::new(0.0, -1.0, 0.0))
            } else {
                (JointKind::Free, Vec3::zeros())
            };
            joints.push(super::model::Joint {
                position: q,
                kind,
                name: None,
                loads: vec![load],
            });
        }
    }
    let beams = super::ground::connect(&joints, joints.len(), &Default::default(), &[], &[], 1e-9);
    Structure { joints, beams }
}

/// The sparse interior-point QP: at fixed geometry with linear mass the first QP subproblem is
/// the layout LP itself, which it solves to optimality.
fn quiet() -> Options {
    Options {
        verbosity: 0,
        max_iterations: 300,
        qp_method: QpMethod::Sparse,
        ..Options::default()
    }
}

fn linear_settings(move_joints: bool) -> super::model::Settings {
    super::model::Settings {
        // σ = 1 Pa and ρ = 1 kg/m³: mass in kg equals volume in m³. The blend width must be
        // small: below it the smoothed |λ| is quadratic, and spreading a force over many idle
        // bars becomes artificially cheap (at ε = 1e-3 P the sizing solve ends 1.2% below the LP).
        mass: MassModel::linear(1.0, 1.0, 1.0),
        objective: super::model::Objective::Mass,
        self_weight: false,
        max_force: 10.0,
        min_length: 0.01,
        max_length: None,
        planar: true,
        held_axis: None,
        move_joints,
        symmetry: Vec::new(),
        obstacles: Vec::new(),
        load_cases: vec!["main".into()],
    }
}

#[test]
fn linear_sizing_equals_the_plastic_lp_and_geometry_improves_on_it() {
    let s = half_wheel(0.25);
    let lp = plastic::layout(&s, 0, true, 1.0, 1.0).unwrap();
    // Sizing at fixed geometry from zero forces: the SQP must find the LP optimum itself.
    let zero = vec![0.0; s.beams.len()];
    let sizing = TrussNlp::new(s.clone(), linear_settings(false), zero).unwrap();
    let sol = crate::solver::solve(&sizing, &quiet());
    assert!(sol.status.is_success(), "{:?}", sol.status);
    let sized = sol.objective * sizing.mass_scale();
    assert!(
        (sized - lp.volume).abs() <= 5e-3 * lp.volume,
        "sizing {sized} vs LP {}",
        lp.volume
    );
    // Geometry from the staged start: the layout LP's members with their LP forces and signs.
    let staged = start::layout_start(&s, &linear_settings(true), None, &Interrupt::new()).unwrap();
    assert!((staged.lp.cost[0] - lp.volume).abs() <= 1e-6 * lp.volume);
    let geometry = TrussNlp::with_parts(
        staged.structure,
        linear_settings(true),
        staged.forces,
        staged.parts,
    )
    .unwrap();
    let sol = crate::solver::solve(&geometry, &quiet());
    assert!(sol.status.is_success(), "{:?}", sol.status);
    let volume = sol.objective * geometry.mass_scale();
    assert!(
        volume <= lp.volume * (1.0 + 1e-6),
        "{volume} vs {}",
        lp.volume
    );
    let exact = plastic::michell_half_wheel_volume(1.0, 1.0, 1.0);
    println!(
        "half-wheel h = 0.25: sizing {sized} LP {} geometry {volume} Michell {exact}",
        lp.volume
    );
}

#[test]
fn design_from_a_solve_reports_consistent_figures() {
    let s = half_wheel(0.5);
    let staged = start::layout_start(&s, &linear_settings(true), None, &Interrupt::new()).unwrap();
    let nlp = TrussNlp::with_parts(
        staged.structure,
        linear_settings(true),
        staged.forces,
        staged.parts,
    )
    .unwrap();
    let sol = crate::solver::solve(&nlp, &quiet());
    assert!(sol.status.is_success(), "{:?}", sol.status);
    let design = Design::from_point(&nlp, &sol.x);
    let fig = design.figures(nlp.settings());
    assert!(fig.max_balance_residual_relative < 1e-6);
    assert!(nlp.dims().n > 0);
}
