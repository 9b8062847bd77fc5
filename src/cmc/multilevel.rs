//! Coarse-to-fine starts (`[quality] coarse_resolution`): the problem is first solved at a
//! coarse resolution, and its solution, uniformly subdivided ([`super::subdivide`]), is the
//! start of the next finer solve, up to the problem's resolution. Where the shape prolongs
//! instead (`Problem::prolonged_resolution`), one coarse level is solved without flips and its
//! solution carried onto the generator's own start at the full resolution
//! ([`super::prolong`]: same triangulation as the file's).
//!
//! Why: on a fine start far from the film's shape (the octahedral frame's flat partition walls
//! meet at 75°–160° instead of 120°), the junction lines must travel across many rows of
//! triangles; the triangles next to them flatten long before the lines arrive (min angle 9° →
//! 2° within ten iterations on `octahedron_square` at resolution 6) and the solve stalls on a
//! collapsed triangle. At the coarse level the same travel is a fraction of one triangle, and
//! each refinement starts with the junction lines within a fraction of a coarse triangle of
//! their place.
//!
//! Levels: with resolution `r` and `coarse_resolution = c`, the first solve is at `d`, the
//! largest divisor of `r` not above `c`; then `r / d` is split into its prime factors in
//! increasing order (6 → 2, 3), each one subdivision. Every intermediate level is solved and
//! equiangulated ([`super::remesh::equiangulate`], then re-solved if anything flipped); the
//! last subdivision is the start of the main solve. This applies to shapes whose resolution
//! counts segments per edge (frames, wires), so that `k`-fold subdivision of level `d` has the
//! connectivity counts of level `k·d`.
//!
//! A level that ends short of a usable solution (iteration or time limit, interrupt,
//! infeasible, ...) ends the run there: its mesh and solution are the run's result
//! ([`Staged::stopped`]), with that level's status (exit 3, or 130 when interrupted).

use crate::error::Error;
use crate::solver::{Evaluations, IterationRecord, Options, Solution, Status};

use super::Problem;
use super::area::total_area;
use super::mesh::Mesh;
use super::nlp::CmcNlp;
use super::prolong::prolong;
use super::remesh::equiangulate;
use super::rescue::{self, Rescue, Resolver};
use super::subdivide::subdivide;
use super::topology::{PopRound, pop_and_resolve};

/// One coarse level's solve.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Stage {
    /// Resolution of the level (the coarse resolution times the factors so far).
    pub resolution: usize,
    /// Vertices of the level's mesh.
    pub vertices: usize,
    /// Solver status of the level's last solve.
    pub status: String,
    /// Major iterations of the level (solve plus re-solve after flips).
    pub iterations: usize,
    /// Total area after the level's solves, m².
    pub area: f64,
}

impl Stage {
    /// The record of a level at `resolution` whose last solve ended at `mesh` with `solution`,
    /// after `iterations` in all.
    fn of(resolution: usize, mesh: &Mesh, solution: &Solution, iterations: usize) -> Stage {
        Stage {
            resolution,
            vertices: mesh.vertex_count(),
            status: format!("{:?}", solution.status),
            iterations,
            area: total_area(mesh),
        }
    }
}

/// A runtime error of `problem`'s coarse levels: `what` failed with `e`.
fn runtime_error(problem: &Problem, what: &str, e: &dyn std::fmt::Display) -> Error {
    Error::Runtime(format!("{}: {what}: {e}", problem.name))
}

/// The NLP whose start is the subdivided coarse solution, with the coarse levels' records.
#[derive(Debug)]
pub struct Staged {
    /// The problem at its full resolution, started from the refined coarse solution.
    pub nlp: CmcNlp,
    /// The coarse levels, coarsest first.
    pub stages: Vec<Stage>,
    /// Iteration logs of every coarse solve, one after the other.
    pub log: Vec<IterationRecord>,
    /// Iterations summed over the coarse solves.
    pub iterations: usize,
    /// Evaluations summed over the coarse solves.
    pub evaluations: Evaluations,
    /// The coarse solves repeated at a larger tangential weight ([`rescue`]).
    pub rescues: Vec<Rescue>,
    /// The solution of a coarse level that ended short of a usable one; `nlp` is then that
    /// level's (not refined) and the run stops there.
    pub stopped: Option<Solution>,
    /// The coarse levels' topology events (`[topology] pop`, [`super::topology`]).
    pub pops: Vec<PopRound>,
}

/// The first level `d` (largest divisor of `resolution` not above `coarse`) and the
/// subdivision factors (prime factors of `resolution / d`, increasing).
pub fn levels(resolution: usize, coarse: usize) -> (usize, Vec<usize>) {
    let resolution = resolution.max(1);
    let d = (1..=coarse.clamp(1, resolution))
        .rev()
        .find(|d| resolution.is_multiple_of(*d))
        .unwrap_or(1);
    let mut rest = resolution / d;
    let mut factors = Vec::new();
    let mut p = 2;
    while rest > 1 {
        while rest.is_multiple_of(p) {
            factors.push(p);
            rest /= p;
        }
        p += 1;
    }
    (d, factors)
}

