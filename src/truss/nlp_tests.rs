//! Tests of the truss NLP: hand-solvable trusses in force balance at their analytic forces, and
//! every derivative block against central differences.

use std::collections::BTreeSet;

use super::ground;
use super::mass::MassModel;
use super::model::{
    Beam, Joint, JointKind, Mirror, Objective, Obstacle, Settings, Structure, Support, Vec3,
};
use super::nlp::TrussNlp;
use super::testing::{assert_derivatives, test_settings};
use crate::solver::Nlp;

fn joint(p: [f64; 3], kind: JointKind, loads: Vec<Vec3>) -> Joint {
    Joint {
        position: Vec3::from(p),
        kind,
        name: None,
        loads,
    }
}

fn pinned() -> JointKind {
    JointKind::Anchor(Support::Pinned)
}

/// Scaled x from forces (N) for the structure's start positions.
fn point(nlp: &TrussNlp, forces: &[f64]) -> Vec<f64> {
    let mut x = vec![0.0; nlp.dims().n];
    nlp.start(&mut x);
    for (v, f) in forces.iter().enumerate() {
        x[2 * v] = (-f).max(0.0) / nlp.force_scale();
        x[2 * v + 1] = f.max(0.0) / nlp.force_scale();
    }
    x
}

#[test]
fn the_force_parts_given_are_the_parts_reported() {
    use super::nlp::ForceParts;
    let s = Structure {
        joints: vec![
            joint([-3.0, 0.0, 0.0], pinned(), vec![Vec3::zeros()]),
            joint([3.0, 0.0, 0.0], pinned(), vec![Vec3::zeros()]),
            joint([0.0, 4.0, 0.0], JointKind::Free, vec![Vec3::zeros()]),
            joint([0.0, -4.0, 0.0], JointKind::Free, vec![Vec3::zeros()]),
        ],
        beams: vec![Beam::new(0, 2), Beam::new(1, 2), Beam::new(0, 3)],
    };
    let parts = vec![
        ForceParts::Compression,
        ForceParts::Both,
        ForceParts::Tension,
    ];
    let nlp =
        TrussNlp::with_parts(s, test_settings(1), vec![1.0, 0.0, -1.0], parts.clone()).unwrap();
    assert_eq!(nlp.parts(), parts);
    // One variable per signed part, two for the free sign, then the free joints' coordinates.
    assert_eq!(nlp.dims().n, 4 + 2 * 3);
}

#[test]
fn two_bar_truss_balances_at_its_analytic_forces() {
    // Anchors at (±3, 0), load P down at (0, 4): each bar carries P·5/(2·4) in compression.
    let p = 1e5;
    let s = Structure {
        joints: vec![
            joint([-3.0, 0.0, 0.0], pinned(), vec![Vec3::zeros()]),
            joint([3.0, 0.0, 0.0], pinned(), vec![Vec3::zeros()]),
            joint(
                [0.0, 4.0, 0.0],
                JointKind::Load,
                vec![Vec3::new(0.0, -p, 0.0)],
            ),
        ],
        beams: vec![Beam::new(0, 2), Beam::new(1, 2)],
    };
    let mut set = test_settings(1);
    set.planar = true;
    let nlp = TrussNlp::new(s, set, vec![0.0; 2]).unwrap();
    assert_eq!(nlp.dims().m, 2, "planar load joint: x and y balance only");
    let lambda = p * 5.0 / 8.0;
    let x = point(&nlp, &[lambda, lambda]);
    assert!(nlp.max_balance_residual(&x).unwrap() < 1e-9 * p);
    // Wrong sign (tension) does not balance.
    let x = point(&nlp, &[-lambda, -lambda]);
    assert!(nlp.max_balance_residual(&x).unwrap() > p);
}

