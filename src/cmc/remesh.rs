//! Equiangulation between solve rounds: Delaunay edge flips within each surface.
//!
//! An edge shared by exactly two triangles of the same surface, `(a, b, c)` and `(b, a, d)`, is
//! flipped to `(c, a, d)`, `(d, b, c)` when the angles opposite it sum to more than π (the
//! intrinsic Delaunay criterion) and the quadrilateral `a, d, b, c` is convex enough that both
//! new triangles face the way the old pair did. Boundary, junction and wire edges (one, three
//! or more triangles, or two triangles of different surfaces) never flip, so wires, junction
//! lines and surface membership are kept; vertices and their indices do not change. Flipping
//! raises the smallest angle of the pair and makes the cotangent weights positive, which keeps
//! the curvature operator well behaved; it changes the area of a curved mesh only at the
//! order of the mesh's deviation from its surface.

use std::collections::BTreeSet;

use super::area::area_vector;
use super::mesh::{Mesh, MeshError, Point};

/// Flips non-Delaunay edges until none is left or `max_passes` passes are done; returns the
/// new mesh and the number of flips.
pub fn equiangulate(mesh: &Mesh, max_passes: usize) -> Result<(Mesh, usize), MeshError> {
    let mut triangles = mesh.triangles().to_vec();
    let surface = mesh.triangle_surface();
    let pos = mesh.positions();
    let mut flips = 0;
    for _ in 0..max_passes {
        let current = Mesh::new(
            pos.to_vec(),
            triangles.clone(),
            surface.to_vec(),
            mesh.surfaces().to_vec(),
            mesh.flags().to_vec(),
            mesh.guides().to_vec(),
        )?;
        let mut touched: BTreeSet<usize> = BTreeSet::new();
        let mut edges: BTreeSet<[usize; 2]> = current.edges().iter().map(|e| e.vertices).collect();
        let mut pass_flips = 0;
        for edge in current.edges() {
            let &[t1, t2] = edge.triangles.as_slice() else {
                continue;
            };
            if surface[t1] != surface[t2] || touched.contains(&t1) || touched.contains(&t2) {
                continue;
            }
            let Some((a, b, c)) = ordered(triangles[t1], edge.vertices) else {
                continue;
            };
            let Some((b2, a2, d)) = ordered(triangles[t2], [b, a]) else {
                continue;
            };
            // Inconsistent orientation across the edge: leave it alone.
            if (a2, b2) != (a, b) {
                continue;
            }
            let new_edge = [c.min(d), c.max(d)];
            if edges.contains(&new_edge) {
                continue;
            }
            let angle =
                |apex: usize, p: usize, q: usize| (pos[p] - pos[apex]).angle(&(pos[q] - pos[apex]));
            if angle(c, a, b) + angle(d, a, b) <= std::f64::consts::PI + 1e-12 {
                continue;
            }
            let old: Point =
                area_vector(&[pos[a], pos[b], pos[c]]) + area_vector(&[pos[b], pos[a], pos[d]]);
            let n1 = area_vector(&[pos[c], pos[a], pos[d]]);
            let n2 = area_vector(&[pos[d], pos[b], pos[c]]);
            if n1.dot(&old) <= 0.0 || n2.dot(&old) <= 0.0 {
                continue;
            }
            triangles[t1] = [c, a, d];
            triangles[t2] = [d, b, c];
            edges.remove(&edge.vertices);
            edges.insert(new_edge);
            touched.insert(t1);
            touched.insert(t2);
            pass_flips += 1;
        }
        flips += pass_flips;
        if pass_flips == 0 {
            break;
        }
    }
    let out = Mesh::new(
        pos.to_vec(),
        triangles,
        surface.to_vec(),
        mesh.surfaces().to_vec(),
        mesh.flags().to_vec(),
        mesh.guides().to_vec(),
    )?;
    Ok((out, flips))
}

/// Triangle `tri` rotated to `(first, second, third)` if it contains the directed edge
/// `edge[0] → edge[1]`, or the reverse edge (then rotated to start at `edge[1]`).
fn ordered(tri: [usize; 3], edge: [usize; 2]) -> Option<(usize, usize, usize)> {
    for k in 0..3 {
        let (p, q, r) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
        if (p, q) == (edge[0], edge[1]) || (p, q) == (edge[1], edge[0]) {
            return Some((p, q, r));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::area::total_area;
    use crate::cmc::figures::quality;
    use crate::cmc::mesh::MeshBuilder;

    #[test]
    fn a_non_delaunay_pair_is_flipped() {
        // Two flat triangles sharing the long diagonal of a rhombus.
        let mut b = MeshBuilder::new();
        let s = b.surface("film");
        let a = b.fixed(Point::new(-2.0, 0.0, 0.0));
        let c = b.fixed(Point::new(0.0, 0.0, -0.5));
        let bb = b.fixed(Point::new(2.0, 0.0, 0.0));
        let d = b.fixed(Point::new(0.0, 0.0, 0.5));
        b.triangle(s, [a, bb, c]);
        b.triangle(s, [bb, a, d]);
        let mesh = b.build().unwrap();
        let before = quality(&mesh).min_angle_deg;
        let (flipped, flips) = equiangulate(&mesh, 5).unwrap();
        assert_eq!(flips, 1);
        assert!(
            flipped
                .edges()
                .iter()
                .any(|e| e.vertices == [c.min(d), c.max(d)])
        );
        assert!(quality(&flipped).min_angle_deg > before);
        // Orientation kept: same total area vector, and a flat pair keeps its area.
        let normal = |m: &Mesh| -> Point {
            (0..m.triangles().len())
                .map(|t| area_vector(&m.corners(t)))
                .sum()
        };
        assert!((normal(&mesh) - normal(&flipped)).norm() < 1e-12);
        assert!((total_area(&mesh) - total_area(&flipped)).abs() < 1e-12);
        // A Delaunay mesh is left alone.
        let (again, flips) = equiangulate(&flipped, 5).unwrap();
        assert_eq!(flips, 0);
        assert_eq!(again.triangles(), flipped.triangles());
    }

    #[test]
    fn junctions_and_boundaries_never_flip() {
        let shape = crate::cmc::generators::double_bubble([1.0, 2.0], 4).unwrap();
        let mut rng = crate::cmc::testing::rng(31);
        let mesh = crate::cmc::testing::perturbed(&shape.mesh, 0.3, &mut rng);
        let (flipped, flips) = equiangulate(&mesh, 10).unwrap();
        assert!(flips > 0);
        let junction = |m: &Mesh| -> Vec<[usize; 2]> {
            m.edges()
                .iter()
                .filter(|e| e.triangles.len() >= 3)
                .map(|e| e.vertices)
                .collect()
        };
        assert_eq!(junction(&mesh), junction(&flipped));
        assert!(quality(&flipped).min_angle_deg >= quality(&mesh).min_angle_deg);
        // Volumes are sums over closed surfaces and stay consistent after flips.
        for (_, region, _) in &shape.volumes {
            let (v0, v1) = (region.volume(&mesh), region.volume(&flipped));
            assert!((v0 - v1).abs() < 0.05 * v0, "{v0} vs {v1}");
        }
    }
}