/// Solves `problem` at its coarse level and the intermediate levels and returns the full
/// resolution's NLP started from the last subdivision; `None` when there is nothing to do
/// (no `coarse_resolution`, or it is not below the resolution).
pub fn coarse_to_fine(problem: &Problem, options: &Options) -> Result<Option<Staged>, Error> {
    if let Some(coarse) = problem.prolonged_resolution() {
        return prolonged(problem, options, coarse).map(Some);
    }
    let Some(coarse) = problem.coarse_resolution() else {
        return Ok(None);
    };
    if coarse >= problem.resolution {
        return Ok(None);
    }
    let (first, factors) = levels(problem.resolution, coarse);
    let runtime = |what: &str, e: &dyn std::fmt::Display| runtime_error(problem, what, e);
    let mut nlp = problem.with_resolution(first).build()?;
    let (mut stages, mut log, mut evaluations) = (Vec::new(), Vec::new(), Evaluations::default());
    let mut rescues = Vec::new();
    let mut pops = Vec::new();
    let mut resolution = first;
    for (level, &factor) in factors.iter().enumerate() {
        let mut iterations = 0;
        let stage = format!("level {}", level + 1);
        let mut solution = rescue::solve(&mut nlp, options, &stage, &mut rescues);
        iterations += solution.iterations;
        log.extend_from_slice(&solution.log);
        add(&mut evaluations, &solution.evaluations);
        let solved = usable(solution.status, solution.max_violation, options);
        if solved {
            let mesh = nlp
                .mesh_at(&solution.x)
                .map_err(|e| runtime("coarse mesh", &e))?;
            let (flipped, flips) =
                equiangulate(&mesh, 10).map_err(|e| runtime("edge flips", &e))?;
            if flips > 0 {
                nlp = nlp
                    .remeshed(flipped)
                    .map_err(|e| runtime("flipped mesh", &e))?;
                let remeshed = format!("{stage} remeshed");
                solution = rescue::solve(&mut nlp, options, &remeshed, &mut rescues);
                iterations += solution.iterations;
                log.extend_from_slice(&solution.log);
                add(&mut evaluations, &solution.evaluations);
            }
        }
        if solved && problem.spec.file.topology.pop {
            let mut account = |s: &Solution| {
                iterations += s.iterations;
                log.extend_from_slice(&s.log);
                add(&mut evaluations, &s.evaluations);
            };
            let mut resolver = Resolver {
                options,
                stage: &stage,
                rescues: &mut rescues,
                account: &mut account,
            };
            let rounds;
            (nlp, solution, rounds) = pop_and_resolve(nlp, solution, &mut resolver)?;
            pops.extend(rounds);
        }
        let mesh = nlp
            .mesh_at(&solution.x)
            .map_err(|e| runtime("coarse mesh", &e))?;
        stages.push(Stage::of(resolution, &mesh, &solution, iterations));
        if !usable(solution.status, solution.max_violation, options) {
            return Ok(Some(Staged {
                nlp,
                iterations: stages.iter().map(|s: &Stage| s.iterations).sum(),
                stages,
                log,
                evaluations,
                rescues,
                stopped: Some(solution),
                pops,
            }));
        }
        let finer = subdivide(&mesh, factor).map_err(|e| runtime("subdivision", &e))?;
        nlp = nlp
            .remeshed(finer)
            .map_err(|e| runtime("subdivided mesh", &e))?;
        resolution *= factor;
    }
    Ok(Some(Staged {
        nlp,
        iterations: stages.iter().map(|s: &Stage| s.iterations).sum(),
        stages,
        log,
        evaluations,
        rescues,
        stopped: None,
        pops,
    }))
}

/// One coarse level at resolution `coarse`, solved without edge flips, its solution
/// prolonged onto the generator's own start at the problem's resolution ([`prolong`]): the
/// full resolution's NLP on the file's triangulation, started near its answer.
fn prolonged(problem: &Problem, options: &Options, coarse: usize) -> Result<Staged, Error> {
    let runtime = |what: &str, e: &dyn std::fmt::Display| runtime_error(problem, what, e);
    let mut nlp = problem.with_resolution(coarse).build()?;
    let coarse_start = nlp.mesh().clone();
    let mut rescues = Vec::new();
    let solution = rescue::solve(&mut nlp, options, "level 1", &mut rescues);
    let mesh = nlp
        .mesh_at(&solution.x)
        .map_err(|e| runtime("coarse mesh", &e))?;
    let stages = vec![Stage::of(coarse, &mesh, &solution, solution.iterations)];
    let (iterations, log, evaluations) = (
        solution.iterations,
        solution.log.clone(),
        solution.evaluations,
    );
    if !usable(solution.status, solution.max_violation, options) {
        return Ok(Staged {
            nlp,
            stages,
            log,
            iterations,
            evaluations,
            rescues,
            stopped: Some(solution),
            pops: Vec::new(),
        });
    }
    let fine = problem.build()?;
    let mut start = fine.mesh().clone();
    let positions =
        prolong(&coarse_start, &mesh, &start).map_err(|e| runtime("prolongation", &e))?;
    start
        .set_positions(positions)
        .map_err(|e| runtime("prolonged mesh", &e))?;
    Ok(Staged {
        nlp: fine
            .remeshed(start)
            .map_err(|e| runtime("prolonged mesh", &e))?,
        stages,
        log,
        iterations,
        evaluations,
        rescues,
        stopped: None,
        pops: Vec::new(),
    })
}

