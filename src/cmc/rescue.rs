//! Collapsed triangles after a solve, and the re-solve at a larger tangential weight that
//! keeps them open.
//!
//! The area is nearly flat along the surface, and only the tangential regularization
//! `(w/2) Σ_j |P_j (x_j − mean of ring)|²` (m², [`super::nlp`]) holds the vertices' layout.
//! On a coarse or steep film its pull at a small `w` can lose to the area's own tangential
//! gradient: a vertex slides onto its neighbour or onto a wire, and the solve ends Optimal on
//! triangles of 0° whose area is off (ring tent of radius 0.95 m, height 0.4 m at 16 segments:
//! 221 iterations, 0.0°, at w = 0.01; 19 iterations, 10.8°, at w = 0.1).
//!
//! A solve whose movable triangles (at least one free corner) have a smallest angle below
//! [`COLLAPSED_ANGLE_DEG`] is repeated from its own start with the weight multiplied by
//! [`WEIGHT_FACTOR`], up to [`MAX_WEIGHT`]; the last repeat is the solve's result, and the
//! problem keeps that weight for what follows (flip rounds, finer levels). Each repeat is a
//! [`Rescue`] record (`figures.quality_rescues` in `result.json`): the weights, smallest
//! angles, areas and statuses before and after. The regularization's effect on the area is
//! of order `w` times the film's tangential strain, so the record shows what the larger
//! weight cost.

use crate::error::Error;
use crate::solver::{Options, Solution, Status};

use super::area::total_area;
use super::mesh::{Mesh, Point};
use super::nlp::{CmcNlp, merged};

/// Smallest angle (degrees) of a movable triangle below which a solved mesh counts as
/// collapsed. Every shipped file ends at 10.5° or more; the collapsed films of the robustness
/// sweep (docs/notes/cmc.md) ended at 0.0–1.4°, their neighbours at 2.2° and up.
pub const COLLAPSED_ANGLE_DEG: f64 = 2.0;

/// Factor on the tangential weight per repeat of a collapsed solve.
pub const WEIGHT_FACTOR: f64 = 10.0;

/// Largest tangential weight a repeat uses: the default of the shapes with fixed corners
/// (`cells`, frames, clusters), which raises a tent's area by 0.15–0.4 %
/// (docs/problem-files-cmc.md).
pub const MAX_WEIGHT: f64 = 1.0;

/// Weight of the first repeat when the problem's weight is 0.
const FIRST_WEIGHT: f64 = 0.01;

/// One repeat of a collapsed solve.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Rescue {
    /// The solve's stage ("" for a lone solve, "level 2", "remesh 1", ...).
    pub stage: String,
    /// Tangential weight of the collapsed solve.
    pub weight_before: f64,
    /// Tangential weight of the repeat.
    pub weight_after: f64,
    /// Smallest angle of a movable triangle after the collapsed solve, degrees.
    pub min_angle_deg_before: f64,
    /// The same after the repeat, degrees.
    pub min_angle_deg_after: f64,
    /// Total area after the collapsed solve, m².
    pub area_before: f64,
    /// Total area after the repeat, m².
    pub area_after: f64,
    /// Status of the collapsed solve.
    pub status_before: String,
    /// Status of the repeat.
    pub status_after: String,
}

/// The corners of each triangle with at least one free corner: what a solve can collapse.
fn movable_triangles(mesh: &Mesh) -> impl Iterator<Item = [Point; 3]> + '_ {
    let flags = mesh.flags();
    (0..mesh.triangles().len())
        .filter(move |&t| mesh.triangles()[t].iter().any(|&v| !flags[v].fixed))
        .map(|t| mesh.corners(t))
}

/// Smallest angle (degrees) over the triangles with at least one free corner (180 when there
/// is none).
pub fn movable_min_angle(mesh: &Mesh) -> f64 {
    movable_triangles(mesh)
        .map(|p| {
            (0..3)
                .map(|m| (p[(m + 1) % 3] - p[m]).angle(&(p[(m + 2) % 3] - p[m])))
                .fold(f64::INFINITY, f64::min)
                .to_degrees()
        })
        .fold(180.0, f64::min)
}

