//! Start meshes for clusters of N bubbles that share walls, placed by their centres (m) and
//! volumes (m³).
//!
//! Bubble i is the ball of radius `rᵢ = (3Vᵢ/4π)^⅓` about its centre `cᵢ`. Space is split
//! into the power cells of the balls, `|x − cᵢ|² − rᵢ² ≤ |x − cⱼ|² − rⱼ²` for every j (linear
//! in x: `2(cⱼ − cᵢ)·x ≤ |cⱼ|² − |cᵢ|² − rⱼ² + rᵢ²`), whose walls are the radical planes of
//! touching spheres: where two overlapping soap bubbles meet. The union of the balls is
//! replaced by a convex polytope around it: the half-spaces `nₖ·x ≤ maxᵢ(nₖ·cᵢ + rᵢ)` for the
//! 32 face and vertex directions `nₖ` of an icosahedron (a truncated icosahedron about a lone
//! ball). Each bubble's cell is its power cell inside that polytope, a convex polyhedron, so
//! every face is a planar convex polygon: a wall between two bubbles or a piece of a bubble's
//! outer skin ([`super::polygon_complex`]). The complex is meshed with `levels` segments per
//! polygon edge and scaled about the centres' centroid to the total volume (no smoothing or
//! flips: on the skins, which bend over the polytope's edges, the octahedral starts' smoothing
//! and flipping folded triangles into spikes, and the solves from those starts stalled); the optimization then rounds the skins into spherical caps,
//! turns the walls to meet at 120° and reaches each bubble's own volume.
//!
//! A cluster keeps the topology of its start: which bubbles share a wall, and where the walls'
//! junction lines meet. Centres in a degenerate position (four bubbles whose power cells meet
//! along one line, e.g. centres on the corners of a square with equal volumes) give four films
//! on a line, which Plateau's laws forbid and the solve cannot resolve; moving a centre a
//! little breaks the tie into two triple lines joined by a short wall.
//!
//! Surfaces: each bubble's outer skin is named after the bubble (normals outward), the wall
//! between bubbles a and b (a listed first) `a|b` (normals from a into b). A bubble enclosed by
//! others has no skin.

use super::generators::Shape;
use super::mesh::{MeshError, Point};
use super::polygon_complex::{Polygon, clip, distinct_corners, fan_mesh, plane_square};
use super::volume::Region;

/// One bubble of a cluster.
#[derive(Debug, Clone, PartialEq)]
pub struct Bubble {
    /// Name of its volume and of its outer skin.
    pub name: String,
    /// Where the bubble sits (m).
    pub centre: Point,
    /// Its volume, m³.
    pub volume: f64,
}

/// The half-space `a·x ≤ b` of points nearer (in power distance) to bubble `i` than to `j`,
/// for centres `c` and radii `r`.
fn power_half_space(c: &[Point], r: &[f64], i: usize, j: usize) -> (Point, f64) {
    (
        2.0 * (c[j] - c[i]),
        c[j].norm_squared() - c[i].norm_squared() - r[j] * r[j] + r[i] * r[i],
    )
}

/// The 32 unit directions of an icosahedron's 12 vertices and 20 face centres.
fn hull_directions() -> Vec<Point> {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut vertices = Vec::new();
    for a in [-1.0, 1.0] {
        for b in [-t, t] {
            vertices.push(Point::new(0.0, a, b));
            vertices.push(Point::new(a, b, 0.0));
            vertices.push(Point::new(b, 0.0, a));
        }
    }
    let edge = 2.0;
    let mut directions: Vec<Point> = vertices.iter().map(|v| v.normalize()).collect();
    for i in 0..12 {
        for j in (i + 1)..12 {
            for k in (j + 1)..12 {
                let near = |p: &Point, q: &Point| ((p - q).norm() - edge).abs() < 1e-9;
                let (p, q, s) = (&vertices[i], &vertices[j], &vertices[k]);
                if near(p, q) && near(q, s) && near(p, s) {
                    directions.push((p + q + s).normalize());
                }
            }
        }
    }
    directions
}

