//! Solved CMC problems against closed forms: the isoperimetric sphere, the catenoid, the
//! standard double bubble (area, 120° junctions, and the cluster identity
//! area = 1.5·Σ pressure·volume with pressure = 2H for unit tension) and the flat tetrahedral
//! film on the octahedral frame (area 2√2·edge²). Run with `--release`.
//!
//! Junction angles of bubble clusters are measured on the films' own shapes: every film of the
//! standard double and triple bubble is a piece of a sphere (or plane), so each surface's
//! vertices are fitted by one (algebraic least squares `a|p|² + b·p + d = 0`, the smallest
//! right singular vector); at each junction vertex where exactly three films meet, the film
//! directions leaving the junction are the fitted tangent planes' conormals `n × t` (t along
//! the junction through the two neighbouring junction vertices, sign towards the film's own
//! neighbours), and the angles between them are compared with 120°. The fits' largest
//! distance from a vertex is reported and bounded, so the spherical assumption is checked too.
//! (`figures::junction_angles`, which sees only the triangles next to each junction edge,
//! reads 118.4°–121.3° on the exact r8 double bubble start: too coarse to show convergence.)

use std::path::PathBuf;

use super::area::total_area;
use super::catenoid::exact_catenoid;
use super::generators::icosphere;
use super::generators::standard_double_bubble;
use super::mesh::{Mesh, Point};
use super::nlp::{CmcNlp, Formulation, VolumeConstraint};
use super::volume::Region;
use super::{Problem, load, run};
use crate::outcome::{Outcome, RunOptions};
use crate::solver::Options;
use nalgebra::{DMatrix, Vector3};

