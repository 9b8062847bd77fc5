//! Start meshes for the stable soap films on a regular octahedral wire frame (seed Fig. 5.9).
//!
//! The frame's eight triangular faces are windows; a spanning film divides the octahedron into
//! eight cells, one per window. The conical film (every wire joined to the centre) has six
//! quadruple lines (centre to corner), each of which a stable film resolves into two triple
//! lines joined by a new film between two opposite cells around that corner. The resolutions
//! give five stable films, named after their central film: tetrahedral (all films flat, the
//! least area, 2√2·edge²), square, quadrilateral, pentagon and hexagon. A film of one topology
//! cannot turn into another during the optimization, so each needs a start of its own.
//!
//! The starts are weighted window partitions: the point x inside the frame belongs to the cell of
//! window f minimizing `λ_f·d_f(x)`, with `d_f` the distance to window f's plane (m). Since the
//! `d_f` are affine, the cells are convex polyhedra and every wall is a planar convex polygon
//! on the plane `λ_f·d_f = λ_g·d_g`; the wall between two windows sharing a wire contains the
//! whole wire (both distances vanish there). Equal weights give the cone; the weights of
//! [`window_weights`] were chosen (by a search over weights in [1, 3], keeping the partition
//! of the wanted topology with the longest shortest wall edge) to give each stable topology.
//! Each wall is meshed as a fan of triangle patches around its centroid, `levels` segments on
//! every wall edge and spoke; walls share their edge vertices.
//!
//! The partitions' flat walls meet at 75°–160° rather than the films' 120°, so at fine
//! resolutions the junction lines would have to cross many rows of triangles during the solve;
//! the problem files therefore start from resolution 1 and refine ([`super::multilevel`]).

use super::generators::{Shape, add_path, add_triangle_patch};
use super::mesh::{Mesh, MeshBuilder, MeshError, Point};
use super::polygon_complex::{
    Polygon, clip, distinct_corners, fan_mesh, plane_square, smooth_within_walls,
};
use super::remesh::equiangulate;

/// Film topologies on the octahedral frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OctahedronTopology {
    /// Every wire joined by a triangular film to one central vertex (unstable: six quadruple
    /// lines).
    Cone,
    /// Four flat triangles meeting at a central tetrahedral point via six flat kites.
    Tetrahedral,
    /// A central square film.
    Square,
    /// A central quadrilateral film.
    Quadrilateral,
    /// A central pentagonal film.
    Pentagon,
    /// A central hexagonal film (between two opposite windows).
    Hexagon,
}

/// The window of index k: the face with outward normal (sx, sy, sz)/√3, s = +1 where bits
/// 2, 1, 0 of k are clear.
fn window_normal(k: usize) -> Point {
    let sign = |bit: usize| if k & bit == 0 { 1.0 } else { -1.0 };
    Point::new(sign(4), sign(2), sign(1)) / 3f64.sqrt()
}

/// Weights λ of the eight windows (order of `window_normal`) whose partition has the
/// topology's walls; `None` for the cone (equal weights meet at one point).
pub fn window_weights(topology: OctahedronTopology) -> Option<[f64; 8]> {
    match topology {
        OctahedronTopology::Cone => None,
        // Even windows (sx·sy·sz = 1) heavier: the odd cells meet at the centre. At ratio 5/3
        // the partition is the exact film; 2.5 starts away from it.
        OctahedronTopology::Tetrahedral => Some([2.5, 1.0, 1.0, 2.5, 1.0, 2.5, 2.5, 1.0]),
        OctahedronTopology::Square => Some([1.1, 1.4, 1.4, 2.9, 2.6, 1.7, 1.6, 1.6]),
        OctahedronTopology::Quadrilateral => Some([2.5, 1.1, 3.0, 1.7, 1.0, 2.4, 2.3, 2.8]),
        OctahedronTopology::Pentagon => Some([1.0, 1.4, 2.9, 1.3, 2.3, 2.8, 2.4, 1.6]),
        OctahedronTopology::Hexagon => Some([2.5, 1.0, 2.9, 2.7, 2.7, 2.3, 1.3, 2.9]),
    }
}

