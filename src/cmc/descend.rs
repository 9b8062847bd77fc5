//! Leaving a saddle along its negative mode (`[stability] descend = true`, Surface Evolver's
//! `saddle`).
//!
//! A solve can end at a critical point that is not a minimum: the catenoid's unstable branch,
//! a symmetric start that the descent never left. The stability analysis then counts a
//! negative eigenvalue of the second variation and gives its eigenvector as a motion of the
//! vertices ([`super::stability::Stability::descent`], largest displacement 1). Along it the
//! energy `L = A − Σ pᵢ Vᵢ` (the pressures fitted at the solution; for held volumes the
//! Lagrangian, whose second variation the analysis computed) falls in both directions at
//! second order. The mesh is moved by `t` times the motion for `t = ±h·2^j/4`, `j = 0 …`
//! [`STEP_DOUBLINGS`], `h` the median edge length; for each sign the move with the lowest `L`
//! below the solution's is a candidate, and the film is solved again from the lower one
//! first. A re-solve that does not converge is rejected and the other sign tried (one way may
//! lead where the film must change topology: the unstable catenoid's neck shrinking towards a
//! pinch). This repeats while the new solution is still a saddle, up to [`MAX_DESCENTS`]
//! times.
//!
//! The re-solve is in the area formulation (three coordinates per vertex,
//! [`CmcNlp::in_area_formulation`]): the mode moves each vertex along its normal, which on a
//! steep film is far from the direction the mesh needs (on the unstable catenoid between unit
//! rings 1 m apart, 36 segments per ring, nearly vertical at the rings: the rows crowd towards
//! the neck), and normal coordinates, which keep the moved vertices on their normal lines,
//! then ended Optimal at discrete critical points of crowded rows, area 6.40–6.55 m² against
//! the stable catenoid's 5.99 for the first 1–6 trial steps; three coordinates with the
//! tangential regularization reach the stable catenoid (test below). Each descent is a [`Descent`]
//! record (`figures.stability_descents` in `result.json`).

use crate::error::Error;
use crate::solver::Solution;

use super::area::total_area;
use super::mesh::{Mesh, Point};
use super::nlp::CmcNlp;
use super::rescue::{self, Resolver};
use super::stability;

/// At most this many descents after one solve.
pub const MAX_DESCENTS: usize = 3;

/// The trial steps are `h/4 · 2^j` for `j = 0 … STEP_DOUBLINGS` (both signs).
pub const STEP_DOUBLINGS: usize = 5;

/// One move along a negative mode and the re-solve after it.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Descent {
    /// The smallest eigenvalue at the saddle, 1/m².
    pub eigenvalue: f64,
    /// The signed step: the largest vertex displacement of the move, m.
    pub step: f64,
    /// Total area at the saddle, m².
    pub area_before: f64,
    /// Total area after the move, m².
    pub area_moved: f64,
    /// Total area after the re-solve, m².
    pub area_after: f64,
    /// Status of the re-solve.
    pub status: String,
    /// Major iterations of the re-solve.
    pub iterations: usize,
    /// Whether the re-solve converged and its solution replaced the saddle's (otherwise the
    /// move the other way is tried next, or the saddle stands).
    pub kept: bool,
}

/// `L = A − Σ pᵢ Vᵢ` of `mesh` (m²) with the bodies' pressures (1/m).
fn energy(nlp: &CmcNlp, mesh: &Mesh, pressures: &[f64]) -> f64 {
    let work: f64 = nlp
        .volumes()
        .iter()
        .zip(pressures)
        .map(|(v, p)| p * v.region.volume(mesh))
        .sum();
    total_area(mesh) - work
}

/// `mesh` with every vertex moved by `step` times its `motion` (m); `None` when a triangle
/// degenerates.
fn moved_along(mesh: &Mesh, motion: &[Point], step: f64) -> Option<Mesh> {
    let mut moved = mesh.clone();
    let positions = mesh
        .positions()
        .iter()
        .zip(motion)
        .map(|(p, m)| p + m * step)
        .collect();
    (moved.set_positions(positions).is_ok() && moved.check_areas().is_ok()).then_some(moved)
}

