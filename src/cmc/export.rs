//! The `model.glb` of a CMC result: one glTF mesh per surface, with smooth per-vertex normals
//! (area-weighted over the surface's own triangles, so films meeting at a junction keep their
//! own normals) and a distinct double-sided material per surface. Metres, y up.

use std::collections::BTreeMap;

use super::area::area_vector;
use super::mesh::{Mesh, Point};
use crate::io::gltf::{self, Material, Node, Scene};

/// Linear RGBA colours cycled over surfaces (slightly translucent: films and bubbles).
const COLOURS: [[f32; 4]; 8] = [
    [0.20, 0.45, 0.85, 0.75],
    [0.90, 0.50, 0.15, 0.75],
    [0.25, 0.70, 0.30, 0.75],
    [0.80, 0.25, 0.35, 0.75],
    [0.55, 0.35, 0.80, 0.75],
    [0.85, 0.75, 0.20, 0.75],
    [0.20, 0.70, 0.75, 0.75],
    [0.60, 0.60, 0.60, 0.75],
];

/// The glTF scene of `mesh`.
pub fn scene(mesh: &Mesh) -> Scene {
    let mut scene = Scene::default();
    for (s, name) in mesh.surfaces().iter().enumerate() {
        let mut local: BTreeMap<usize, u32> = BTreeMap::new();
        let mut part = gltf::Mesh {
            name: name.clone(),
            material: s,
            ..Default::default()
        };
        let mut normals: Vec<Point> = Vec::new();
        for t in mesh.surface_triangles(s) {
            let n = area_vector(&mesh.corners(t));
            for v in mesh.triangles()[t] {
                let index = *local.entry(v).or_insert_with(|| {
                    let p = mesh.positions()[v];
                    part.positions.push([p.x as f32, p.y as f32, p.z as f32]);
                    normals.push(Point::zeros());
                    (part.positions.len() - 1) as u32
                });
                normals[index as usize] += n;
                part.indices.push(index);
            }
        }
        part.normals = normals
            .iter()
            .map(|n| {
                let u = n.try_normalize(0.0).unwrap_or_else(Point::y);
                [u.x as f32, u.y as f32, u.z as f32]
            })
            .collect();
        scene.materials.push(Material {
            double_sided: true,
            roughness: 0.3,
            ..Material::matte(name, COLOURS[s % COLOURS.len()])
        });
        scene.meshes.push(part);
        scene.nodes.push(Node::with_mesh(name, s));
        scene.roots.push(s);
    }
    scene
}

/// `model.glb` bytes of `mesh`.
pub fn glb(mesh: &Mesh) -> Result<Vec<u8>, gltf::GltfError> {
    scene(mesh).to_glb()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_primitive_per_surface_and_it_reads_back() {
        let shape = crate::cmc::generators::double_bubble([1.0, 2.0], 3).unwrap();
        let bytes = glb(&shape.mesh).unwrap();
        let crate::io::gltf_read::Loaded {
            document: doc,
            buffers,
        } = crate::io::gltf_read::read_slice(&bytes, None).unwrap();
        assert_eq!(doc.meshes().count(), 3);
        assert_eq!(doc.materials().count(), 3);
        let mut triangles = 0;
        for m in doc.meshes() {
            for p in m.primitives() {
                let reader = p.reader(|b| Some(buffers[b.index()].as_slice()));
                let normals: Vec<[f32; 3]> = reader.read_normals().unwrap().collect();
                assert!(normals.iter().all(|n| {
                    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                    (len - 1.0).abs() < 1e-5
                }));
                triangles += reader.read_indices().unwrap().into_u32().count() / 3;
            }
        }
        assert_eq!(triangles, shape.mesh.triangles().len());
    }
}