fn from_text(text: &str, tag: &str) -> Problem {
    let dir = std::env::temp_dir().join(format!("cmc-truth-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join(format!("{tag}.toml"));
    std::fs::write(&file, text).unwrap();
    let problem = load(&file).unwrap();
    let _ = std::fs::remove_file(&file);
    problem
}

fn solve(problem: &Problem) -> Outcome {
    let outcome = run(
        problem,
        &RunOptions {
            quiet: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(
        outcome.status.unwrap().is_success(),
        "{}: {}",
        problem.name(),
        outcome.summary.status_message
    );
    outcome
}

fn area(outcome: &Outcome) -> f64 {
    outcome.summary.figures["total_area"].as_f64().unwrap()
}

/// The solved mesh, read back from the run's `model.glb` (f32 positions, welded on import).
fn solved_mesh(outcome: &Outcome) -> Mesh {
    let glb = outcome
        .artifacts
        .iter()
        .find(|a| a.name == "model.glb")
        .unwrap();
    super::import_gltf::read_gltf_bytes(&glb.bytes).unwrap()
}

/// Sphere-fit junction angles, see the module header: (largest |angle − 120°| in degrees,
/// largest fit distance relative to the cluster's size, junction vertices measured).
fn sphere_fit_junction_deviation(mesh: &Mesh) -> (f64, f64, usize) {
    let pos = mesh.positions();
    let centre = pos.iter().sum::<Point>() / pos.len() as f64;
    let size = pos.iter().map(|p| (p - centre).norm()).fold(0.0, f64::max);
    let local = |p: &Point| (p - centre) / size;
    let mut worst_fit: f64 = 0.0;
    // Per surface: the quadric (a, b, d) and its unit normal at a point (local coordinates).
    let fits: Vec<(f64, Vector3<f64>, f64)> = (0..mesh.surfaces().len())
        .map(|s| {
            let mut verts: Vec<usize> = mesh
                .surface_triangles(s)
                .flat_map(|t| mesh.triangles()[t])
                .collect();
            verts.sort_unstable();
            verts.dedup();
            let rows = DMatrix::from_fn(verts.len(), 5, |r, c| {
                let p = local(&pos[verts[r]]);
                match c {
                    0 => p.norm_squared(),
                    1..=3 => p[c - 1],
                    _ => 1.0,
                }
            });
            let svd = rows.svd(false, true);
            let v_t = svd.v_t.unwrap();
            let k = svd.singular_values.imin();
            let q = v_t.row(k);
            let (a, b, d) = (q[0], Vector3::new(q[1], q[2], q[3]), q[4]);
            for &v in &verts {
                let p = local(&pos[v]);
                let distance =
                    (a * p.norm_squared() + b.dot(&p) + d).abs() / (2.0 * a * p + b).norm();
                worst_fit = worst_fit.max(distance);
            }
            (a, b, d)
        })
        .collect();
    let junction = |v: usize| mesh.vertex_surfaces(v).len() >= 3;
    let mut worst: f64 = 0.0;
    let mut count = 0;
    for v in 0..pos.len() {
        let films = mesh.vertex_surfaces(v);
        let along: Vec<usize> = mesh
            .neighbours(v)
            .iter()
            .copied()
            .filter(|&u| junction(u) && mesh.vertex_surfaces(u) == films)
            .collect();
        if films.len() != 3 || along.len() != 2 {
            continue;
        }
        let t = (pos[along[1]] - pos[along[0]]).normalize();
        let p = local(&pos[v]);
        let conormals: Vec<Point> = films
            .iter()
            .map(|&s| {
                let (a, b, _) = fits[s];
                let n = (2.0 * a * p + b).normalize();
                let nu = n.cross(&t).normalize();
                // Towards the film: the mean of v's neighbours in surface s.
                let own: Point = mesh
                    .vertex_triangles(v)
                    .iter()
                    .filter(|&&tri| mesh.triangle_surface()[tri] == s)
                    .flat_map(|&tri| mesh.triangles()[tri])
                    .map(|u| pos[u] - pos[v])
                    .sum();
                if own.dot(&nu) >= 0.0 { nu } else { -nu }
            })
            .collect();
        for i in 0..3 {
            let angle = conormals[i].angle(&conormals[(i + 1) % 3]).to_degrees();
            worst = worst.max((angle - 120.0).abs());
        }
        count += 1;
    }
    (worst, worst_fit, count)
}

/// Error ratios of successive levels (4 for second order when the edges halve).
fn rates(errors: &[f64]) -> Vec<f64> {
    errors.windows(2).map(|w| w[0] / w[1]).collect()
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn sphere_area_converges_at_second_order() {
    // V = 1: area (36π)^(1/3) = 4.835975862; icosphere levels 0, 1, 2 halve the edges.
    // (Level 3, 642 vertices, takes minutes with the dense QP: docs/notes/cmc.md.)
    let exact = (36.0 * std::f64::consts::PI).cbrt();
    let errors: Vec<f64> = (0..3)
        .map(|level| {
            let radius = (3.0 / (4.0 * std::f64::consts::PI)).cbrt();
            let mesh = icosphere(radius, level, "bubble").unwrap();
            let bubble = VolumeConstraint::with_target(
                "bubble".into(),
                Region {
                    boundary: vec![(0, 1.0)],
                    reference: Point::zeros(),
                },
                1.0,
            );
            let nlp = CmcNlp::new(mesh, vec![bubble.clone()], Vec::new(), 0.01).unwrap();
            let options = Options {
                verbosity: 0,
                ..Default::default()
            };
            let solution = crate::solver::solve(&nlp, &options);
            assert!(solution.status.is_success(), "level {level}");
            let mesh = nlp.mesh_at(&solution.x).unwrap();
            let v = bubble.region.volume(&mesh);
            assert!((v - 1.0).abs() < 1e-6, "volume {v}");
            total_area(&mesh) - exact
        })
        .collect();
    assert!(errors.iter().all(|&e| e > 0.0), "{errors:?}");
    for rate in rates(&errors) {
        assert!(rate > 3.6 && rate < 4.4, "{errors:?}");
    }
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn catenoid_between_unit_rings_matches_the_catenary() {
    // Rings of radius 1, 1.0 apart: stable catenoid area 5.991796975802.
    let (_, exact) = exact_catenoid(1.0, 1.0).unwrap();
    let problem = from_text(
        "[shape]\ntype = \"catenoid\"\nradius = 1.0\nseparation = 1.0\n",
        "catenoid",
    );
    // Levels 2 and 3 (24 and 36 segments per ring, rows in proportion). Level 1 is left out:
    // there the rings' polygon deficit and the meridians' chord excess cancel by chance.
    let errors: Vec<f64> = [2, 3]
        .into_iter()
        .map(|level| {
            let outcome = solve(&problem.with_resolution(level));
            let h = outcome.summary.figures["surfaces"][0]["mean_curvature"]
                .as_f64()
                .unwrap();
            assert!(h.abs() < 1e-4, "H = {h}");
            (area(&outcome) - exact).abs()
        })
        .collect();
    // Edges shrink by 3/2: second order gives a ratio of 2.25 (measured 1.96; level 4 gives
    // 1.70 against 1.78, docs/notes/cmc.md).
    assert!(errors[0] / errors[1] > 1.8, "{errors:?}");
    assert!(errors[1] / exact < 1e-4, "{errors:?}");
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn double_bubble_meets_at_120_degrees_and_balances_pressures() {
    // Volumes 1 and 2 (cm³, in m³): exact area 11.854293128 cm².
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/cmc/double_bubble.toml");
    let exact = standard_double_bubble(1e-6, 2e-6).2;
    // Relative area error and deviation from the cluster identity A = 1.5·Σ p_i V_i, with
    // p_i = 2·H of bubble i's outer cap (outward normal, unit tension), at levels 3 and 4.
    let mut area_errors = Vec::new();
    let mut identity_errors = Vec::new();
    for level in [3, 4] {
        let outcome = solve(&load(&path).unwrap().with_resolution(level));
        let f = &outcome.summary.figures;
        let a = area(&outcome);
        let h = |name: &str| {
            f["surfaces"]
                .as_array()
                .unwrap()
                .iter()
                .find(|s| s["name"] == name)
                .unwrap()["mean_curvature"]
                .as_f64()
                .unwrap()
        };
        let pv = 2.0 * h("left") * 1e-6 + 2.0 * h("right") * 2e-6;
        area_errors.push(a / exact - 1.0);
        identity_errors.push((1.5 * pv / a - 1.0).abs());
        // Dihedral angles between the films at every junction edge: 120° ± 5° (measured
        // 115.1°–122.7° at level 4).
        let j = &f["junction_angles"];
        for key in ["min_deg", "max_deg"] {
            let angle = j[key].as_f64().unwrap();
            assert!((angle - 120.0).abs() < 5.0, "level {level}: {key} {angle}");
        }
    }
    // Measured: area 2.0 % and 1.1 % above, identity 7.4 % and 4.2 % off.
    assert!(area_errors.iter().all(|&e| e > 0.0), "{area_errors:?}");
    assert!(area_errors[1] < 0.7 * area_errors[0], "{area_errors:?}");
    assert!(
        identity_errors[1] < 0.7 * identity_errors[0],
        "{identity_errors:?}"
    );
    assert!(identity_errors[1] < 0.05, "{identity_errors:?}");
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn tetrahedral_octahedron_film_is_flat_with_area_two_root_two() {
    // All films flat: the discrete optimum is the exact one, 2√2·edge². The area formulation
    // reaches it to the solver's tolerance; normal coordinates (the default) to the rounds'
    // stopping rule, a relaxation gaining at most RELAXATION_GAIN = 1e-5 of the area.
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/cmc/octahedron_frame.toml");
    let exact = 2.0 * 2f64.sqrt() * 0.05 * 0.05;
    for (formulation, tolerance) in [(Formulation::Area, 1e-7), (Formulation::Normal, 1e-6)] {
        let mut problem = load(&path).unwrap().with_resolution(2);
        problem.spec.file.formulation = formulation;
        let outcome = solve(&problem);
        assert!(
            (area(&outcome) / exact - 1.0).abs() < tolerance,
            "{formulation:?}: {}",
            area(&outcome)
        );
    }
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn double_bubble_junction_angles_converge_to_120_degrees() {
    // problems/cmc/double_bubble.toml (one round of flips) at levels 3, 4, 5: the largest
    // deviation of the sphere-fit junction angles from 120° must shrink with every refinement
    // and be below 2° at level 5 (the stated tolerance). Measured (docs/notes/cmc.md): 2.16°,
    // 1.76°, 1.09° at levels 3–5, 0.83° at 6, 0.46° at 8; fits within 1.3e-2 of the size.
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/cmc/double_bubble.toml");
    let mut deviations = Vec::new();
    for level in [3, 4, 5] {
        let outcome = solve(&load(&path).unwrap().with_resolution(level));
        let (deviation, fit, count) = sphere_fit_junction_deviation(&solved_mesh(&outcome));
        assert_eq!(count, 6 * level, "junction circle of 6·level vertices");
        assert!(
            fit < 0.02,
            "level {level}: films off their spheres by {fit}"
        );
        deviations.push(deviation);
    }
    for w in deviations.windows(2) {
        assert!(w[1] < 0.85 * w[0], "{deviations:?}");
    }
    assert!(deviations[2] < 2.0, "{deviations:?}");
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn triple_bubble_junction_angles_converge_to_120_degrees() {
    // problems/cmc/triple_bubble.toml (volumes 1, 1.5, 2 cm³; every film of the standard
    // triple bubble is spherical) at resolutions 4 and 8 (the shipped one), each solved from
    // the generator's digon start; the vertices where four junction lines meet (the poles)
    // are left out. The stated tolerance: below 1.5° at resolution 8, and at least 1.5×
    // smaller than at 4. Measured: 2.41° at 4, 1.27° at 8 (the earlier grid start, resolution
    // 8 from the subdivided resolution-4 solution: 2.10°, 0.40°).
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/cmc/triple_bubble.toml");
    let mut deviations = Vec::new();
    for level in [4, 8] {
        let outcome = solve(&load(&path).unwrap().with_resolution(level));
        let (deviation, fit, count) = sphere_fit_junction_deviation(&solved_mesh(&outcome));
        assert!(
            count >= 4 * level,
            "level {level}: {count} junction vertices"
        );
        assert!(
            fit < 0.02,
            "level {level}: films off their spheres by {fit}"
        );
        deviations.push(deviation);
    }
    assert!(deviations[1] < deviations[0] / 1.5, "{deviations:?}");
    assert!(deviations[1] < 1.5, "{deviations:?}");
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn the_triple_bubble_solves_soundly_at_resolutions_without_a_small_divisor() {
    // problems/cmc/triple_bubble.toml at 10 (= 2·5), 11 and 13 (primes) and 16, no `[quality]`
    // keys: with pole fans of one triangle per row column (~109°/resolution each) 10, 11 and
    // 13 ended Optimal in 1,291 iterations with a 2.8° triangle, Degenerate (0.8°) and at the
    // iteration limit (0.0°). The stated bounds: Optimal, no triangle angle below 10°, fewer
    // than 200 iterations; at 16, from the prolonged resolution-8 solution, fewer than 60 (from
    // its own start the first solve stalled and the fallback took 122 in all). Measured:
    // 37 / 28 / 28 / 28 iterations, 17.3° / 17.7° / 16.4° / 12.4° (13 and 16 prolonged).
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/cmc/triple_bubble.toml");
    for (resolution, most_iterations) in [(10, 200), (11, 200), (13, 200), (16, 60)] {
        let outcome = solve(&load(&path).unwrap().with_resolution(resolution));
        let summary = &outcome.summary;
        assert_eq!(summary.status, "Optimal", "resolution {resolution}");
        assert!(
            summary.iterations < most_iterations,
            "resolution {resolution}: {}",
            summary.iterations
        );
        let q = super::figures::quality(&solved_mesh(&outcome));
        assert!(q.min_angle_deg >= 10.0, "resolution {resolution}: {q:?}");
    }
}

/// A cluster file of bubbles `(name, centre in cm, volume in cm³)` at `resolution`, solved
/// from one segment per polygon edge (`coarse_resolution = 1`) with w = 1, as the shipped
/// tetrahedral cluster.
fn cluster_text(bubbles: &[(&str, [f64; 3], f64)], resolution: usize) -> String {
    let mut text = format!("resolution = {resolution}\n[shape]\ntype = \"cluster\"\n");
    for (name, c, v) in bubbles {
        text += &format!(
            "[[shape.bubble]]\nname = \"{name}\"\ncentre = [{:e}, {:e}, {:e}]\nvolume = {:e}\n",
            c[0] * 1e-2,
            c[1] * 1e-2,
            c[2] * 1e-2,
            v * 1e-6
        );
    }
    // No `[quality]`: the cluster's own defaults (coarse level 1, w = 1) apply.
    text
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn a_two_bubble_cluster_is_the_standard_double_bubble() {
    // Bubbles of 1 and 2 cm³ placed 1 cm apart: the power-diagram start (a flat wall, flat
    // skins on a polytope) solves to the standard double bubble, 11.854293128 cm². Measured
    // at resolution 4 (3,680 triangles): 11.860412 cm², +0.052 %, within the discretization
    // error of the double bubble's own generator (+0.104 % at 3,042 triangles, docs/notes).
    let text = cluster_text(
        &[
            ("small", [-0.5, 0.0, 0.0], 1.0),
            ("large", [0.5, 0.0, 0.0], 2.0),
        ],
        4,
    );
    let outcome = solve(&from_text(&text, "two_bubble_cluster"));
    let exact = 11.854293128e-4;
    let relative = area(&outcome) / exact - 1.0;
    assert!(
        relative > 0.0 && relative < 1e-3,
        "area {} (+{relative:e})",
        area(&outcome)
    );
    let (deviation, fit, count) = sphere_fit_junction_deviation(&solved_mesh(&outcome));
    assert!(count >= 20, "{count} junction vertices");
    assert!(fit < 0.02, "films off their spheres by {fit}");
    assert!(deviation < 2.0, "junction angles off 120° by {deviation}°");
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn a_triple_bubble_of_unequal_volumes_solves_from_the_defaults() {
    // 1, 2 and 3 cm³ from the symmetric start, no `[quality]` keys: with w = 0.01 (the
    // default before the triple bubble had its own) the pole fans collapsed and the run ended
    // Stalled at resolution 4; with the shape's default w = 1 it is Optimal (measured 70
    // iterations, 20.91 cm²), below the start's area.
    let text = "resolution = 4\n[shape]\ntype = \"triple_bubble\"\n\
                volumes = [1.0e-6, 2.0e-6, 3.0e-6]\n";
    let problem = from_text(text, "unequal_triple_bubble");
    let start = total_area(problem.build().unwrap().mesh());
    let outcome = solve(&problem);
    assert!(
        area(&outcome) < start,
        "{} vs start {start}",
        area(&outcome)
    );
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn the_tetrahedral_cluster_meets_plateaus_laws() {
    // problems/cmc/tetrahedral_cluster.toml (four 1 cm³ bubbles) at resolutions 2 and 4 (the
    // shipped one): every film of the standard tetrahedral cluster is spherical or flat, so the
    // sphere-fit angles apply (vertices where more than three films meet left out). Plateau's
    // 120° is approached under refinement, the four bubbles stay alike (the symmetry the
    // start's icosahedral polytope does not have), and the area falls towards its limit.
    // Measured: largest deviation 1.30° at 2 and 0.39° at 4, fits within 4.1e-3 and 1.8e-3 of
    // the size, areas 16.936870 and 16.906582 cm².
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/cmc/tetrahedral_cluster.toml");
    let mut deviations = Vec::new();
    let mut areas = Vec::new();
    for level in [2, 4] {
        let outcome = solve(&load(&path).unwrap().with_resolution(level));
        let mesh = solved_mesh(&outcome);
        let (deviation, fit, count) = sphere_fit_junction_deviation(&mesh);
        assert!(
            count >= 12 * level,
            "level {level}: {count} junction vertices"
        );
        assert!(
            fit < 0.02,
            "level {level}: films off their spheres by {fit}"
        );
        let skins: Vec<f64> = outcome.summary.figures["surfaces"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|s| s["name"].as_str().unwrap().len() == 1)
            .map(|s| s["area"].as_f64().unwrap())
            .collect();
        assert_eq!(skins.len(), 4);
        let (lo, hi) = skins
            .iter()
            .fold((f64::MAX, 0.0f64), |(l, h), a| (l.min(*a), h.max(*a)));
        assert!(hi / lo - 1.0 < 1e-3, "level {level}: skins {skins:?}");
        deviations.push(deviation);
        areas.push(area(&outcome));
    }
    assert!(deviations[1] < deviations[0] / 1.5, "{deviations:?}");
    assert!(deviations[1] < 1.0, "{deviations:?}");
    assert!(areas[1] < areas[0], "{areas:?}");
}

/// The first pop round's event kinds of a solved outcome (`figures.topology.pops`).
fn first_pop_kinds(outcome: &Outcome) -> Vec<String> {
    outcome.summary.figures["topology"]["pops"][0]["events"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["kind"].as_str().unwrap().to_string())
        .collect()
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn the_octahedral_cone_pops_into_the_flat_tetrahedral_film() {
    // Surface Evolver's octa.fe, solved with pops from the cone: six quadruple lines split,
    // the centre opened, the films that shrink merged away and popped again. The end is the
    // tetrahedral film, all flat, whose discrete optimum is the exact 2√2·edge²; normal
    // coordinates stop at a relaxation gain of RELAXATION_GAIN = 1e-5 of the area.
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/cmc/octahedron_cone.toml");
    let exact = 2.0 * 2f64.sqrt() * 0.05 * 0.05;
    for resolution in [1, 3] {
        let outcome = solve(&load(&path).unwrap().with_resolution(resolution));
        let error = area(&outcome) / exact - 1.0;
        assert!(error.abs() < 1e-5, "resolution {resolution}: {error:e}");
        let topology = &outcome.summary.figures["topology"];
        assert_eq!(topology["non_minimal_lines"], 0);
        assert_eq!(topology["non_minimal_vertices"], 0);
        let mut kinds = vec!["line"; 6];
        kinds.push("vertex");
        assert_eq!(first_pop_kinds(&outcome), kinds);
        assert_eq!(outcome.summary.figures["stability"]["verdict"], "stable");
    }
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn the_unpopped_octahedral_cone_is_reported_as_no_soap_film() {
    // Without pops the cone is a critical point of its own topology: twelve flat right
    // triangles of legs edge/√2, area 3·edge², with its junctions counted and named.
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/cmc/octahedron_cone.toml");
    let mut problem = load(&path).unwrap().with_resolution(2);
    problem.spec.file.topology.pop = false;
    let outcome = solve(&problem);
    assert!((area(&outcome) / (3.0 * 0.05 * 0.05) - 1.0).abs() < 1e-9);
    let topology = &outcome.summary.figures["topology"];
    assert_eq!(topology["non_minimal_lines"], 6);
    assert_eq!(topology["non_minimal_vertices"], 1);
    assert!(topology["pops"].as_array().unwrap().is_empty());
    assert!(
        outcome.summary.status_message.contains("not a soap film"),
        "{}",
        outcome.summary.status_message
    );
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "slow without optimizations: run with --release"
)]
fn the_imported_cube_cone_pops_into_the_film_the_cube_frame_start_reaches() {
    // The same film from two starts: the imported cone, its centre popped and refined to
    // 2,240 facets, and the generator's central-square start at resolution 12 (3,168
    // facets). Both below the cone's 3√2·edge².
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/cmc");
    let popped = solve(&load(&dir.join("cube_cone.toml")).unwrap());
    assert_eq!(first_pop_kinds(&popped), ["vertex"]);
    assert_eq!(
        popped.summary.figures["topology"]["pops"][0]["events"][0]["sheets"],
        6
    );
    assert_eq!(popped.summary.figures["stability"]["verdict"], "stable");
    let direct = solve(
        &load(&dir.join("cube_frame_film.toml"))
            .unwrap()
            .with_resolution(12),
    );
    let (a, b) = (area(&popped), area(&direct));
    assert!((a / b - 1.0).abs() < 1e-4, "{a} vs {b}");
    assert!(a < 3.0 * 2f64.sqrt() * 0.05 * 0.05 * (1.0 - 5e-4), "{a}");
}