/// Whether a mesh's movable triangles are collapsed: some angle below [`COLLAPSED_ANGLE_DEG`]
/// (tested on its cosine, `(a·b)² > cos²θ |a|²|b|²` with `a·b > 0`, without inverse cosines:
/// this runs after every solve).
pub fn collapsed(mesh: &Mesh) -> bool {
    let cos2 = COLLAPSED_ANGLE_DEG.to_radians().cos().powi(2);
    movable_triangles(mesh).any(|p| {
        (0..3).any(|m| {
            let (a, b) = (p[(m + 1) % 3] - p[m], p[(m + 2) % 3] - p[m]);
            let dot = a.dot(&b);
            dot > 0.0 && dot * dot > cos2 * a.norm_squared() * b.norm_squared()
        })
    })
}

/// The run's status for a solve that ended with `status` on `mesh`: `Degenerate` (exit 3)
/// when it converged on a collapsed mesh (after the repeats), else `status`.
pub fn final_status(status: Status, mesh: &Mesh) -> Status {
    if status.is_success() && collapsed(mesh) {
        Status::Degenerate
    } else {
        status
    }
}

/// [`final_status`] of problem `name`'s run, with a warning on stderr when it is
/// `Degenerate` (at tangential weight `weight`).
pub fn judged(name: &str, status: Status, mesh: &Mesh, weight: f64) -> Status {
    let judged = final_status(status, mesh);
    if judged != status {
        eprintln!(
            "warning: {name}: converged with collapsed triangles (smallest angle {:.2}° < \
             {COLLAPSED_ANGLE_DEG}°) at tangential weight {weight}; status Degenerate, exit 3",
            movable_min_angle(mesh),
        );
    }
    judged
}

/// Whether a solve ended at a film worth working on: converged, or stalled or out of
/// iterations at a feasible point.
pub fn settled(solution: &Solution, options: &Options) -> bool {
    solution.status.is_success()
        || (matches!(solution.status, Status::Stalled | Status::IterationLimit)
            && solution.max_violation <= options.constraint_tolerance)
}

/// The name of a solve `name` within `stage` (`name` alone when the stage has none).
pub fn substage(stage: &str, name: &str) -> String {
    match stage {
        "" => name.to_string(),
        _ => format!("{stage} {name}"),
    }
}

/// The run-time error of a step after a solve (a pop, a descent): `what` failed with `e`.
pub fn step_failed(what: &str, e: &dyn std::fmt::Display) -> Error {
    Error::Runtime(format!("{what}: {e}"))
}

/// What the steps after a solve (pops, descents) need to solve again: the solver options,
/// the stage their solves are named under, the record of repeats, and `account`, which sees
/// every re-solve (for the run's totals).
pub struct Resolver<'a> {
    /// Solver options of the re-solves.
    pub options: &'a Options,
    /// Stage of the solve before ("" for a lone solve, "level 1", "full", ...).
    pub stage: &'a str,
    /// Repeats at a larger tangential weight ([`solve`]).
    pub rescues: &'a mut Vec<Rescue>,
    /// Sees every re-solve.
    pub account: &'a mut dyn FnMut(&Solution),
}

impl Resolver<'_> {
    /// [`solve`] under `options` as the solve `name` within the stage, accounted.
    pub fn solve_with(&mut self, nlp: &mut CmcNlp, options: &Options, name: &str) -> Solution {
        let solution = solve(nlp, options, &substage(self.stage, name), self.rescues);
        (self.account)(&solution);
        solution
    }

    /// [`Resolver::solve_with`] the resolver's options.
    pub fn solve(&mut self, nlp: &mut CmcNlp, name: &str) -> Solution {
        let options = self.options;
        self.solve_with(nlp, options, name)
    }
}