/// The walls of the weighted window partition of the octahedron with vertices at
/// ±`half_diagonal` on the axes (m): `(f, g, polygon)` for every pair of windows whose wall
/// has positive area, corners in order.
pub fn partition_walls(half_diagonal: f64, weights: &[f64; 8]) -> Vec<(usize, usize, Vec<Point>)> {
    let c = half_diagonal / 3f64.sqrt();
    // φ_f(x) = λ_f (c − n_f·x) = λ_f d_f(x); φ_f ≤ φ_h ⇔ (λ_h n_h − λ_f n_f)·x ≤ (λ_h − λ_f) c.
    let le = |f: usize, h: usize| {
        (
            weights[h] * window_normal(h) - weights[f] * window_normal(f),
            (weights[h] - weights[f]) * c,
        )
    };
    let tolerance = 1e-9 * half_diagonal;
    let mut walls = Vec::new();
    for (f, &weight_f) in weights.iter().enumerate() {
        for g in (f + 1)..8 {
            let (a, b) = le(f, g);
            let mut poly = plane_square(&a, b, &Point::zeros(), 4.0 * half_diagonal);
            for h in (0..8).filter(|&h| h != f && h != g) {
                let (a, b) = le(f, h);
                poly = clip(&poly, &a, b);
            }
            // Inside the frame: φ_f ≥ 0.
            poly = clip(&poly, &(weight_f * window_normal(f)), weight_f * c);
            let min_area = 1e-6 * half_diagonal.powi(2);
            if let Some(corners) = distinct_corners(poly, tolerance, min_area) {
                walls.push((f, g, corners));
            }
        }
    }
    walls
}

/// A wire octahedron with edges of length `edge` (m, centred at the origin, vertices on the
/// axes), fixed wires, with the films of `topology` in one surface `films`; `levels` segments
/// per wire (and per wall edge and spoke).
pub fn octahedron_frame(
    edge: f64,
    topology: OctahedronTopology,
    levels: usize,
) -> Result<Shape, MeshError> {
    match window_weights(topology) {
        None => cone(edge, levels),
        Some(weights) => partition_film(edge, &weights, levels),
    }
}

/// Every wire joined by a triangle patch to the centre.
fn cone(edge: f64, levels: usize) -> Result<Shape, MeshError> {
    let n = levels.max(1);
    let s = edge / 2f64.sqrt();
    let mut b = MeshBuilder::new();
    let films = b.surface("films");
    let axes = [
        Point::x(),
        -Point::x(),
        Point::y(),
        -Point::y(),
        Point::z(),
        -Point::z(),
    ];
    let corners: Vec<usize> = axes.iter().map(|d| b.fixed(d * s)).collect();
    let centre = b.vertex(Point::zeros());
    let spokes: Vec<Vec<usize>> = corners
        .iter()
        .map(|&c| add_path(&mut b, (centre, c), n, false))
        .collect();
    for i in 0..6 {
        for j in (i + 1)..6 {
            // Opposite vertices (i, i^1) share no wire.
            if j == (i ^ 1) {
                continue;
            }
            let wire = add_path(&mut b, (corners[i], corners[j]), n, true);
            add_triangle_patch(&mut b, films, &spokes[i], &spokes[j], &wire);
        }
    }
    Ok(Shape {
        mesh: b.build()?,
        volumes: Vec::new(),
    })
}

/// The weighted window partition's film on a wire octahedron of edge `edge` (m) with window
/// weights `weights`; wires fixed, one surface `films`, `levels` segments per wall edge.
pub fn partition_film(edge: f64, weights: &[f64; 8], levels: usize) -> Result<Shape, MeshError> {
    // The fans of walls with short edges are slivers (`levels` segments on every edge, however
    // short, so every sub-triangle is similar to its thin fan triangle), which the tangential
    // regularization cannot repair during the solve (the films' triangles collapse). Smoothing
    // within each planar wall alternated with Delaunay flips grades them; the area stays exact.
    let mut mesh = partition_fans(edge, weights, levels)?;
    for _ in 0..START_SMOOTHING_ROUNDS {
        smooth_within_walls(&mut mesh)?;
        mesh = equiangulate(&mesh, 1)?.0;
    }
    Ok(Shape {
        mesh,
        volumes: Vec::new(),
    })
}

/// Rounds of smoothing and flipping applied to a partition start.
const START_SMOOTHING_ROUNDS: usize = 30;

