//! Test helpers: seeded random triangles and perturbed meshes, central differences.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::mesh::{Mesh, Point};

/// A seeded generator.
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

fn unit(rng: &mut ChaCha8Rng) -> f64 {
    rng.random::<f64>() * 2.0 - 1.0
}

/// A random triangle in the cube [−1, 1]³ (acute and obtuse ones alike).
pub fn random_triangle(rng: &mut ChaCha8Rng) -> [Point; 3] {
    loop {
        let p = [0, 1, 2].map(|_| Point::new(unit(rng), unit(rng), unit(rng)));
        if super::area::triangle_area(&p) > 0.05 {
            return p;
        }
    }
}

/// Central difference of `f` w.r.t. corner `k` of `p`, all three axes.
pub fn central_difference(
    p: &[Point; 3],
    k: usize,
    h: f64,
    f: impl Fn(&[Point; 3]) -> f64,
) -> Point {
    Point::from_fn(|c, _| {
        let mut plus = *p;
        let mut minus = *p;
        plus[k][c] += h;
        minus[k][c] -= h;
        (f(&plus) - f(&minus)) / (2.0 * h)
    })
}

/// A copy of `mesh` with every vertex moved randomly by up to `amount` times the mean edge
/// length along each axis.
pub fn perturbed(mesh: &Mesh, amount: f64, rng: &mut ChaCha8Rng) -> Mesh {
    let edges = mesh.edges();
    let mean = edges
        .iter()
        .map(|e| (mesh.positions()[e.vertices[0]] - mesh.positions()[e.vertices[1]]).norm())
        .sum::<f64>()
        / edges.len() as f64;
    let pos = mesh
        .positions()
        .iter()
        .map(|p| p + amount * mean * Point::new(unit(rng), unit(rng), unit(rng)))
        .collect();
    let mut m = mesh.clone();
    m.set_positions(pos)
        .expect("small perturbations keep triangles valid");
    m
}

fn angle_cosines(mesh: &Mesh, v: usize) -> Vec<f64> {
    mesh.vertex_triangles(v)
        .iter()
        .flat_map(|&t| {
            let p = mesh.corners(t);
            (0..3).map(move |m| {
                let a = p[(m + 1) % 3] - p[m];
                let b = p[(m + 2) % 3] - p[m];
                a.dot(&b) / (a.norm() * b.norm())
            })
        })
        .collect()
}

/// Whether a triangle of `v`'s star has an angle within `tol` (in cosine) of 90°, where the
/// mixed area has a kink and finite differences straddle it.
pub fn near_right_angle(mesh: &Mesh, v: usize, tol: f64) -> bool {
    angle_cosines(mesh, v).iter().any(|c| c.abs() < tol)
}

/// Whether a triangle of `v`'s star is obtuse.
pub fn has_obtuse(mesh: &Mesh, v: usize) -> bool {
    angle_cosines(mesh, v).iter().any(|&c| c < 0.0)
}

/// `mesh` moved radially (about the y axis) onto the catenoid `r = a·cosh(y/a)` (m).
pub fn onto_catenoid(mut mesh: Mesh, a: f64) -> Mesh {
    let moved = mesh
        .positions()
        .iter()
        .map(|p| {
            let s = a * (p.y / a).cosh() / p.x.hypot(p.z);
            Point::new(p.x * s, p.y, p.z * s)
        })
        .collect();
    mesh.set_positions(moved).unwrap();
    mesh
}

/// The catenoids between unit rings 1 m apart: the roots (stable, unstable) of
/// `a·cosh(1/(2a)) = 1`, m.
pub fn unit_catenoid_branches() -> (f64, f64) {
    let (stable, _) = super::catenoid::exact_catenoid(1.0, 1.0).unwrap();
    let g = |a: f64| a * (0.5 / a).cosh() - 1.0;
    let (mut lo, mut hi) = (0.1, 0.4);
    assert!(g(lo) > 0.0 && g(hi) < 0.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if g(mid) > 0.0 { lo = mid } else { hi = mid }
    }
    (stable, 0.5 * (lo + hi))
}