/// `nlp.solve(options, stage)`, repeated from the same start at larger tangential weights
/// while its mesh is collapsed (module header); each repeat is appended to `rescues`. `nlp`
/// becomes the last solve's problem; the returned solution carries every solve's iterations,
/// evaluations and log. A solve stopped by the user or the time limit is not repeated.
pub fn solve(
    nlp: &mut CmcNlp,
    options: &Options,
    stage: &str,
    rescues: &mut Vec<Rescue>,
) -> Solution {
    let start = nlp.mesh().clone();
    let mut solution = nlp.solve(options, stage);
    loop {
        if matches!(solution.status, Status::Interrupted | Status::TimeLimit) {
            return solution;
        }
        let weight = match nlp.tangential_weight() {
            w if w > 0.0 => w * WEIGHT_FACTOR,
            _ => FIRST_WEIGHT,
        };
        if weight > MAX_WEIGHT * (1.0 + 1e-12) {
            return solution;
        }
        let Ok(mesh) = nlp.mesh_at(&solution.x) else {
            return solution;
        };
        if !collapsed(&mesh) {
            return solution;
        }
        let Ok(mut repeat) = nlp.reweighted(start.clone(), weight) else {
            return solution;
        };
        let repeat_stage = match stage {
            "" => format!("w = {weight}"),
            _ => format!("{stage} w = {weight}"),
        };
        let repeated = repeat.solve(options, &repeat_stage);
        let Ok(after) = repeat.mesh_at(&repeated.x) else {
            return solution;
        };
        rescues.push(Rescue {
            stage: stage.to_string(),
            weight_before: nlp.tangential_weight(),
            weight_after: weight,
            min_angle_deg_before: movable_min_angle(&mesh),
            min_angle_deg_after: movable_min_angle(&after),
            area_before: total_area(&mesh),
            area_after: total_area(&after),
            status_before: format!("{:?}", solution.status),
            status_after: format!("{:?}", repeated.status),
        });
        *nlp = repeat;
        solution = merged(solution, repeated);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::mesh::{MeshBuilder, Point};

    #[test]
    fn fixed_triangles_do_not_count_as_collapsed() {
        // A sliver (0.1°) of three fixed vertices along a wire, and a sound triangle with a
        // free corner: only the second is movable.
        let mut b = MeshBuilder::new();
        let s = b.surface("film");
        let w: Vec<usize> = [0.0, -0.001, 0.0]
            .iter()
            .enumerate()
            .map(|(k, &z)| b.fixed(Point::new(k as f64, 0.0, z)))
            .collect();
        let v = b.vertex(Point::new(1.0, 0.0, 1.0));
        b.triangle(s, [w[0], w[1], w[2]]);
        b.triangle(s, [w[0], w[2], v]);
        let mesh = b.build().unwrap();
        assert!((movable_min_angle(&mesh) - 45.0).abs() < 1e-9);
        assert!(!collapsed(&mesh));
        assert_eq!(final_status(Status::Optimal, &mesh), Status::Optimal);
    }

    #[test]
    fn a_converged_collapsed_film_is_degenerate() {
        // A free vertex 0.01 m above a wire of two 1 m segments: 0.6° at the wire's ends.
        let mut b = MeshBuilder::new();
        let s = b.surface("film");
        let w: Vec<usize> = (0..3)
            .map(|k| b.fixed(Point::new(k as f64, 0.0, 0.0)))
            .collect();
        let v = b.vertex(Point::new(1.0, 0.0, -0.01));
        b.triangle(s, [w[0], v, w[1]]);
        b.triangle(s, [w[1], v, w[2]]);
        let mesh = b.build().unwrap();
        assert!(collapsed(&mesh));
        assert_eq!(final_status(Status::Optimal, &mesh), Status::Degenerate);
        assert_eq!(final_status(Status::Acceptable, &mesh), Status::Degenerate);
        assert!(!Status::Degenerate.is_success());
        // A solve that did not converge keeps its own status.
        assert_eq!(
            final_status(Status::IterationLimit, &mesh),
            Status::IterationLimit
        );
    }
}