/// The cluster's start: surfaces as in the module header, one volume per bubble (named after
/// it). Bubbles whose cell is empty (inside the others), or a complex whose polygons do not
/// close up (a degenerate placement), are errors.
pub fn cluster(bubbles: &[Bubble], levels: usize) -> Result<Shape, MeshError> {
    let count = bubbles.len();
    let centroid = bubbles.iter().map(|b| b.centre).sum::<Point>() / count.max(1) as f64;
    // Relative to the centroid, which keeps the power planes' offsets small.
    let c: Vec<Point> = bubbles.iter().map(|b| b.centre - centroid).collect();
    let r: Vec<f64> = bubbles
        .iter()
        .map(|b| (3.0 * b.volume / (4.0 * std::f64::consts::PI)).cbrt())
        .collect();
    let size = (0..count).map(|i| c[i].norm() + r[i]).fold(0.0, f64::max);
    let hull: Vec<(Point, f64)> = hull_directions()
        .into_iter()
        .map(|n| {
            let h = (0..count)
                .map(|i| n.dot(&c[i]) + r[i])
                .fold(f64::MIN, f64::max);
            (n, h)
        })
        .collect();
    let tolerance = 1e-7 * size;
    let min_area = 1e-9 * size * size;
    let half_side = 8.0 * size;
    let inside_cell = |mut poly: Vec<Point>, i: usize, skip: &[usize], hull_skip: Option<usize>| {
        for j in (0..count).filter(|j| *j != i && !skip.contains(j)) {
            let (a, b) = power_half_space(&c, &r, i, j);
            poly = clip(&poly, &a, b);
        }
        for (k, (n, h)) in hull.iter().enumerate() {
            if Some(k) != hull_skip {
                poly = clip(&poly, n, *h);
            }
        }
        distinct_corners(poly, tolerance, min_area)
    };
    // Skins first (bubble order), then walls (pair order); surfaces only where polygons are.
    let mut names: Vec<String> = Vec::new();
    let mut polygons: Vec<Polygon> = Vec::new();
    let mut boundaries: Vec<Vec<(usize, f64)>> = vec![Vec::new(); count];
    let mut add_surface = |name: String, pieces: Vec<Polygon>, sides: &[(usize, f64)]| {
        if pieces.is_empty() {
            return;
        }
        let s = names.len();
        names.push(name);
        for &(i, sign) in sides {
            boundaries[i].push((s, sign));
        }
        polygons.extend(pieces.into_iter().map(|p| Polygon { surface: s, ..p }));
    };
    for (i, bubble) in bubbles.iter().enumerate() {
        let pieces = hull
            .iter()
            .enumerate()
            .filter_map(|(k, (n, h))| {
                let square = plane_square(n, *h, &Point::zeros(), half_side);
                inside_cell(square, i, &[], Some(k)).map(|corners| Polygon {
                    surface: 0,
                    up: Some(*n),
                    corners,
                })
            })
            .collect();
        add_surface(bubble.name.clone(), pieces, &[(i, 1.0)]);
    }
    for i in 0..count {
        for j in (i + 1)..count {
            let (a, b) = power_half_space(&c, &r, i, j);
            let square = plane_square(&a, b, &Point::zeros(), half_side);
            let pieces = inside_cell(square, i, &[j], None)
                .map(|corners| Polygon {
                    surface: 0,
                    up: Some(a),
                    corners,
                })
                .into_iter()
                .collect();
            let name = format!("{}|{}", bubbles[i].name, bubbles[j].name);
            add_surface(name, pieces, &[(i, 1.0), (j, -1.0)]);
        }
    }
    if let Some(i) = boundaries.iter().position(Vec::is_empty) {
        return Err(MeshError::Inconsistent(format!(
            "bubble `{}` gets no cell: its ball lies inside the others' (move it out or enlarge it)",
            bubbles[i].name
        )));
    }
    let mut mesh = fan_mesh(&names, &polygons, levels, tolerance, |_| false)?;
    if let Some(edge) = mesh.edges().iter().find(|e| e.triangles.len() < 2) {
        let p = mesh.positions()[edge.vertices[0]] + centroid;
        return Err(MeshError::Inconsistent(format!(
            "the bubbles' walls do not close up near ({:.3e}, {:.3e}, {:.3e}) m: the centres are \
             in a degenerate position; move one a little",
            p.x, p.y, p.z
        )));
    }
    let volumes: Vec<(String, Region, f64)> = bubbles
        .iter()
        .zip(boundaries)
        .map(|(bubble, boundary)| {
            let region = Region {
                boundary,
                reference: Point::zeros(),
            };
            (bubble.name.clone(), region, bubble.volume)
        })
        .collect();
    let start: f64 = volumes.iter().map(|(_, v, _)| v.volume(&mesh)).sum();
    let target: f64 = bubbles.iter().map(|b| b.volume).sum();
    let scale = (target / start).cbrt();
    let placed = mesh
        .positions()
        .iter()
        .map(|p| p * scale + centroid)
        .collect();
    mesh.set_positions(placed)?;
    Ok(Shape { mesh, volumes })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::figures::{junction_angles, quality};

    fn bubble(name: &str, centre: [f64; 3], volume: f64) -> Bubble {
        Bubble {
            name: name.into(),
            centre: Point::from(centre),
            volume,
        }
    }

    /// Four equal bubbles on the corners of a regular tetrahedron.
    pub(crate) fn tetrahedral(edge: f64, volume: f64) -> Vec<Bubble> {
        let s = edge / 8f64.sqrt();
        [
            ("a", [s, s, s]),
            ("b", [s, -s, -s]),
            ("c", [-s, s, -s]),
            ("d", [-s, -s, s]),
        ]
        .iter()
        .map(|&(n, p)| bubble(n, p, volume))
        .collect()
    }

    #[test]
    fn a_lone_bubble_is_a_closed_truncated_icosahedron_of_its_volume() {
        let shape = cluster(&[bubble("only", [1.0, 2.0, 3.0], 2.0)], 2).unwrap();
        assert_eq!(shape.mesh.surfaces(), ["only"]);
        assert!(shape.mesh.edges().iter().all(|e| e.triangles.len() == 2));
        let (_, region, target) = &shape.volumes[0];
        assert!((region.volume(&shape.mesh) - target).abs() < 1e-12 * target);
        let mean = shape.mesh.positions().iter().sum::<Point>() / shape.mesh.vertex_count() as f64;
        assert!((mean - Point::new(1.0, 2.0, 3.0)).norm() < 0.05);
    }

    #[test]
    fn a_tetrahedral_cluster_has_four_skins_six_walls_and_triple_junctions() {
        let shape = cluster(&tetrahedral(1.0, 0.3), 2).unwrap();
        let names = shape.mesh.surfaces();
        assert_eq!(names.len(), 10, "{names:?}");
        for wall in ["a|b", "a|c", "a|d", "b|c", "b|d", "c|d"] {
            assert!(names.iter().any(|n| n == wall), "{wall} missing: {names:?}");
        }
        // Every edge is a film edge (2 triangles) or a junction (3); the centre, where the four
        // interior junction lines meet, has six.
        let counts: Vec<usize> = shape
            .mesh
            .edges()
            .iter()
            .map(|e| e.triangles.len())
            .collect();
        assert!(counts.iter().all(|&k| k == 2 || k == 3), "{counts:?}");
        assert!(counts.contains(&3));
        let total: f64 = shape
            .volumes
            .iter()
            .map(|(_, v, _)| v.volume(&shape.mesh))
            .sum();
        assert!((total - 1.2).abs() < 1e-12);
        for (name, region, _) in &shape.volumes {
            let v = region.volume(&shape.mesh);
            assert!((v - 0.3).abs() < 0.01, "{name}: {v}");
        }
        assert!(quality(&shape.mesh).min_angle_deg > 5.0);
        assert!(junction_angles(&shape.mesh).is_some());
    }

    #[test]
    fn a_bubble_inside_another_is_an_error() {
        let err = cluster(
            &[
                bubble("big", [0.0; 3], 10.0),
                bubble("small", [0.1, 0.0, 0.0], 0.01),
            ],
            1,
        )
        .unwrap_err();
        assert!(err.to_string().contains("`small` gets no cell"), "{err}");
    }
}