/// A level's solution is refined when it succeeded or stalled feasible (a stall here is
/// usually a triangle folded flat, which the next level's flips and solve repair).
fn usable(status: Status, max_violation: f64, options: &Options) -> bool {
    status.is_success()
        || (status == Status::Stalled && max_violation <= options.constraint_tolerance)
}

fn add(total: &mut Evaluations, more: &Evaluations) {
    total.functions += more.functions;
    total.derivatives += more.derivatives;
    total.hessians += more.hessians;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_split_the_refinement_into_prime_factors() {
        assert_eq!(levels(6, 1), (1, vec![2, 3]));
        assert_eq!(levels(6, 2), (2, vec![3]));
        assert_eq!(levels(6, 4), (3, vec![2]));
        assert_eq!(levels(8, 1), (1, vec![2, 2, 2]));
        assert_eq!(levels(5, 2), (1, vec![5]));
        assert_eq!(levels(3, 3), (3, vec![]));
    }

    #[test]
    fn cube_film_starts_from_its_coarse_solution_on_the_generators_triangulation() {
        // Resolution 6: a coarse level at 2, prolonged onto the generator's resolution-6 start
        // (same triangles, fixed wires in place), which it starts below in area, and the solve
        // from there ends Optimal no higher than the solve from the generator's start.
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("problems/cmc/cube_frame_film.toml");
        let problem = crate::cmc::load(&path).unwrap().with_resolution(6);
        assert_eq!(problem.prolonged_resolution(), Some(2));
        let mut options = problem.spec.file.solver.clone();
        options.verbosity = 0;
        let mut staged = coarse_to_fine(&problem, &options).unwrap().unwrap();
        assert!(staged.stopped.is_none());
        assert_eq!(staged.stages.len(), 1);
        assert_eq!(staged.stages[0].resolution, 2);
        assert_eq!(staged.stages[0].status, "Optimal");
        let mut direct = problem.build().unwrap();
        let (prolonged, generated) = (staged.nlp.mesh(), direct.mesh());
        assert_eq!(prolonged.triangles(), generated.triangles());
        for (v, flags) in generated.flags().iter().enumerate() {
            if flags.fixed {
                assert_eq!(prolonged.positions()[v], generated.positions()[v]);
            }
        }
        assert!(total_area(prolonged) < total_area(generated));
        let area = |nlp: &CmcNlp, x: &[f64]| total_area(&nlp.mesh_at(x).unwrap());
        let from_coarse = staged.nlp.solve(&options, "");
        let from_start = direct.solve(&options, "");
        assert_eq!(from_coarse.status, Status::Optimal);
        assert_eq!(from_start.status, Status::Optimal);
        assert!(area(&staged.nlp, &from_coarse.x) <= area(&direct, &from_start.x));
    }

    #[test]
    fn octahedral_film_refines_to_the_generators_counts() {
        // Quadrilateral film at resolution 2 from resolution 1: one coarse level, then the ×2
        // subdivision has the vertex, triangle, wire and junction counts of the generator's
        // resolution-2 start, with the coarse solution's (smaller) area.
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("problems/cmc/octahedron_quadrilateral.toml");
        let problem = crate::cmc::load(&path).unwrap().with_resolution(2);
        let mut options = problem.spec.file.solver.clone();
        options.verbosity = 0;
        let staged = coarse_to_fine(&problem, &options).unwrap().unwrap();
        assert_eq!(staged.stages.len(), 1);
        assert_eq!(staged.stages[0].resolution, 1);
        assert_eq!(staged.stages[0].status, "Optimal");
        let direct = problem.build().unwrap();
        let (refined, generated) = (staged.nlp.mesh(), direct.mesh());
        assert_eq!(refined.vertex_count(), generated.vertex_count());
        assert_eq!(refined.triangles().len(), generated.triangles().len());
        let fixed = |m: &crate::cmc::mesh::Mesh| m.flags().iter().filter(|f| f.fixed).count();
        assert_eq!(fixed(refined), fixed(generated));
        assert_eq!(
            refined.junction_vertices().len(),
            generated.junction_vertices().len()
        );
        assert_eq!(staged.nlp.curvature_rows(), direct.curvature_rows());
        let coarse_area = staged.stages[0].area;
        assert!((total_area(refined) - coarse_area).abs() < 1e-15);
        assert!(coarse_area < total_area(generated));
    }
}
