//! Prolongation of a coarse solution onto the generator's own finer start mesh (coarse-to-fine
//! starts that keep the fine triangulation, [`super::multilevel`]).
//!
//! A generator builds its start at every resolution on the same surfaces (the cube frame's
//! planar partition walls, a bubble's spheres): a fine start vertex `p` lies on (or, on a
//! curved start, next to) the coarse start triangle `(a, b, c)` of its surface that holds it,
//! with barycentric coordinates `β` of its projection onto that triangle's plane,
//!
//! ```text
//! u = ((p − a) × (c − a)) · n / |n|²,   w = ((b − a) × (p − a)) · n / |n|²,
//! β = (1 − u − w, u, w),   n = (b − a) × (c − a).
//! ```
//!
//! Its prolonged position follows the coarse solution `(a′, b′, c′)` with the same
//! coordinates, plus its offset from the coarse start's triangle (zero on a planar start):
//!
//! ```text
//! p′ = β₀ a′ + β₁ b′ + β₂ c′ + (p − (β₀ a + β₁ b + β₂ c)).
//! ```
//!
//! So the fine level starts on the coarse solution's piecewise-linear surface with its
//! tangential layout (the coarse rounds' relaxation, [`super::tangential`]) but keeps the
//! generator's connectivity: the same triangulation the file describes (and Surface Evolver
//! is given), unlike the uniform subdivision of [`super::subdivide`]. A vertex on a coarse
//! edge or corner has the same position from every triangle that holds it, so junction curves
//! and wires map onto themselves. Fixed vertices keep their start positions.
//!
//! The holding triangle is the one of the vertex's surfaces that minimizes the distance from
//! `p` to its plane plus how far `β` lies outside the triangle (its negative parts, times the
//! triangle's size); candidates come from a uniform grid of the coarse triangles' bounding
//! boxes, the lowest index winning ties (deterministic).

use std::collections::HashMap;

use super::mesh::{Mesh, Point};

/// Why a start was not prolonged.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProlongError {
    /// The coarse start and the coarse solution differ in their vertices or triangles.
    #[error("the coarse solution does not match the coarse start")]
    Mismatch,
    /// A free fine vertex lies on no surface the coarse start has.
    #[error("fine vertex {0} lies on no coarse triangle of its surfaces")]
    Unplaced(usize),
}

/// The positions of `fine_start`'s vertices carried from `coarse_start` to `coarse` (the
/// coarse level's solution on the same vertices and triangles), see the module header.
pub fn prolong(
    coarse_start: &Mesh,
    coarse: &Mesh,
    fine_start: &Mesh,
) -> Result<Vec<Point>, ProlongError> {
    if coarse_start.vertex_count() != coarse.vertex_count()
        || coarse_start.triangles().len() != coarse.triangles().len()
    {
        return Err(ProlongError::Mismatch);
    }
    let grid = Grid::new(coarse_start);
    let (start, solved) = (coarse_start.positions(), coarse.positions());
    fine_start
        .positions()
        .iter()
        .enumerate()
        .map(|(v, &p)| {
            if fine_start.flags()[v].fixed {
                return Ok(p);
            }
            let surfaces: Vec<&str> = fine_start
                .vertex_surfaces(v)
                .into_iter()
                .map(|s| fine_start.surfaces()[s].as_str())
                .collect();
            let on_surface = |t: usize| {
                let s = coarse_start.triangle_surface()[t];
                surfaces.contains(&coarse_start.surfaces()[s].as_str())
            };
            let (t, beta) = grid
                .holder(coarse_start, p, on_surface)
                .ok_or(ProlongError::Unplaced(v))?;
            let [a, b, c] = coarse_start.triangles()[t];
            let at = |x: &[Point]| x[a] * beta[0] + x[b] * beta[1] + x[c] * beta[2];
            Ok(at(solved) + (p - at(start)))
        })
        .collect()
}

/// The barycentric coordinates of `p`'s projection onto the plane of triangle `[a, b, c]` and
/// the holding score of the module header (0 for a point inside the triangle).
fn locate(p: Point, [a, b, c]: [Point; 3]) -> ([f64; 3], f64) {
    let (e1, e2, d) = (b - a, c - a, p - a);
    let n = e1.cross(&e2);
    let nn = n.norm_squared();
    if nn == 0.0 {
        return ([1.0, 0.0, 0.0], f64::INFINITY);
    }
    let u = d.cross(&e2).dot(&n) / nn;
    let w = e1.cross(&d).dot(&n) / nn;
    let beta = [1.0 - u - w, u, w];
    let size = nn.sqrt().sqrt();
    let outside: f64 = beta.iter().map(|x| (-x).max(0.0)).sum();
    (beta, n.dot(&d).abs() / nn.sqrt() + outside * size)
}

/// The coarse triangles by the cells of a uniform grid their bounding boxes (grown by a tenth
/// of the cell) overlap; the cell is the mean triangle size.
struct Grid {
    cell: f64,
    cells: HashMap<[i64; 3], Vec<usize>>,
}