/// While the solved film is a saddle, moves it along the negative mode and solves again
/// (module header). The resolver's `account` sees every re-solve. Returns the last problem and solution and
/// the descents; `nlp` and `solution` themselves when the solution is no saddle, had not
/// converged, or no trial step lowers the energy.
pub fn descend(
    mut nlp: CmcNlp,
    mut solution: Solution,
    resolver: &mut Resolver,
) -> Result<(CmcNlp, Solution, Vec<Descent>), Error> {
    let mut descents = Vec::new();
    for _ in 0..MAX_DESCENTS {
        if !rescue::settled(&solution, resolver.options) {
            break;
        }
        let mesh = nlp
            .mesh_at(&solution.x)
            .map_err(|e| rescue::step_failed("mesh at the saddle", &e))?;
        let analysis = stability::analyse(&mesh, &nlp.bodies(), 1);
        let (Some(motion), Some(&eigenvalue)) =
            (&analysis.descent, analysis.smallest_eigenvalues.first())
        else {
            break;
        };
        let at_saddle = energy(&nlp, &mesh, &analysis.pressures);
        let h = mesh.median_edge_length();
        // The best trial move of each sign, the lower energy first.
        let mut moves: Vec<(f64, f64, Mesh)> = Vec::new();
        for sign in [1.0, -1.0] {
            let mut best: Option<(f64, f64, Mesh)> = None;
            for j in 0..=STEP_DOUBLINGS {
                let step = sign * h * 0.25 * f64::powi(2.0, j as i32);
                let Some(moved) = moved_along(&mesh, motion, step) else {
                    continue;
                };
                let e = energy(&nlp, &moved, &analysis.pressures);
                if e < at_saddle && best.as_ref().is_none_or(|b| e < b.0) {
                    best = Some((e, step, moved));
                }
            }
            moves.extend(best);
        }
        moves.sort_by(|a, b| a.0.total_cmp(&b.0));
        // The first whose re-solve converges is kept (the other way may lead where the film
        // must change topology: the catenoid's pinching neck).
        let mut kept = None;
        for (_, step, moved) in moves {
            let area_moved = total_area(&moved);
            let descent_stage = format!("descent {}", descents.len() + 1);
            let mut next = nlp
                .in_area_formulation(moved)
                .map_err(|e| rescue::step_failed("moved mesh", &e))?;
            let resolved = resolver.solve(&mut next, &descent_stage);
            let area_after = next
                .mesh_at(&resolved.x)
                .map(|m| total_area(&m))
                .map_err(|e| rescue::step_failed("mesh after the descent", &e))?;
            let converged = resolved.status.is_success();
            descents.push(Descent {
                eigenvalue,
                step,
                area_before: total_area(&mesh),
                area_moved,
                area_after,
                status: format!("{:?}", resolved.status),
                iterations: resolved.iterations,
                kept: converged,
            });
            if converged {
                kept = Some((next, resolved));
                break;
            }
        }
        match kept {
            Some(pair) => (nlp, solution) = pair,
            None => break,
        }
    }
    Ok((nlp, solution, descents))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::load;
    use crate::cmc::testing::{onto_catenoid, unit_catenoid_branches};
    use crate::solver::Options;
    use std::path::PathBuf;

    /// The catenoid problem (unit rings 1 apart) at `resolution`, started on `r = a·cosh(y/a)`.
    fn catenoid_from(a: f64, resolution: usize) -> CmcNlp {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/cmc/catenoid.toml");
        let nlp = load(&path)
            .unwrap()
            .with_resolution(resolution)
            .build()
            .unwrap();
        let mesh = onto_catenoid(nlp.mesh().clone(), a);
        nlp.remeshed(mesh).unwrap()
    }

    #[test]
    #[cfg_attr(
        debug_assertions,
        ignore = "slow without optimizations: run with --release"
    )]
    fn the_unstable_catenoid_descends_to_the_stable_one() {
        // The solver itself leaves the unstable branch (its convexified steps follow negative
        // curvature), so the saddle is given as a solution: the exact unstable catenoid, the
        // solve stopped before its first iteration.
        let options = Options::default();
        let (stable_a, unstable_a) = unit_catenoid_branches();
        let mut saddle = catenoid_from(unstable_a, 3);
        let mut stop = options.clone();
        stop.max_iterations = 0;
        let at_saddle = saddle.solve(&stop, "");
        let mesh = saddle.mesh_at(&at_saddle.x).unwrap();
        let analysis = stability::analyse(&mesh, &[], 2);
        assert!(
            analysis.verdict.starts_with("saddle"),
            "{}",
            analysis.verdict
        );
        // The mode is a direction of negative curvature of the area: a negative second
        // difference.
        let motion = analysis.descent.clone().unwrap();
        let area_along = |step: f64| total_area(&moved_along(&mesh, &motion, step).unwrap());
        let t = 1e-3;
        assert!(area_along(t) + area_along(-t) - 2.0 * total_area(&mesh) < 0.0);
        // Descended and solved again: the stable catenoid of the same mesh.
        let mut resolver = Resolver {
            options: &options,
            stage: "",
            rescues: &mut Vec::new(),
            account: &mut |_| {},
        };
        let (descended, solution, descents) = descend(saddle, at_saddle, &mut resolver).unwrap();
        assert!(descents.last().is_some_and(|d| d.kept), "{descents:?}");
        assert!(solution.status.is_success(), "{descents:?}");
        let mut stable = catenoid_from(stable_a, 3);
        let direct = rescue::solve(&mut stable, &options, "", &mut Vec::new());
        let (a, b) = (
            total_area(&descended.mesh_at(&solution.x).unwrap()),
            total_area(&stable.mesh_at(&direct.x).unwrap()),
        );
        assert!((a / b - 1.0).abs() < 1e-6, "{a} vs {b}");
        let after = stability::analyse(&descended.mesh_at(&solution.x).unwrap(), &[], 2);
        assert_eq!(after.verdict, "stable");
    }
}
