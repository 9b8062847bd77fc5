//! Mesh improvement between solve rounds: Delaunay edge flips within each surface
//! ([`equiangulate`]) and refinement of stretched regions ([`split_long_edges`]).
//!
//! Flips. An edge shared by exactly two triangles of the same surface, `(a, b, c)` and
//! `(b, a, d)`, is flipped to `(c, a, d)`, `(d, b, c)` when the angles opposite it sum to more
//! than π (the intrinsic Delaunay criterion) and the quadrilateral `a, d, b, c` is convex enough
//! that both new triangles face the way the old pair did. Boundary, junction and wire edges
//! (one, three or more triangles, or two triangles of different surfaces) never flip, so wires,
//! junction lines and surface membership are kept; vertices and their indices do not change.
//! Flipping raises the smallest angle of the pair and makes the cotangent weights positive,
//! which keeps the curvature operator well behaved; it changes the area of a curved mesh only at
//! the order of the mesh's deviation from its surface.
//!
//! Splits. An edge longer than a given length gets a new vertex at its midpoint, and each
//! triangle `(a, b, c)` on it becomes `(a, m, c)`, `(m, b, c)` in the same surface and
//! orientation (a junction edge splits all its triangles, so junction lines stay shared). On an
//! edge inside a surface the new vertex goes to Loop's subdivision point `3/8 (a + b) +
//! 1/8 (c + d)` (c, d opposite): on a flat region that is in the plane (area unchanged
//! exactly), on a curved one it moves off the chord by O(h²) towards the smooth surface, so
//! the area changes only at second order while the new vertices' curvature rows start near
//! the surface's value (a midpoint would be flat there: a large start violation). Boundary and
//! junction edges get their midpoint, so each surface's boundary polygon and hence its vector
//! area `½∮ x × dx` are exactly unchanged. Refinement adds freedom where the solve stretched
//! the mesh (around tent poles, say). Old vertices keep
//! their indices (chords stay valid); new ones are appended. Flags: the new vertex is free and
//! carries a curvature constraint unless both ends are excluded. Edges between two fixed
//! vertices (wires, pole caps, rims) are never split, and neither are boundary edges unless
//! both ends are free with the same guide (or none), which the midpoint then inherits: a film
//! never comes loose from what holds it.

use std::collections::HashSet;

use super::area::area_vector;
use super::mesh::{Mesh, MeshError, Point, VertexFlags};

