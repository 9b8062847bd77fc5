//! The catenoid between two coaxial rings: a start mesh and the exact answer.
//!
//! Two fixed circles of radius `R` (m) in the planes y = ±h/2 about the y axis bound a minimal
//! surface of revolution r(y) = a·cosh(y/a) when `a·cosh(h/(2a)) = R` has a solution; of its
//! two roots the larger `a` is the stable catenoid. Its area is
//! `A = 2π ∫ r √(1 + r'²) dy = π·a·(h + a·sinh(h/a))` (m²). Solutions exist for
//! h/R ≤ 1.325486839 (max over a of 2a·acosh(R/a)); for R = 1, h = 1: a = 0.848338…,
//! A = 5.991796975802.
//!
//! The start mesh is the cylinder between the rings: `12·levels` vertices per ring, every other
//! ring turned by half a segment (near-equilateral triangles without a net twist: a cumulative
//! stagger would shear the mesh into a helix), outward normals.

use std::f64::consts::PI;

use super::generators::Shape;
use super::mesh::{MeshBuilder, MeshError, Point};

/// The stable catenoid between coaxial rings of radius `radius` (m) a distance `separation`
/// (m) apart: its neck radius `a` (m) and area (m²), or `None` when no catenoid spans them.
pub fn exact_catenoid(radius: f64, separation: f64) -> Option<(f64, f64)> {
    // g(a) = a·cosh(h/2a) − R; the stable root lies between the turning point a* (where g is
    // smallest) and R. Its turning point: tanh(u) = 1/u with u = h/2a, u* = 1.19967864.
    let h = separation;
    if !(radius > 0.0 && h > 0.0) {
        return None;
    }
    let g = |a: f64| a * (h / (2.0 * a)).cosh() - radius;
    let mut u: f64 = 1.2;
    for _ in 0..60 {
        // Newton on tanh(u) − 1/u = 0.
        let f = u.tanh() - 1.0 / u;
        let df = 1.0 - u.tanh().powi(2) + 1.0 / (u * u);
        u -= f / df;
    }
    let a_turn = h / (2.0 * u);
    if g(a_turn) > 0.0 {
        return None;
    }
    let (mut lo, mut hi) = (a_turn, radius);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if g(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let a = 0.5 * (lo + hi);
    Some((a, PI * a * (h + a * (h / a).sinh())))
}

/// The cylinder between two fixed coaxial rings of radius `radius` (m) in the planes
/// y = ±`separation`/2, one film `film` with outward normals; `12·levels` segments per ring.
pub fn catenoid(radius: f64, separation: f64, levels: usize) -> Result<Shape, MeshError> {
    let around = 12 * levels.max(1);
    // Rows for near-equilateral triangles at level 1, times the level: every level has the
    // same triangle shapes, so the discretization error falls cleanly with the edge length.
    let level_one_segment = 2.0 * PI * radius / 12.0;
    let rows_per_level =
        ((separation / (level_one_segment * 3f64.sqrt() / 2.0)).round() as usize).max(1);
    let rows = rows_per_level * levels.max(1);
    let mut b = MeshBuilder::new();
    let film = b.surface("film");
    staggered_band(&mut b, film, rows, around, |j, phi| {
        let y = separation * (j as f64 / rows as f64 - 0.5);
        Point::new(radius * phi.cos(), y, radius * phi.sin())
    });
    Ok(Shape {
        mesh: b.build()?,
        volumes: Vec::new(),
    })
}

/// Meshes a band of `rows + 1` rows of `around` vertices, row `j`'s vertex `i` at
/// `place(j, φ)` with `φ = 2π (i + ½ (j mod 2)) / around` (every other row turned by half a
/// segment: near-equilateral triangles without a net twist); the first and last rows are fixed
/// wires. Triangles are counter-clockwise seen from the side a ring's outward normal points to
/// when the rows advance along the axis (the catenoid's outward normals).
pub fn staggered_band(
    b: &mut MeshBuilder,
    surface: usize,
    rows: usize,
    around: usize,
    place: impl Fn(usize, f64) -> Point,
) {
    let rings: Vec<Vec<usize>> = (0..=rows)
        .map(|j| {
            (0..around)
                .map(|i| {
                    let phi = 2.0 * PI * (i as f64 + 0.5 * (j % 2) as f64) / around as f64;
                    let p = place(j, phi);
                    if j == 0 || j == rows {
                        b.fixed(p)
                    } else {
                        b.vertex(p)
                    }
                })
                .collect()
        })
        .collect();
    for j in 0..rows {
        let (lower, upper) = (&rings[j], &rings[j + 1]);
        for i in 0..around {
            let k = (i + 1) % around;
            // The upper vertex between lower[i] and lower[i + 1]: upper[i] above an even ring
            // (the upper ring is turned by +½ segment), upper[i + 1] above an odd one.
            let u = if j % 2 == 0 { i } else { k };
            let u_next = (u + 1) % around;
            b.triangle(surface, [lower[i], upper[u], lower[k]]);
            b.triangle(surface, [lower[k], upper[u], upper[u_next]]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::area::{area_vector, total_area};

    #[test]
    fn exact_catenoid_matches_the_known_area_and_limits() {
        let (a, area) = exact_catenoid(1.0, 1.0).unwrap();
        assert!((a * (0.5 / a).cosh() - 1.0).abs() < 1e-12);
        assert!((area - 5.991796975802).abs() < 1e-9, "{area}");
        // The stable branch is the wider neck: a above the turning point h/(2·1.19967864).
        assert!(a > 1.0 / (2.0 * 1.19967864), "{a}");
        assert!(exact_catenoid(1.0, 1.3254).is_some());
        assert!(exact_catenoid(1.0, 1.3256).is_none());
        // Scale invariance: A(λR, λh) = λ²·A(R, h).
        let (_, scaled) = exact_catenoid(2.0, 2.0).unwrap();
        assert!((scaled / area - 4.0).abs() < 1e-9);
    }

    #[test]
    fn cylinder_start_has_outward_normals_and_fixed_rings() {
        let shape = catenoid(1.0, 1.0, 2).unwrap();
        let m = &shape.mesh;
        for t in 0..m.triangles().len() {
            let c = m.corners(t);
            let centre = (c[0] + c[1] + c[2]) / 3.0;
            let radial = Point::new(centre.x, 0.0, centre.z);
            assert!(area_vector(&c).dot(&radial) > 0.0, "triangle {t}");
        }
        let fixed = m.flags().iter().filter(|f| f.fixed).count();
        assert_eq!(fixed, 2 * 24);
        // The inscribed prism: slightly below the cylinder's 2π·R·h.
        let a = total_area(m);
        assert!(a < 2.0 * PI && a > 0.98 * 2.0 * PI, "{a}");
    }
}
