//! Topology events in a run (`[topology] pop = true`): after a solve, the non-minimal
//! junctions are popped ([`super::pop`]) and the film solved again from the popped mesh, the
//! new films growing from their small start to their size; equiangulated and solved once more
//! when edges flip. A pop may open a film the wrong way for the whole (a line with four films
//! at 90° has two equally good splits): that film then shrinks during the re-solve, and the
//! solve stalls on its collapsing triangles. So each later round first merges the edges
//! shorter than [`COLLAPSE_FRACTION`] of the median edge length
//! ([`pop::collapse_short_edges`], Evolver's `t`), which turns a shrunken film back into a
//! junction, and pops again. Rounds repeat while there is something to merge or pop, up to
//! [`MAX_POP_ROUNDS`]. Each round is a [`PopRound`] record (`figures.topology.pops` in
//! `result.json`): the merges, the events, and the areas before and after the pop and after
//! the re-solve.
//!
//! Where it runs: after each coarse level of a coarse-to-fine start ([`super::multilevel`]),
//! where the new films are a few triangles that the finer levels refine, and after the full
//! resolution's solve.

use crate::error::Error;
use crate::solver::Solution;

use super::area::total_area;
use super::nlp::CmcNlp;
use super::pop::{self, PopEvent};
use super::remesh::equiangulate;
use super::rescue::{self, Resolver};

/// At most this many pop rounds after one solve.
pub const MAX_POP_ROUNDS: usize = 6;

/// Edges shorter than this fraction of the median edge length are merged before a pop round
/// after the first ([`pop::collapse_short_edges`]). On problems/cmc/octahedron_cone.toml 0.02
/// merged too late: the coarse level's shrinking films stalled the solves and the run ended
/// at the iteration limit (1,504 iterations, 4.6 s); 0.1 ends Optimal at the tetrahedral film
/// (616 iterations, 0.4 s). Surface Evolver's own octa.fe script merges at 0.1 of a frame
/// edge.
pub const COLLAPSE_FRACTION: f64 = 0.1;

/// Iteration cap of the first re-solve after a pop: its films only need to grow or shrink
/// towards their size before the edge flips and the next round's merges.
pub const POP_SOLVE_ITERATIONS: usize = 50;

/// One pop and the re-solve after it.
#[derive(Debug, Clone, serde::Serialize)]
pub struct PopRound {
    /// The stage of the solve before the pop ("level 1", "full", ...).
    pub stage: String,
    /// Edges merged first: films that had shrunk to nothing.
    pub merges: usize,
    /// The topology changes.
    pub events: Vec<PopEvent>,
    /// Total area of the solved film before the pop, m².
    pub area_before: f64,
    /// Total area of the popped mesh, m².
    pub area_popped: f64,
    /// Total area after the re-solve (and the re-solve after edge flips), m².
    pub area_after: f64,
    /// Status of the last re-solve.
    pub status: String,
    /// Major iterations of the re-solves.
    pub iterations: usize,
}

/// The surfaces that bound a body of `nlp` (a volume or pressure region): their junctions are
/// not popped ([`pop::pop`]).
fn bounding_surfaces(nlp: &CmcNlp) -> Vec<bool> {
    let mut bounding = vec![false; nlp.mesh().surfaces().len()];
    for volume in nlp.volumes() {
        for &(s, _) in &volume.region.boundary {
            if let Some(flag) = bounding.get_mut(s) {
                *flag = true;
            }
        }
    }
    bounding
}

/// Pops the solved film's non-minimal junctions and solves again, in rounds (module header).
/// The resolver's `account` sees every re-solve (for the run's iteration and evaluation
/// totals). Returns the
/// last problem and solution and the rounds; `nlp` and `solution` themselves when nothing
/// popped or the solve had not converged.
pub fn pop_and_resolve(
    mut nlp: CmcNlp,
    mut solution: Solution,
    resolver: &mut Resolver,
) -> Result<(CmcNlp, Solution, Vec<PopRound>), Error> {
    let mut rounds = Vec::new();
    for round in 0..MAX_POP_ROUNDS {
        if !rescue::settled(&solution, resolver.options) {
            break;
        }
        let mesh = nlp
            .mesh_at(&solution.x)
            .map_err(|e| rescue::step_failed("mesh before the pop", &e))?;
        // From the second round on, films that shrank to nothing leave first.
        let (collapsed, merges) = match round {
            0 => (mesh.clone(), 0),
            _ => pop::collapse_short_edges(&mesh, COLLAPSE_FRACTION)
                .map_err(|e| rescue::step_failed("short edges", &e))?,
        };
        let (popped, events) = pop::pop(&collapsed, &bounding_surfaces(&nlp))
            .map_err(|e| rescue::step_failed("pop", &e))?;
        if merges == 0 && events.is_empty() {
            break;
        }
        let area_popped = total_area(&popped);
        let pop_stage = format!("pop {}", round + 1);
        let mut next = nlp
            .remeshed(popped)
            .map_err(|e| rescue::step_failed("popped mesh", &e))?;
        let mut capped = resolver.options.clone();
        capped.max_iterations = capped.max_iterations.min(POP_SOLVE_ITERATIONS);
        let mut resolved = resolver.solve_with(&mut next, &capped, &pop_stage);
        let mut iterations = resolved.iterations;
        if let Ok(after) = next.mesh_at(&resolved.x) {
            let (flipped, flips) =
                equiangulate(&after, 10).map_err(|e| rescue::step_failed("flips", &e))?;
            if flips > 0 {
                next = next
                    .remeshed(flipped)
                    .map_err(|e| rescue::step_failed("flipped mesh", &e))?;
                let flipped_stage = format!("{pop_stage} remeshed");
                resolved = resolver.solve(&mut next, &flipped_stage);
                iterations += resolved.iterations;
            }
        }
        let area_after = next
            .mesh_at(&resolved.x)
            .map(|m| total_area(&m))
            .map_err(|e| rescue::step_failed("mesh after the pop", &e))?;
        rounds.push(PopRound {
            stage: resolver.stage.to_string(),
            merges,
            events,
            area_before: total_area(&mesh),
            area_popped,
            area_after,
            status: format!("{:?}", resolved.status),
            iterations,
        });
        (nlp, solution) = (next, resolved);
    }
    Ok((nlp, solution, rounds))
}
