//! Simple display meshes for the glTF writer: cylinders (beams), spheres (joints, loads),
//! boxes and capsules (links), a ground plane, and smooth normals for arbitrary triangle lists.
//!
//! Lengths in metres; every mesh has outward unit normals and counter-clockwise triangles
//! seen from outside. Material index 0 is set; callers pick the material.

use std::f32::consts::{PI, TAU};

use nalgebra::Vector3;

use super::gltf::Mesh;

type V3 = Vector3<f32>;

fn arr(v: V3) -> [f32; 3] {
    [v.x, v.y, v.z]
}

/// Two unit vectors perpendicular to the unit vector `axis` and to each other.
fn frame(axis: V3) -> (V3, V3) {
    let helper = if axis.x.abs() < 0.9 { V3::x() } else { V3::y() };
    let u = axis.cross(&helper).normalize();
    (u, axis.cross(&u))
}

/// A closed cylinder of radius `r` from `a` to `b` with `segments` facets around.
/// Degenerate input (a = b) gives a sphere of radius `r` at `a`, so zero-length beams still show.
pub fn cylinder(a: [f32; 3], b: [f32; 3], r: f32, segments: usize) -> Mesh {
    let (pa, pb) = (V3::from(a), V3::from(b));
    if (pb - pa).norm() <= f32::EPSILON * (1.0 + pa.norm()) {
        return sphere(a, r, segments.max(6));
    }
    frustum(pa, pb, [r, r], segments)
}

/// A solid cone with its apex at `apex` and a flat base of radius `r` centred at `base`, with
/// `segments` facets around; `apex` and `base` must differ.
pub fn cone(apex: [f32; 3], base: [f32; 3], r: f32, segments: usize) -> Mesh {
    frustum(V3::from(apex), V3::from(base), [0.0, r], segments)
}

/// A closed frustum from `pa` (radius `r[0]`) to `pb` (radius `r[1]`), `pa ≠ pb`: the side
/// with normals perpendicular to its slant, and a flat cap on each end of nonzero radius.
fn frustum(pa: V3, pb: V3, r: [f32; 2], segments: usize) -> Mesh {
    let length = (pb - pa).norm();
    let axis = (pb - pa).normalize();
    let (u, v) = frame(axis);
    let s = segments.max(3);
    let mut mesh = Mesh::default();
    // Side: two rings with normals across the slant (radial on a cylinder).
    for (end, radius) in [(pa, r[0]), (pb, r[1])] {
        for k in 0..s {
            let t = TAU * k as f32 / s as f32;
            let radial = u * t.cos() + v * t.sin();
            mesh.positions.push(arr(end + radial * radius));
            let normal = if r[0] == r[1] {
                radial
            } else {
                (radial * length - axis * (r[1] - r[0])).normalize()
            };
            mesh.normals.push(arr(normal));
        }
    }
    for k in 0..s {
        let (k0, k1) = (k as u32, ((k + 1) % s) as u32);
        let s = s as u32;
        mesh.indices
            .extend_from_slice(&[k0, k1, s + k1, k0, s + k1, s + k0]);
    }
    // Caps: a centre vertex and a ring with axial normals.
    for (end, normal, radius) in [(pa, -axis, r[0]), (pb, axis, r[1])] {
        if radius == 0.0 {
            continue;
        }
        let centre = mesh.positions.len() as u32;
        mesh.positions.push(arr(end));
        mesh.normals.push(arr(normal));
        for k in 0..s {
            let t = TAU * k as f32 / s as f32;
            mesh.positions
                .push(arr(end + (u * t.cos() + v * t.sin()) * radius));
            mesh.normals.push(arr(normal));
        }
        for k in 0..s as u32 {
            let (k0, k1) = (centre + 1 + k, centre + 1 + (k + 1) % s as u32);
            if normal.dot(&axis) > 0.0 {
                mesh.indices.extend_from_slice(&[centre, k0, k1]);
            } else {
                mesh.indices.extend_from_slice(&[centre, k1, k0]);
            }
        }
    }
    mesh
}

/// A UV sphere of radius `r` about `c` with `segments` facets around (and half as many rings).
pub fn sphere(c: [f32; 3], r: f32, segments: usize) -> Mesh {
    let s = segments.max(4);
    let rings = (s / 2).max(2);
    let centre = V3::from(c);
    let mut mesh = Mesh::default();
    for i in 0..=rings {
        let phi = PI * i as f32 / rings as f32;
        for k in 0..=s {
            let t = TAU * k as f32 / s as f32;
            let n = V3::new(phi.sin() * t.cos(), phi.cos(), phi.sin() * t.sin());
            mesh.positions.push(arr(centre + n * r));
            mesh.normals.push(arr(n));
        }
    }
    let row = (s + 1) as u32;
    for i in 0..rings as u32 {
        for k in 0..s as u32 {
            let (a, b) = (i * row + k, (i + 1) * row + k);
            mesh.indices
                .extend_from_slice(&[a, a + 1, b + 1, a, b + 1, b]);
        }
    }
    mesh
}