/// Flips non-Delaunay edges until none is left or `max_passes` passes are done; returns the
/// new mesh and the number of flips.
pub fn equiangulate(mesh: &Mesh, max_passes: usize) -> Result<(Mesh, usize), MeshError> {
    let mut triangles = mesh.triangles().to_vec();
    let surface = mesh.triangle_surface();
    let pos = mesh.positions();
    let mut flips = 0;
    // The mesh of the current triangles, once a pass has flipped any (before: `mesh` itself).
    let mut flipped: Option<Mesh> = None;
    for _ in 0..max_passes {
        let current = flipped.as_ref().unwrap_or(mesh);
        let mut touched = vec![false; triangles.len()];
        // The pass's edges: the mesh's (its sorted neighbour lists), less those flipped away,
        // plus the new diagonals (a diagonal's triangles are touched, so it is not flipped
        // away in the same pass).
        let (mut added, mut removed) = (HashSet::new(), HashSet::new());
        let mut pass_flips = 0;
        for edge in current.edges() {
            let &[t1, t2] = edge.triangles.as_slice() else {
                continue;
            };
            if surface[t1] != surface[t2] || touched[t1] || touched[t2] {
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
            let in_mesh = current.neighbours(c).binary_search(&d).is_ok();
            if (in_mesh && !removed.contains(&new_edge)) || added.contains(&new_edge) {
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
            removed.insert(edge.vertices);
            added.insert(new_edge);
            touched[t1] = true;
            touched[t2] = true;
            pass_flips += 1;
        }
        flips += pass_flips;
        if pass_flips == 0 {
            break;
        }
        flipped = Some(Mesh::new(
            pos.to_vec(),
            triangles.clone(),
            surface.to_vec(),
            mesh.surfaces().to_vec(),
            mesh.flags().to_vec(),
            mesh.guides().to_vec(),
        )?);
    }
    Ok((flipped.unwrap_or_else(|| mesh.clone()), flips))
}

/// Splits, in order of decreasing length, the edges longer than `max_length` (m) that may be
/// split (module header), at most one per triangle per pass, for up to `max_passes` passes;
/// returns the new mesh and the number of splits.
pub fn split_long_edges(
    mesh: &Mesh,
    max_length: f64,
    max_passes: usize,
) -> Result<(Mesh, usize), MeshError> {
    let mut current = mesh.clone();
    let mut splits = 0;
    for _ in 0..max_passes {
        let pos = current.positions().to_vec();
        let flags = current.flags();
        let mut candidates: Vec<(f64, usize)> = current
            .edges()
            .iter()
            .enumerate()
            .filter_map(|(k, e)| {
                let [a, b] = e.vertices;
                let length = (pos[a] - pos[b]).norm();
                (length > max_length && splittable(&flags[a], &flags[b], e.triangles.len()))
                    .then_some((length, k))
            })
            .collect();
        if candidates.is_empty() {
            break;
        }
        candidates.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
        let mut triangles = current.triangles().to_vec();
        let mut surface = current.triangle_surface().to_vec();
        let mut positions = pos.clone();
        let mut new_flags = flags.to_vec();
        let mut touched = vec![false; triangles.len()];
        for (_, k) in candidates {
            let edge = &current.edges()[k];
            if edge.triangles.iter().any(|&t| touched[t]) {
                continue;
            }
            let [a, b] = edge.vertices;
            let m = positions.len();
            positions.push(new_position(&current, &pos, edge));
            let (fa, fb) = (flags[a], flags[b]);
            new_flags.push(VertexFlags {
                fixed: false,
                excluded: fa.excluded && fb.excluded,
                guide: if edge.triangles.len() == 1 {
                    fa.guide
                } else {
                    None
                },
            });
            for &t in &edge.triangles {
                let Some((p, q, r)) = ordered(triangles[t], [a, b]) else {
                    continue;
                };
                touched[t] = true;
                triangles[t] = [p, m, r];
                triangles.push([m, q, r]);
                surface.push(surface[t]);
                touched.push(true);
            }
            splits += 1;
        }
        let next = Mesh::new(
            positions,
            triangles,
            surface,
            current.surfaces().to_vec(),
            new_flags,
            current.guides().to_vec(),
        );
        current = next?;
    }
    Ok((current, splits))
}

/// Where the new vertex on `edge` goes: Loop's subdivision rule `3/8 (a + b) + 1/8 (c + d)`
/// on an edge with two triangles (opposite vertices c, d), which lands near the smooth surface
/// through the mesh, so the new vertex's curvature row starts close to the others; the
/// midpoint on boundary and junction edges, which stay on their curves.
fn new_position(mesh: &Mesh, pos: &[Point], edge: &super::mesh::Edge) -> Point {
    let [a, b] = edge.vertices;
    let opposite: Vec<usize> = edge
        .triangles
        .iter()
        .filter_map(|&t| ordered(mesh.triangles()[t], [a, b]).map(|(_, _, r)| r))
        .collect();
    match opposite.as_slice() {
        &[c, d] => (pos[a] + pos[b]) * 0.375 + (pos[c] + pos[d]) * 0.125,
        _ => (pos[a] + pos[b]) / 2.0,
    }
}

/// Whether an edge with end flags `a`, `b` and `triangles` triangles may be split.
fn splittable(a: &VertexFlags, b: &VertexFlags, triangles: usize) -> bool {
    if a.fixed && b.fixed {
        return false;
    }
    triangles != 1 || (!a.fixed && !b.fixed && a.guide == b.guide)
}

/// Triangle `tri` rotated to `(first, second, third)` if it contains the directed edge
/// `edge[0] → edge[1]`, or the reverse edge (then rotated to start at `edge[1]`).
pub(super) fn ordered(tri: [usize; 3], edge: [usize; 2]) -> Option<(usize, usize, usize)> {
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

    #[test]
    fn splits_keep_geometry_junctions_and_flags() {
        let shape = crate::cmc::generators::double_bubble([1.0, 2.0], 4).unwrap();
        let mut rng = crate::cmc::testing::rng(7);
        let mesh = crate::cmc::testing::perturbed(&shape.mesh, 0.2, &mut rng);
        let lengths = mesh.sorted_edge_lengths();
        let median = lengths[lengths.len() / 2];
        let (split, splits) = split_long_edges(&mesh, median, 1).unwrap();
        assert!(splits > 0);
        let n = mesh.vertex_count();
        assert_eq!(split.vertex_count(), n + splits);
        // Old vertices keep their indices, positions and flags; new ones are free.
        assert_eq!(&split.positions()[..n], mesh.positions());
        assert_eq!(&split.flags()[..n], mesh.flags());
        assert!(split.flags()[n..].iter().all(|f| !f.fixed));
        // The boundary polygons, and so each surface's vector area ½∮ x × dx, are unchanged.
        for s in 0..mesh.surfaces().len() {
            let sum = |m: &Mesh| -> Point {
                m.surface_triangles(s)
                    .map(|t| area_vector(&m.corners(t)))
                    .sum()
            };
            assert!((sum(&split) - sum(&mesh)).norm() < 1e-12);
        }
        // Junction lines stay shared: as many junction vertices as before plus the split
        // junction edges' midpoints, each a junction vertex again.
        let junction_edges = |m: &Mesh| m.edges().iter().filter(|e| e.triangles.len() >= 3).count();
        let new_junction = (n..split.vertex_count())
            .filter(|&v| split.junction_vertices().contains(&v))
            .count();
        assert_eq!(junction_edges(&split), junction_edges(&mesh) + new_junction);
        assert_eq!(
            split.junction_vertices().len(),
            mesh.junction_vertices().len() + new_junction
        );
        assert!(split.sorted_edge_lengths().last() <= lengths.last());
    }

    #[test]
    fn refined_tents_keep_rims_and_pole_caps() {
        let t = crate::cmc::generators::tents(
            &[crate::cmc::generators::TentSpec {
                name: "roof".into(),
                boundary: (0..8)
                    .map(|k| {
                        let a = 2.0 * std::f64::consts::PI * k as f64 / 8.0;
                        Point::new(5.0 * a.cos(), 1.0, -5.0 * a.sin())
                    })
                    .collect(),
                poles: vec![crate::cmc::generators::Pole {
                    at: [0.0, 0.0],
                    height: 3.0,
                    radius: 0.8,
                }],
            }],
            4,
        )
        .unwrap();
        let mesh = t.mesh;
        let fixed_edges = |m: &Mesh| -> Vec<[usize; 2]> {
            m.edges()
                .iter()
                .filter(|e| m.flags()[e.vertices[0]].fixed && m.flags()[e.vertices[1]].fixed)
                .map(|e| e.vertices)
                .collect()
        };
        // Edges between fixed vertices are never split, so the edges of their triangles stay
        // at least half as long as they are: refine to the longest of them.
        let p = mesh.positions();
        let limit = fixed_edges(&mesh)
            .iter()
            .map(|&[a, b]| (p[a] - p[b]).norm())
            .fold(0.0, f64::max);
        assert!(limit < *mesh.sorted_edge_lengths().last().unwrap());
        let (split, splits) = split_long_edges(&mesh, limit, 20).unwrap();
        assert!(splits > 0);
        // Rim and caps untouched; the film still hangs from them (no new boundary edges).
        assert_eq!(fixed_edges(&split), fixed_edges(&mesh));
        let boundary = |m: &Mesh| m.edges().iter().filter(|e| e.triangles.len() == 1).count();
        assert_eq!(boundary(&split), boundary(&mesh));
        assert!((total_area(&split) - total_area(&mesh)).abs() < 1e-2 * total_area(&mesh));
        // Every edge that may be split is now short enough.
        let p = split.positions();
        for e in split.edges() {
            let [a, b] = e.vertices;
            let (fa, fb) = (split.flags()[a], split.flags()[b]);
            if splittable(&fa, &fb, e.triangles.len()) {
                assert!((p[a] - p[b]).norm() <= limit);
            }
        }
    }

    #[test]
    fn refinement_changes_area_and_volume_at_second_order() {
        // Split every edge of the exact double bubble once: the new vertices sit O(h²) off the
        // old triangles, so the relative changes fall about 4× when h halves.
        let mut changes = Vec::new();
        for levels in [4, 8] {
            let shape = crate::cmc::generators::double_bubble([1.0, 2.0], levels).unwrap();
            let mesh = &shape.mesh;
            let (split, splits) = split_long_edges(mesh, 0.0, 1).unwrap();
            assert!(splits > 0);
            let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
            let volume = shape
                .volumes
                .iter()
                .map(|(_, r, _)| rel(r.volume(&split), r.volume(mesh)))
                .fold(0.0, f64::max);
            changes.push((rel(total_area(&split), total_area(mesh)), volume));
        }
        let (a, b) = (changes[0], changes[1]);
        assert!(a.0 / b.0 > 3.0 && a.1 / b.1 > 3.0, "{changes:?}");
        assert!(b.0 < 1e-2 && b.1 < 1e-2, "{changes:?}");
    }
}