impl Grid {
    fn new(mesh: &Mesh) -> Grid {
        let count = mesh.triangles().len().max(1);
        let cell = (0..mesh.triangles().len())
            .map(|t| {
                let [a, b, c] = mesh.corners(t);
                ((b - a).norm() + (c - b).norm() + (a - c).norm()) / 3.0
            })
            .sum::<f64>()
            / count as f64;
        let cell = if cell > 0.0 { cell } else { 1.0 };
        let mut cells: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
        for t in 0..mesh.triangles().len() {
            let [a, b, c] = mesh.corners(t);
            let grow = Point::repeat(0.1 * cell);
            let lo = key(a.inf(&b).inf(&c) - grow, cell);
            let hi = key(a.sup(&b).sup(&c) + grow, cell);
            for i in lo[0]..=hi[0] {
                for j in lo[1]..=hi[1] {
                    for k in lo[2]..=hi[2] {
                        cells.entry([i, j, k]).or_default().push(t);
                    }
                }
            }
        }
        Grid { cell, cells }
    }

    /// The triangle allowed by `allowed` that holds `p` best and `p`'s coordinates in it: from
    /// `p`'s cell, or from every triangle when that cell has none allowed.
    fn holder(
        &self,
        mesh: &Mesh,
        p: Point,
        allowed: impl Fn(usize) -> bool,
    ) -> Option<(usize, [f64; 3])> {
        let best = |candidates: &mut dyn Iterator<Item = usize>| {
            let mut best: Option<(f64, usize, [f64; 3])> = None;
            for t in candidates.filter(|&t| allowed(t)) {
                let (beta, score) = locate(p, mesh.corners(t));
                if score.is_finite() && best.is_none_or(|(s, _, _)| score < s) {
                    best = Some((score, t, beta));
                }
            }
            best.map(|(_, t, beta)| (t, beta))
        };
        self.cells
            .get(&key(p, self.cell))
            .and_then(|list| best(&mut list.iter().copied()))
            .or_else(|| best(&mut (0..mesh.triangles().len())))
    }
}

fn key(p: Point, cell: f64) -> [i64; 3] {
    [0, 1, 2].map(|i| (p[i] / cell).floor() as i64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::generators;

    #[test]
    fn coordinates_reproduce_points_in_the_triangle_and_score_outside_ones() {
        let tri = [Point::zeros(), Point::x(), Point::y()];
        let (beta, score) = locate(Point::new(0.25, 0.5, 0.0), tri);
        assert!((beta[0] - 0.25).abs() < 1e-15 && (beta[1] - 0.25).abs() < 1e-15);
        assert!((beta[2] - 0.5).abs() < 1e-15 && score == 0.0);
        // 0.1 above the plane and 0.5 past the edge x + y = 1.
        let (_, score) = locate(Point::new(1.0, 0.5, 0.1), tri);
        assert!((score - (0.1 + 0.5)).abs() < 1e-12, "{score}");
    }

    #[test]
    fn unmoved_coarse_start_leaves_the_fine_start_in_place() {
        // Coarse solution = coarse start: every fine vertex keeps its position (planar walls and
        // junction curves of the cube frame film, and the bubble's curved-free cube).
        for bubble in [None, Some(1e-6)] {
            let coarse = generators::cube_frame(0.05, bubble, 2).unwrap().mesh;
            let fine = generators::cube_frame(0.05, bubble, 6).unwrap().mesh;
            let moved = prolong(&coarse, &coarse, &fine).unwrap();
            for (p, q) in fine.positions().iter().zip(&moved) {
                assert!((p - q).norm() < 1e-15, "{p} → {q}");
            }
        }
    }

    #[test]
    fn an_affine_motion_of_the_coarse_level_moves_the_fine_start_alike() {
        // The coarse solution an affine map of the coarse start: the prolongation, linear on each
        // coarse triangle, applies the same map to every free fine vertex (fixed ones stay).
        let coarse = generators::cube_frame(0.05, None, 2).unwrap().mesh;
        let fine = generators::cube_frame(0.05, None, 6).unwrap().mesh;
        let map = |p: &Point| Point::new(p.x + 0.3 * p.z, 1.1 * p.y, p.z - 0.2 * p.x + 0.01);
        let mut solved = coarse.clone();
        solved
            .set_positions(coarse.positions().iter().map(map).collect())
            .unwrap();
        let moved = prolong(&coarse, &solved, &fine).unwrap();
        for (v, (p, q)) in fine.positions().iter().zip(&moved).enumerate() {
            let expected = if fine.flags()[v].fixed { *p } else { map(p) };
            assert!(
                (expected - q).norm() < 1e-14,
                "vertex {v}: {expected} vs {q}"
            );
        }
    }

    #[test]
    fn mismatched_coarse_meshes_are_refused() {
        let coarse = generators::cube_frame(0.05, None, 2).unwrap().mesh;
        let other = generators::cube_frame(0.05, None, 3).unwrap().mesh;
        assert_eq!(
            prolong(&coarse, &other, &other),
            Err(ProlongError::Mismatch)
        );
    }
}