#[test]
fn roller_support_needs_a_tie() {
    // Pinned A (0,0), roller B (2,0) free along x, load P at (1,1): legs P/√2 in compression,
    // tie A–B P/2 in tension.
    let p = 2e4;
    let s = Structure {
        joints: vec![
            joint([0.0, 0.0, 0.0], pinned(), vec![Vec3::zeros()]),
            joint(
                [2.0, 0.0, 0.0],
                JointKind::Anchor(Support::Roller(vec![Vec3::y()])),
                vec![Vec3::zeros()],
            ),
            joint(
                [1.0, 1.0, 0.0],
                JointKind::Load,
                vec![Vec3::new(0.0, -p, 0.0)],
            ),
        ],
        beams: vec![Beam::new(0, 2), Beam::new(1, 2), Beam::new(0, 1)],
    };
    let mut set = test_settings(1);
    set.planar = true;
    let nlp = TrussNlp::new(s, set, vec![0.0; 3]).unwrap();
    // Load: x, y; roller: x only.
    assert_eq!(nlp.dims().m, 3);
    let leg = p / 2f64.sqrt();
    let x = point(&nlp, &[leg, leg, -p / 2.0]);
    assert!(nlp.max_balance_residual(&x).unwrap() < 1e-9 * p);
    let x = point(&nlp, &[leg, leg, 0.0]);
    let r = nlp.max_balance_residual(&x).unwrap();
    assert!((r - p / 2.0).abs() < 1e-6 * p, "untied roller residual {r}");
}

#[test]
fn tripod_balances_with_and_without_self_weight_accounting() {
    // Three anchors on a circle of radius 2 at y = 0, load P at (0, 3, 0): each leg carries
    // P·L/(3h) in compression, L = √13, h = 3.
    let p = 5e4;
    let mut joints: Vec<Joint> = (0..3)
        .map(|k| {
            let t = 2.0 * std::f64::consts::PI * f64::from(k) / 3.0;
            joint(
                [2.0 * t.cos(), 0.0, 2.0 * t.sin()],
                pinned(),
                vec![Vec3::zeros()],
            )
        })
        .collect();
    joints.push(joint(
        [0.0, 3.0, 0.0],
        JointKind::Load,
        vec![Vec3::new(0.0, -p, 0.0)],
    ));
    let s = Structure {
        joints,
        beams: (0..3).map(|k| Beam::new(k, 3)).collect(),
    };
    let leg = p * 13f64.sqrt() / 9.0;
    let nlp = TrussNlp::new(s.clone(), test_settings(1), vec![0.0; 3]).unwrap();
    let x = point(&nlp, &[leg; 3]);
    assert!(nlp.max_balance_residual(&x).unwrap() < 1e-9 * p);
    // With self-weight the apex carries half of each leg's mass too; the analytic leg force
    // then solves λ·3h/L = P + (3/2)·g·m(λ, L): check the fixed point by iteration.
    let mut set = test_settings(1);
    set.self_weight = true;
    let nlp = TrussNlp::new(s, set.clone(), vec![0.0; 3]).unwrap();
    let len = 13f64.sqrt();
    let mut lambda = leg;
    for _ in 0..50 {
        let weight = 1.5 * super::mass::STANDARD_GRAVITY * set.mass.mass(lambda, len);
        lambda = (p + weight) * len / 9.0;
    }
    assert!(lambda > leg);
    let x = point(&nlp, &[lambda; 3]);
    assert!(nlp.max_balance_residual(&x).unwrap() < 1e-8 * p);
}

/// A 3-D test structure exercising every feature: rollers, free joints, several cases.
fn rich_structure(cases: usize) -> Structure {
    let mut joints = vec![
        joint([0.0, 0.0, 0.0], pinned(), vec![Vec3::zeros(); cases]),
        joint(
            [12.0, 0.0, 0.0],
            JointKind::Anchor(Support::Roller(vec![Vec3::y()])),
            vec![Vec3::zeros(); cases],
        ),
        joint([0.0, 0.0, 4.0], pinned(), vec![Vec3::zeros(); cases]),
        joint(
            [12.0, 0.0, 4.0],
            JointKind::Anchor(Support::Roller(vec![Vec3::y(), Vec3::z()])),
            vec![Vec3::zeros(); cases],
        ),
    ];
    for (k, x) in [4.0, 8.0].into_iter().enumerate() {
        for z in [0.0, 4.0] {
            let loads = (0..cases)
                .map(|c| Vec3::new(1e3 * c as f64, -1e5 * (1.0 + 0.3 * (k + c) as f64), 2e3))
                .collect();
            joints.push(joint([x, 0.0, z], JointKind::Load, loads));
        }
    }
    let free = [
        [2.1, 3.2, 0.3],
        [6.2, 3.9, -0.2],
        [9.8, 3.1, 0.4],
        [2.0, 2.8, 3.7],
        [5.9, 4.2, 4.3],
        [10.1, 3.3, 3.9],
        [6.0, -2.5, 2.1],
    ];
    for p in free {
        joints.push(joint(p, JointKind::Free, vec![Vec3::zeros(); cases]));
    }
    let beams = ground::connect(&joints, 6, &BTreeSet::new(), &[], &[], 1e-9);
    Structure { joints, beams }
}

