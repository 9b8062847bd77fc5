//! Start meshes from complexes of planar convex polygons (m) that share corners and edges: the
//! walls of a partition of space into convex cells ([`super::octahedron`], [`super::cluster`]).
//!
//! A cell bounded by planes `aₖ·x ≤ bₖ` is convex, so each of its faces is a convex polygon:
//! a large square in the face's plane clipped by every other half-space
//! (Sutherland–Hodgman, [`clip`]). Polygons are meshed as fans of triangle patches around
//! their centroids ([`fan_mesh`]), `levels` segments on every polygon edge and spoke; corners
//! at the same position (within a tolerance) are one vertex and every polygon edge is one
//! shared path, which is how the faces meet along junction lines. Fans have thin triangles
//! where a polygon has short edges; [`smooth_within_walls`] moves the vertices inside each
//! surface towards their ring centroids.

use std::collections::BTreeMap;

use super::area::area_vector;
use super::generators::{add_path, add_triangle_patch};
use super::mesh::{Mesh, MeshBuilder, MeshError, Point};

/// One planar convex polygon of a complex.
#[derive(Debug, Clone)]
pub struct Polygon {
    /// Index of its surface in the complex's surface names.
    pub surface: usize,
    /// The side its triangles' normals face (`None`: as the fan comes, for unoriented films).
    pub up: Option<Point>,
    /// Corners in order around the polygon (m).
    pub corners: Vec<Point>,
}

/// Keeps the part of the convex polygon `poly` where `a·x ≤ b` (Sutherland–Hodgman).
pub fn clip(poly: &[Point], a: &Point, b: f64) -> Vec<Point> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (i, p) in poly.iter().enumerate() {
        let q = &poly[(i + 1) % poly.len()];
        let (fp, fq) = (a.dot(p) - b, a.dot(q) - b);
        if fp <= 0.0 {
            out.push(*p);
        }
        if fp * fq < 0.0 {
            out.push(p + (q - p) * (fp / (fp - fq)));
        }
    }
    out
}

/// A square of half side `half_side` (m) in the plane `a·x = b`, centred at the point of the
/// plane nearest `centre`: the polygon the face of that plane is clipped from.
pub fn plane_square(a: &Point, b: f64, centre: &Point, half_side: f64) -> Vec<Point> {
    let n = a.normalize();
    let origin = centre + n * ((b / a.norm()) - n.dot(centre));
    let u = n.cross(&Point::new(1.0, 0.3, 0.1)).normalize();
    let v = n.cross(&u);
    [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)]
        .iter()
        .map(|&(p, q)| origin + half_side * (p * u + q * v))
        .collect()
}

/// The corners of a clipped polygon with consecutive ones closer than `tolerance` (m) merged;
/// `None` when fewer than three remain or the area is at most `min_area` (m²).
pub fn distinct_corners(poly: Vec<Point>, tolerance: f64, min_area: f64) -> Option<Vec<Point>> {
    let mut corners: Vec<Point> = Vec::new();
    for p in poly {
        if corners.last().is_none_or(|q| (p - q).norm() > tolerance) {
            corners.push(p);
        }
    }
    while corners.len() > 1 && (corners[0] - corners[corners.len() - 1]).norm() <= tolerance {
        corners.pop();
    }
    (corners.len() >= 3 && polygon_area(&corners) > min_area).then_some(corners)
}

/// Area of a planar polygon (m²).
pub fn polygon_area(corners: &[Point]) -> f64 {
    let mut sum = Point::zeros();
    for i in 1..corners.len() - 1 {
        sum += (corners[i] - corners[0]).cross(&(corners[i + 1] - corners[0]));
    }
    0.5 * sum.norm()
}