/// The partition's walls, each meshed as a fan of triangle patches around its centroid.
fn partition_fans(edge: f64, weights: &[f64; 8], levels: usize) -> Result<Mesh, MeshError> {
    let half = edge / 2f64.sqrt();
    let polygons: Vec<Polygon> = partition_walls(half, weights)
        .into_iter()
        .map(|(_, _, corners)| Polygon {
            surface: 0,
            up: None,
            corners,
        })
        .collect();
    let tolerance = 1e-7 * half;
    let is_frame_vertex =
        |p: &Point| (p.abs().max() - half).abs() < tolerance && p.norm() > 0.9 * half;
    fan_mesh(
        &["films".into()],
        &polygons,
        levels,
        tolerance,
        is_frame_vertex,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::area::total_area;
    use crate::cmc::figures::quality;
    use crate::cmc::polygon_complex::polygon_area;

    const STABLE: [OctahedronTopology; 5] = [
        OctahedronTopology::Tetrahedral,
        OctahedronTopology::Square,
        OctahedronTopology::Quadrilateral,
        OctahedronTopology::Pentagon,
        OctahedronTopology::Hexagon,
    ];

    fn touches_frame_vertex(poly: &[Point], half: f64) -> bool {
        poly.iter()
            .any(|p| (p.abs().max() - half).abs() < 1e-9 && p.norm() > 0.9 * half)
    }

    #[test]
    fn partitions_have_the_named_central_films() {
        let half = 1.0 / 2f64.sqrt();
        for (topology, walls, central) in [
            (OctahedronTopology::Tetrahedral, 18, None),
            (OctahedronTopology::Square, 19, Some(4)),
            (OctahedronTopology::Quadrilateral, 19, Some(4)),
            (OctahedronTopology::Pentagon, 19, Some(5)),
            (OctahedronTopology::Hexagon, 19, Some(6)),
        ] {
            let w = partition_walls(half, &window_weights(topology).unwrap());
            assert_eq!(w.len(), walls, "{topology:?}");
            let inner: Vec<usize> = w
                .iter()
                .filter(|(_, _, p)| !touches_frame_vertex(p, half))
                .map(|(_, _, p)| p.len())
                .collect();
            assert_eq!(inner.first().copied(), central, "{topology:?}: {inner:?}");
            assert!(inner.len() <= 1, "{topology:?}");
            // All twelve wires carry a wall (the twelve pairs of windows sharing a wire).
            let wires = w
                .iter()
                .filter(|(f, g, _)| (f ^ g).count_ones() == 1)
                .count();
            assert_eq!(wires, 12, "{topology:?}");
        }
    }

    #[test]
    fn tetrahedral_partition_at_ratio_five_thirds_is_the_flat_film() {
        // The least-area film has area 2√2 for unit edges; the weighted partition with even
        // windows 5/3 as heavy as odd ones has exactly its planes.
        let half = 1.0 / 2f64.sqrt();
        let mut w = [1.0; 8];
        for (k, wk) in w.iter_mut().enumerate() {
            if (k.count_ones() % 2) == 0 {
                *wk = 5.0 / 3.0;
            }
        }
        let area: f64 = partition_walls(half, &w)
            .iter()
            .map(|(_, _, p)| polygon_area(p))
            .sum();
        assert!((area - 2.0 * 2f64.sqrt()).abs() < 1e-9, "{area}");
    }

    #[test]
    fn flat_film_junction_angles_measure_120_degrees() {
        // The exact tetrahedral film (weights 5/3 : 1): every triple edge at 120°, also where
        // the third vertex of a triangle lies on another junction line (all the films are one
        // surface, so a tangent fit must not reach across a junction into another film).
        let mut w = [1.0; 8];
        for (k, wk) in w.iter_mut().enumerate() {
            if (k.count_ones() % 2) == 0 {
                *wk = 5.0 / 3.0;
            }
        }
        let mesh = partition_film(1.0, &w, 4).unwrap().mesh;
        let angles = crate::cmc::figures::junction_angles(&mesh).unwrap();
        assert!(angles.edges > 0);
        assert!(
            (angles.min_deg - 120.0).abs() < 1e-6 && (angles.max_deg - 120.0).abs() < 1e-6,
            "{angles:?}"
        );
    }

    #[test]
    fn flipped_starts_are_better_shaped() {
        for topology in STABLE {
            let (walls, levels) = (window_weights(topology).unwrap(), 6);
            let flipped = octahedron_frame(1.0, topology, levels).unwrap().mesh;
            let fans = partition_fans(1.0, &walls, levels).unwrap();
            let (before, after) = (
                quality(&fans).min_angle_deg,
                quality(&flipped).min_angle_deg,
            );
            eprintln!("{topology:?}: {before:.3}° -> {after:.3}°");
            assert!(after > 1.5 * before, "{topology:?}: {before} -> {after}");
            assert!((total_area(&flipped) - total_area(&fans)).abs() < 1e-12);
        }
    }

    #[test]
    fn stable_starts_build_with_fixed_wires() {
        for topology in STABLE {
            let shape = octahedron_frame(1.0, topology, 3).unwrap();
            let m = &shape.mesh;
            // 6 corners + 12 wires × 2 interior vertices.
            let fixed = m.flags().iter().filter(|f| f.fixed).count();
            assert_eq!(fixed, 6 + 12 * 2, "{topology:?}");
            let walls = partition_walls(1.0 / 2f64.sqrt(), &window_weights(topology).unwrap());
            let exact: f64 = walls.iter().map(|(_, _, p)| polygon_area(p)).sum();
            assert!((total_area(m) - exact).abs() < 1e-9, "{topology:?}");
            assert!(!m.junction_vertices().is_empty());
        }
    }
}