fn check(structure: Structure, set: Settings, seed: u64, what: &str) {
    let forces = TrussNlp::random_start_forces(&structure, set.load_cases.len(), seed);
    let nlp = TrussNlp::new(structure, set, forces).unwrap();
    let mut x = vec![0.0; nlp.dims().n];
    nlp.start(&mut x);
    assert_derivatives(&nlp, &x, seed, 2e-6, what);
}

#[test]
fn derivatives_single_case_with_self_weight() {
    let mut set = test_settings(1);
    set.self_weight = true;
    set.max_length = Some(9.0);
    check(rich_structure(1), set, 1, "self-weight");
}

#[test]
fn derivatives_of_every_objective() {
    for objective in [
        Objective::Mass,
        Objective::Length,
        Objective::MassTensionPreference(3.0),
    ] {
        let mut set = test_settings(1);
        set.self_weight = true;
        set.objective = objective;
        check(rich_structure(1), set, 2, &format!("{objective:?}"));
    }
    let mut set = test_settings(1);
    set.mass = MassModel::linear(250e6, 120e6, 7850.0);
    set.self_weight = true;
    check(rich_structure(1), set, 3, "linear mass");
}

#[test]
fn derivatives_with_several_load_cases() {
    let mut set = test_settings(3);
    set.self_weight = true;
    check(rich_structure(3), set.clone(), 4, "three cases, mass");
    set.objective = Objective::Length;
    check(rich_structure(3), set, 5, "three cases, length");
}

#[test]
fn derivatives_with_obstacles_symmetry_and_held_planes() {
    let mut set = test_settings(1);
    set.self_weight = true;
    set.obstacles = vec![
        Obstacle::Sphere {
            center: Vec3::new(6.0, 1.5, 2.0),
            radius: 1.0,
        },
        Obstacle::HalfSpace {
            point: Vec3::new(0.0, -3.0, 0.0),
            normal: Vec3::new(0.1, 1.0, 0.0).normalize(),
        },
    ];
    set.held_axis = Some(2);
    check(rich_structure(1), set.clone(), 6, "obstacles, held z");

    // A mirror-symmetric structure about x = 6.
    let mut s = rich_structure(1);
    s.joints.truncate(8);
    for p in [
        [2.5, 3.0, 0.5],
        [9.5, 3.0, 0.5],
        [6.0, 3.5, 2.0],
        [6.0, -2.0, 2.0],
    ] {
        s.joints
            .push(joint(p, JointKind::Free, vec![Vec3::zeros()]));
    }
    s.beams = ground::connect(&s.joints, 6, &BTreeSet::new(), &[], &[], 1e-9);
    set.held_axis = None;
    set.obstacles.clear();
    set.symmetry = vec![Mirror {
        point: Vec3::new(6.0, 0.0, 0.0),
        normal: Vec3::x(),
    }];
    let forces = TrussNlp::random_start_forces(&s, 1, 7);
    let nlp = TrussNlp::new(s, set, forces).unwrap();
    // 1 pair × 3 axes + 2 on-plane joints.
    let names: Vec<String> = (0..nlp.dims().m).map(|r| nlp.constraint_name(r)).collect();
    assert_eq!(names.iter().filter(|n| n.contains("mirrors")).count(), 3);
    assert_eq!(
        names
            .iter()
            .filter(|n| n.contains("on symmetry plane"))
            .count(),
        2
    );
    let mut x = vec![0.0; nlp.dims().n];
    nlp.start(&mut x);
    let (mut f, mut c) = (0.0, vec![0.0; nlp.dims().m]);
    nlp.eval(&x, &mut f, &mut c).unwrap();
    for (r, name) in names.iter().enumerate() {
        if name.contains("mirror") || name.contains("symmetry") {
            assert!(c[r].abs() < 1e-12, "{name}: {}", c[r]);
        }
    }
    assert_derivatives(&nlp, &x, 7, 2e-6, "symmetry");
}