/// Meshes `polygons` as fans of triangle patches around their centroids, `levels` segments on
/// every edge and spoke, into surfaces `surfaces`. Corners within `tolerance` (m) of each other
/// are one vertex, fixed where `is_fixed` says so; an edge between two fixed corners is a fixed
/// wire.
pub fn fan_mesh(
    surfaces: &[String],
    polygons: &[Polygon],
    levels: usize,
    tolerance: f64,
    is_fixed: impl Fn(&Point) -> bool,
) -> Result<Mesh, MeshError> {
    let n = levels.max(1);
    let mut b = MeshBuilder::new();
    let surface_ids: Vec<usize> = surfaces.iter().map(|s| b.surface(s)).collect();
    // Shared corners by position.
    let mut corner_ids: Vec<(Point, usize)> = Vec::new();
    let mut corner = |b: &mut MeshBuilder, p: Point| {
        if let Some(&(_, id)) = corner_ids.iter().find(|(q, _)| (p - q).norm() < tolerance) {
            return id;
        }
        let id = if is_fixed(&p) {
            b.fixed(p)
        } else {
            b.vertex(p)
        };
        corner_ids.push((p, id));
        id
    };
    let rings: Vec<Vec<usize>> = polygons
        .iter()
        .map(|poly| poly.corners.iter().map(|&p| corner(&mut b, p)).collect())
        .collect();
    // Shared edge paths: wires (both ends fixed) fixed.
    let mut paths: BTreeMap<(usize, usize), Vec<usize>> = BTreeMap::new();
    for ring in &rings {
        for i in 0..ring.len() {
            let (p, q) = (ring[i], ring[(i + 1) % ring.len()]);
            let key = (p.min(q), p.max(q));
            if let std::collections::btree_map::Entry::Vacant(slot) = paths.entry(key) {
                let wire = b.flags_mut(key.0).fixed && b.flags_mut(key.1).fixed;
                slot.insert(add_path(&mut b, key, n, wire));
            }
        }
    }
    for (poly, ring) in polygons.iter().zip(&rings) {
        let centroid = ring.iter().map(|&v| b.position(v)).sum::<Point>() / ring.len() as f64;
        let centre = b.vertex(centroid);
        let spokes: Vec<Vec<usize>> = ring
            .iter()
            .map(|&v| add_path(&mut b, (centre, v), n, false))
            .collect();
        let s = surface_ids[poly.surface];
        for i in 0..ring.len() {
            let j = (i + 1) % ring.len();
            let (p, q) = (ring[i], ring[j]);
            let mut base = paths[&(p.min(q), p.max(q))].clone();
            if base[0] != p {
                base.reverse();
            }
            // A patch's triangles all turn like (centre, p, q).
            let turn = (b.position(p) - centroid).cross(&(b.position(q) - centroid));
            if poly.up.is_some_and(|up| turn.dot(&up) < 0.0) {
                base.reverse();
                add_triangle_patch(&mut b, s, &spokes[j], &spokes[i], &base);
            } else {
                add_triangle_patch(&mut b, s, &spokes[i], &spokes[j], &base);
            }
        }
    }
    b.build()
}

/// One Gauss–Seidel sweep of Laplacian smoothing over the free vertices inside a surface
/// (closed disk stars of one surface): each moves to its ring's centroid unless that would
/// turn one of its triangles over. Wires and junction lines stay; inside a planar polygon the
/// area is unchanged.
pub fn smooth_within_walls(mesh: &mut Mesh) -> Result<(), MeshError> {
    let mut pos = mesh.positions().to_vec();
    for v in 0..mesh.vertex_count() {
        if mesh.flags()[v].fixed || !mesh.is_interior_manifold(v) {
            continue;
        }
        let ring = mesh.neighbours(v);
        let target = ring.iter().map(|&w| pos[w]).sum::<Point>() / ring.len() as f64;
        let keeps_orientation = mesh.vertex_triangles(v).iter().all(|&t| {
            let tri = mesh.triangles()[t];
            let corners = |at: Point| tri.map(|u| if u == v { at } else { pos[u] });
            let before = area_vector(&corners(pos[v]));
            let after = area_vector(&corners(target));
            after.dot(&before) > 0.05 * before.norm_squared()
        });
        if keeps_orientation {
            pos[v] = target;
        }
    }
    mesh.set_positions(pos)
}
