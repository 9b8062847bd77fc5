//! A tent from a square wire to a raised horizontal ring: the annular soap film between the
//! fixed square `|x|, |z| ≤ w` in the plane y = 0 and the fixed circle of radius `r < w` about
//! the y axis at height `h`.
//!
//! The film exists only while the ring is low enough: like a catenoid, a neck of radius about
//! `r` holds it at most about `r·acosh(R/r)` above supports at distance `R` (between `w` and
//! `√2·w` here). Above that the neck pinches and no annulus spans the wires; a mesh can still
//! hold a discrete "solution", whose area then does not converge under refinement
//! ([`super::refinement`]).
//!
//! Mesh: `8·levels` vertices per row around the axis, rows from the ring (row 0) to the square
//! (last row), every other row turned by half a segment (near-equilateral triangles, as the
//! catenoid's cylinder). A vertex at angle φ sits on the segment from the ring point at φ to the
//! point of the square on the ray at φ, at the row's fraction; the rows are an even number, so
//! the last row, unturned, holds the square's four corners (φ = 45° + 90°·k).

use std::f64::consts::PI;

use super::catenoid::staggered_band;
use super::generators::Shape;
use super::mesh::{MeshBuilder, MeshError, Point};

/// Largest number of rows per level (the face count stays within 64·levels²).
const MAX_ROWS_PER_LEVEL: usize = 4;

/// The start mesh of the tent between the square wire of half-width `half_width` (m) at y = 0
/// and the ring of radius `ring_radius` (m) at height `ring_height` (m), one film `film`.
pub fn ring_tent(
    half_width: f64,
    ring_radius: f64,
    ring_height: f64,
    levels: usize,
) -> Result<Shape, MeshError> {
    let levels = levels.max(1);
    let around = 8 * levels;
    // Rows for near-equilateral triangles at level 1 at the middle radius, rounded up to even.
    let middle = 0.5 * (ring_radius + 1.2 * half_width);
    let segment = 2.0 * PI * middle / 8.0;
    let distance = (1.2 * half_width - ring_radius).hypot(ring_height);
    let per_level = (distance / (segment * 3f64.sqrt() / 2.0)).round() as usize;
    let rows = 2 * per_level.div_ceil(2).clamp(1, MAX_ROWS_PER_LEVEL / 2) * levels;
    let mut b = MeshBuilder::new();
    let film = b.surface("film");
    staggered_band(&mut b, film, rows, around, |j, phi| {
        let f = j as f64 / rows as f64;
        let (c, s) = ((phi + PI / 4.0).cos(), (phi + PI / 4.0).sin());
        let inner = Point::new(ring_radius * c, ring_height, ring_radius * s);
        let reach = half_width / c.abs().max(s.abs());
        let outer = Point::new(reach * c, 0.0, reach * s);
        inner + (outer - inner) * f
    });
    Ok(Shape {
        mesh: b.build()?,
        volumes: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wires_are_the_square_and_the_ring() {
        let shape = ring_tent(1.0, 0.4, 0.3, 2).unwrap();
        let m = &shape.mesh;
        let fixed: Vec<&Point> = m.fixed_positions().collect();
        assert_eq!(fixed.len(), 2 * 16);
        for p in fixed {
            let on_ring = (p.y - 0.3).abs() < 1e-12 && (p.x.hypot(p.z) - 0.4).abs() < 1e-12;
            let on_square = p.y.abs() < 1e-12 && (p.x.abs().max(p.z.abs()) - 1.0).abs() < 1e-12;
            assert!(on_ring || on_square, "{p}");
        }
        // The four corners are vertices, so the wire is exactly the square.
        for (x, z) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
            assert!(
                m.positions()
                    .iter()
                    .any(|p| (p - Point::new(x, 0.0, z)).norm() < 1e-12)
            );
        }
        assert!(m.triangles().len() <= 64 * 4);
    }
}