/// An axis-aligned box centred at `c` with half extents `h`.
pub fn cuboid(c: [f32; 3], h: [f32; 3]) -> Mesh {
    let mut mesh = Mesh::default();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = [0.0f32; 3];
            n[axis] = sign;
            let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = mesh.positions.len() as u32;
            for (s1, s2) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let mut p = c;
                p[axis] += sign * h[axis];
                p[a1] += s1 * h[a1];
                p[a2] += s2 * h[a2];
                mesh.positions.push(p);
                mesh.normals.push(n);
            }
            if sign > 0.0 {
                mesh.indices.extend_from_slice(&[
                    base,
                    base + 1,
                    base + 2,
                    base,
                    base + 2,
                    base + 3,
                ]);
            } else {
                mesh.indices.extend_from_slice(&[
                    base,
                    base + 2,
                    base + 1,
                    base,
                    base + 3,
                    base + 2,
                ]);
            }
        }
    }
    mesh
}

/// A capsule (cylinder with hemispherical ends) of radius `r` from `a` to `b`.
pub fn capsule(a: [f32; 3], b: [f32; 3], r: f32, segments: usize) -> Mesh {
    let mut mesh = cylinder(a, b, r, segments);
    for end in [a, b] {
        append(&mut mesh, &sphere(end, r, segments));
    }
    mesh
}

/// A square ground plane of half-width `h` at height `y`, facing up.
pub fn ground(h: f32, y: f32) -> Mesh {
    Mesh {
        name: "ground".into(),
        positions: vec![[-h, y, -h], [-h, y, h], [h, y, h], [h, y, -h]],
        normals: vec![[0.0, 1.0, 0.0]; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
        material: 0,
    }
}

/// Appends `other`'s triangles to `mesh` (same material).
pub fn append(mesh: &mut Mesh, other: &Mesh) {
    let base = mesh.positions.len() as u32;
    mesh.positions.extend_from_slice(&other.positions);
    mesh.normals.extend_from_slice(&other.normals);
    mesh.indices.extend(other.indices.iter().map(|i| i + base));
}

/// A mesh from triangles with area-weighted vertex normals (zero-area triangles contribute
/// nothing; an isolated vertex gets +y).
pub fn smooth(positions: Vec<[f32; 3]>, triangles: &[[u32; 3]]) -> Mesh {
    let mut normals = vec![V3::zeros(); positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| V3::from(positions[i as usize]));
        let n = (b - a).cross(&(c - a));
        for &i in t {
            normals[i as usize] += n;
        }
    }
    let normals = normals
        .into_iter()
        .map(|n| {
            if n.norm() > 0.0 {
                arr(n.normalize())
            } else {
                [0.0, 1.0, 0.0]
            }
        })
        .collect();
    Mesh {
        name: String::new(),
        positions,
        normals,
        indices: triangles.iter().flatten().copied().collect(),
        material: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Volume by the divergence theorem; positive iff triangles wind outward.
    fn volume(mesh: &Mesh) -> f32 {
        mesh.indices
            .chunks(3)
            .map(|t| {
                let [a, b, c] = [0, 1, 2].map(|k| V3::from(mesh.positions[t[k] as usize]));
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn closed_shapes_enclose_their_volume_outward() {
        let cyl = cylinder([0.0; 3], [0.0, 0.0, 2.0], 1.0, 64);
        let exact = PI * 2.0;
        assert!(
            (volume(&cyl) - exact).abs() < 0.01 * exact,
            "{}",
            volume(&cyl)
        );
        let sph = sphere([1.0, 2.0, 3.0], 1.0, 64);
        let exact = 4.0 / 3.0 * PI;
        assert!(
            (volume(&sph) - exact).abs() < 0.01 * exact,
            "{}",
            volume(&sph)
        );
        let cube = cuboid([0.5; 3], [1.0, 2.0, 3.0]);
        assert!((volume(&cube) - 48.0).abs() < 1e-4, "{}", volume(&cube));
        // πr²h/3, either way up.
        for (apex, base) in [
            ([0.0; 3], [0.0, 0.0, 3.0]),
            ([1.0, 3.0, 0.0], [1.0, 0.0, 0.0]),
        ] {
            let c = cone(apex, base, 1.0, 64);
            let exact = PI;
            assert!((volume(&c) - exact).abs() < 0.01 * exact, "{}", volume(&c));
        }
    }

    #[test]
    fn normals_are_unit_and_counts_match() {
        for m in [
            cylinder([0.0; 3], [1.0, 1.0, 1.0], 0.2, 8),
            capsule([0.0; 3], [0.0, 1.0, 0.0], 0.1, 8),
            cone([0.0; 3], [0.14, 0.0, 0.0], 0.04, 8),
        ] {
            assert_eq!(m.positions.len(), m.normals.len());
            assert!(
                m.normals
                    .iter()
                    .all(|n| (V3::from(*n).norm() - 1.0).abs() < 1e-5)
            );
            assert!(m.indices.iter().all(|&i| (i as usize) < m.positions.len()));
        }
        // A zero-length cylinder falls back to a sphere instead of producing NaN normals.
        let dot = cylinder([1.0; 3], [1.0; 3], 0.1, 8);
        assert!(dot.normals.iter().flatten().all(|v| v.is_finite()));
    }
}