#[test]
fn derivatives_in_degenerate_geometry() {
    // Near-zero forces (inside the blend), a beam at minimum length and nearly collinear beams.
    let mut s = rich_structure(1);
    let n = s.joints.len();
    s.joints.push(joint(
        [6.21, 3.93, -0.19],
        JointKind::Free,
        vec![Vec3::zeros()],
    ));
    s.joints.push(joint(
        [4.0, 1e-3, 2.0],
        JointKind::Free,
        vec![Vec3::zeros()],
    ));
    s.beams.push(Beam::new(9, n));
    s.beams.push(Beam::new(4, n + 1));
    s.beams.push(Beam::new(n + 1, 5));
    s.beams.push(Beam::new(n, n + 1));
    let mut set = test_settings(1);
    set.self_weight = true;
    set.obstacles = vec![Obstacle::Sphere {
        center: Vec3::new(6.2, 3.0, -0.2),
        radius: 0.5,
    }];
    let forces: Vec<f64> = (0..s.beams.len())
        .map(|j| (j as f64 - 20.0) * 3.0)
        .collect();
    let nlp = TrussNlp::new(s, set, forces).unwrap();
    let mut x = vec![0.0; nlp.dims().n];
    nlp.start(&mut x);
    assert_derivatives(&nlp, &x, 8, 2e-6, "degenerate");
}

#[test]
fn planar_problems_have_two_coordinates_per_free_joint() {
    let mut s = rich_structure(1);
    for j in &mut s.joints {
        j.position.z = 0.0;
        for f in &mut j.loads {
            f.z = 0.0;
        }
    }
    // Remove joints that now coincide and rebuild beams.
    s.joints.retain(|j| j.is_free() || j.position.z == 0.0);
    let mut unique: Vec<Joint> = Vec::new();
    for j in s.joints {
        if unique
            .iter()
            .all(|u| (u.position - j.position).norm() > 1e-9)
        {
            unique.push(j);
        }
    }
    s.joints = unique;
    s.beams = ground::connect(&s.joints, 6, &BTreeSet::new(), &[], &[], 1e-9);
    let mut set = test_settings(1);
    set.planar = true;
    set.self_weight = true;
    let free = s.free_count();
    let beams = s.beams.len();
    let forces = TrussNlp::random_start_forces(&s, 1, 9);
    let nlp = TrussNlp::new(s, set, forces).unwrap();
    assert_eq!(nlp.dims().n, 2 * beams + 2 * free);
    let mut x = vec![0.0; nlp.dims().n];
    nlp.start(&mut x);
    assert_derivatives(&nlp, &x, 9, 2e-6, "planar");
}

#[test]
fn zero_length_beams_are_domain_errors() {
    let s = rich_structure(1);
    let nlp = TrussNlp::new(s.clone(), test_settings(1), vec![0.0; s.beams.len()]).unwrap();
    let mut x = vec![0.0; nlp.dims().n];
    nlp.start(&mut x);
    // Move the first free joint onto a neighbour.
    let b = s
        .beams
        .iter()
        .find(|b| s.joints[b.ends[1]].is_free())
        .unwrap();
    let target = s.joints[b.ends[0]].position;
    let free_index = s.joints[..b.ends[1]].iter().filter(|j| j.is_free()).count();
    let base = 2 * s.beams.len() + 3 * free_index;
    let scaled = target / nlp.length_scale();
    x[base..base + 3].copy_from_slice(scaled.as_slice());
    let (mut f, mut c) = (0.0, vec![0.0; nlp.dims().m]);
    assert!(matches!(
        nlp.eval(&x, &mut f, &mut c),
        Err(crate::solver::EvalError::Domain(_))
    ));
    x[0] = f64::NAN;
    assert!(nlp.eval(&x, &mut f, &mut c).is_err());
}
