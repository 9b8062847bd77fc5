//! Uniform k-fold subdivision of a triangle mesh (coarse-to-fine starts).
//!
//! Every edge is cut into `k` equal segments and every triangle `(a, b, c)` into `k²` triangles
//! on the barycentric grid `P(i, j) = a + (i/k)(b − a) + (j/k)(c − a)`, `i, j ≥ 0, i + j ≤ k`,
//! each keeping the orientation and surface of its parent. Vertices on a shared edge are made
//! once, so junction edges (three or more triangles) stay junctions and surfaces stay
//! connected. The new points lie in the parent triangles' planes: the area is unchanged, and the
//! new vertices are flat (H = 0 at vertices inside a parent triangle).
//!
//! Flags: old vertices keep theirs. A new vertex on a boundary edge (one triangle) whose ends
//! are both fixed is fixed (a straight wire segment, such as the octahedral frame's: the point
//! lies exactly on the wire); every other new vertex is free. Meshes with guided vertices are
//! refused, since a point between two guided vertices is not on their curve in general.

use std::collections::HashMap;

use super::mesh::{Mesh, MeshBuilder, MeshError, VertexFlags};

/// Why a mesh was not subdivided.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SubdivideError {
    /// The factor must be at least 1.
    #[error("subdivision factor must be at least 1")]
    ZeroFactor,
    /// Guided vertices are not supported.
    #[error("meshes with guided vertices are not subdivided")]
    Guided,
    /// The subdivided mesh is invalid.
    #[error(transparent)]
    Mesh(#[from] MeshError),
}

/// The mesh with every triangle cut into `k²` (see the module header); `k = 1` copies it.
pub fn subdivide(mesh: &Mesh, k: usize) -> Result<Mesh, SubdivideError> {
    if k == 0 {
        return Err(SubdivideError::ZeroFactor);
    }
    if !mesh.guides().is_empty() {
        return Err(SubdivideError::Guided);
    }
    let mut b = MeshBuilder::new();
    let surfaces: Vec<usize> = mesh.surfaces().iter().map(|s| b.surface(s)).collect();
    let pos = mesh.positions();
    for (v, &p) in pos.iter().enumerate() {
        b.vertex_with(p, mesh.flags()[v]);
    }
    // The k − 1 inner points of each edge, ordered from its lower to its higher vertex index.
    let mut edge_points: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
    for edge in mesh.edges() {
        let [p, q] = edge.vertices;
        let (lo, hi) = (p.min(q), p.max(q));
        let wire = edge.triangles.len() == 1 && mesh.flags()[lo].fixed && mesh.flags()[hi].fixed;
        let flags = VertexFlags {
            fixed: wire,
            ..Default::default()
        };
        let points = (1..k)
            .map(|i| {
                let t = i as f64 / k as f64;
                b.vertex_with(pos[lo] + (pos[hi] - pos[lo]) * t, flags)
            })
            .collect();
        edge_points.insert((lo, hi), points);
    }
    // Grid point `(i, j)` of edge `p → q` at step `s` from p.
    let on_edge = |p: usize, q: usize, s: usize| -> usize {
        if s == 0 {
            return p;
        }
        if s == k {
            return q;
        }
        let points = &edge_points[&(p.min(q), p.max(q))];
        if p < q {
            points[s - 1]
        } else {
            points[k - 1 - s]
        }
    };
    for (t, &[a, bv, c]) in mesh.triangles().iter().enumerate() {
        let mut grid = vec![usize::MAX; (k + 1) * (k + 1)];
        let at = |i: usize, j: usize| i * (k + 1) + j;
        for i in 0..=k {
            for j in 0..=(k - i) {
                grid[at(i, j)] = if j == 0 {
                    on_edge(a, bv, i)
                } else if i == 0 {
                    on_edge(a, c, j)
                } else if i + j == k {
                    on_edge(bv, c, j)
                } else {
                    let (s, u) = (i as f64 / k as f64, j as f64 / k as f64);
                    b.vertex(pos[a] + (pos[bv] - pos[a]) * s + (pos[c] - pos[a]) * u)
                };
            }
        }
        let s = surfaces[mesh.triangle_surface()[t]];
        for i in 0..k {
            for j in 0..(k - i) {
                b.triangle(s, [grid[at(i, j)], grid[at(i + 1, j)], grid[at(i, j + 1)]]);
                if i + j + 1 < k {
                    b.triangle(
                        s,
                        [
                            grid[at(i + 1, j)],
                            grid[at(i + 1, j + 1)],
                            grid[at(i, j + 1)],
                        ],
                    );
                }
            }
        }
    }
    Ok(b.build()?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::area::{area_vector, total_area};
    use crate::cmc::mesh::Point;

    /// Two films on a fixed wire square sharing a diagonal with a third (a junction edge).
    fn junction_mesh() -> Mesh {
        let mut b = MeshBuilder::new();
        let s = b.surface("a");
        let t = b.surface("b");
        let p = [
            b.fixed(Point::new(0.0, 0.0, 0.0)),
            b.fixed(Point::new(1.0, 0.0, 0.0)),
            b.vertex(Point::new(1.0, 1.0, 0.1)),
            b.fixed(Point::new(0.0, 1.0, 0.0)),
            b.fixed(Point::new(0.5, 0.5, 1.0)),
        ];
        b.triangle(s, [p[0], p[1], p[2]]);
        b.triangle(s, [p[0], p[2], p[3]]);
        b.triangle(t, [p[0], p[4], p[2]]);
        b.build().unwrap()
    }

    #[test]
    fn keeps_area_orientation_and_counts() {
        let m = junction_mesh();
        for k in 1..=4 {
            let s = subdivide(&m, k).unwrap();
            assert_eq!(s.triangles().len(), m.triangles().len() * k * k);
            // V' = V + E (k − 1) + T (k − 1)(k − 2) / 2.
            let expected = m.vertex_count()
                + m.edges().len() * (k - 1)
                + m.triangles().len() * (k - 1) * (k - 2) / 2;
            assert_eq!(s.vertex_count(), expected, "k = {k}");
            assert!((total_area(&s) - total_area(&m)).abs() < 1e-12);
            // Each child faces the way of its parent (k² children per parent, in order).
            for (t, child) in s.triangles().iter().enumerate() {
                let parent = area_vector(&m.corners(t / (k * k)));
                let own = area_vector(&child.map(|v| s.positions()[v]));
                assert!(own.dot(&parent) > 0.0);
                assert_eq!(s.triangle_surface()[t], m.triangle_surface()[t / (k * k)]);
            }
        }
    }

    #[test]
    fn wire_points_fixed_and_junctions_kept() {
        let m = junction_mesh();
        let s = subdivide(&m, 3).unwrap();
        // Boundary edges with both ends fixed: 0-1 and 0-3 (1-2, 2-3 have a free end; 0-4 and
        // 4-2 are the third film's boundary, 0-4 with both ends fixed).
        let fixed = s.flags().iter().filter(|f| f.fixed).count();
        assert_eq!(fixed, 4 + 3 * 2);
        let junction = |mesh: &Mesh| {
            mesh.edges()
                .iter()
                .filter(|e| e.triangles.len() == 3)
                .count()
        };
        assert_eq!(junction(&m), 1);
        assert_eq!(junction(&s), 3);
        assert!(matches!(subdivide(&m, 0), Err(SubdivideError::ZeroFactor)));
    }
}
