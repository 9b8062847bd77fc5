//! Start meshes from glTF 2.0 files (`.glb`, or `.gltf` with its buffers), as Blender exports
//! them, with the same conventions as the OBJ reader ([`super::import`]).
//!
//! Every mesh primitive reachable from the default scene (or from every scene, or every mesh
//! when the file has no scene) is read in world coordinates (node transforms applied; metres,
//! y up as glTF defines). Names and flags:
//! - triangle primitives (`TRIANGLES`, strips, fans) are films of the surface named by the
//!   primitive's material, else by its mesh, else by its node, else `surface`;
//! - line and point primitives (Blender's loose edges and vertices) mark wires: their vertices
//!   are fixed, unless one of the names above starts with `excluded`, in which case they are
//!   only excluded from curvature constraints;
//! - triangle primitives any of whose names starts with `fixed` are fixed geometry, not films.
//!
//! glTF primitives do not share vertices, so vertices at the same position (within 1e-9 of
//! the model's size) are welded: that is how films join at wires and junctions.

use std::collections::BTreeMap;
use std::path::Path;

use gltf::mesh::Mode;
use nalgebra::Matrix4;

use super::import::{ImportError, assemble};
use super::mesh::{Mesh, Point};
use crate::io::gltf_read;

/// Reads a `.glb` or `.gltf` file (external buffers relative to it).
pub fn read_gltf_file(path: &Path) -> Result<Mesh, ImportError> {
    let loaded = gltf_read::read_file(path).map_err(|e| ImportError::Gltf(format!("glTF: {e}")))?;
    read_document(&loaded.document, &loaded.buffers)
}

/// Reads a GLB (or self-contained glTF JSON) held in memory.
pub fn read_gltf_bytes(bytes: &[u8]) -> Result<Mesh, ImportError> {
    let loaded =
        gltf_read::read_slice(bytes, None).map_err(|e| ImportError::Gltf(format!("glTF: {e}")))?;
    read_document(&loaded.document, &loaded.buffers)
}

/// One primitive in world coordinates.
struct Part {
    names: Vec<String>,
    mode: Mode,
    positions: Vec<Point>,
    indices: Vec<usize>,
}

fn read_document(document: &gltf::Document, buffers: &[Vec<u8>]) -> Result<Mesh, ImportError> {
    let mut parts = Vec::new();
    let scenes: Vec<gltf::Scene> = match document.default_scene() {
        Some(s) => vec![s],
        None => document.scenes().collect(),
    };
    if scenes.is_empty() {
        for mesh in document.meshes() {
            read_mesh(&mesh, None, &Matrix4::identity(), buffers, &mut parts)?;
        }
    }
    for scene in scenes {
        for node in scene.nodes() {
            walk(&node, &Matrix4::identity(), buffers, &mut parts)?;
        }
    }
    if parts.is_empty() {
        return Err(ImportError::Gltf("glTF: no mesh primitives".into()));
    }
    weld(&parts)
}

fn walk(
    node: &gltf::Node,
    parent: &Matrix4<f64>,
    buffers: &[Vec<u8>],
    parts: &mut Vec<Part>,
) -> Result<(), ImportError> {
    let local = node.transform().matrix();
    let local = Matrix4::from_fn(|r, c| f64::from(local[c][r]));
    let world = parent * local;
    if let Some(mesh) = node.mesh() {
        read_mesh(&mesh, node.name(), &world, buffers, parts)?;
    }
    for child in node.children() {
        walk(&child, &world, buffers, parts)?;
    }
    Ok(())
}

fn read_mesh(
    mesh: &gltf::Mesh,
    node_name: Option<&str>,
    world: &Matrix4<f64>,
    buffers: &[Vec<u8>],
    parts: &mut Vec<Part>,
) -> Result<(), ImportError> {
    for primitive in mesh.primitives() {
        let reader = primitive.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let positions: Vec<Point> = reader
            .read_positions()
            .ok_or_else(|| {
                ImportError::Gltf(format!(
                    "glTF mesh `{}`: a primitive without positions",
                    mesh.name().unwrap_or("?")
                ))
            })?
            .map(|p| {
                let h = world * nalgebra::Vector4::new(p[0].into(), p[1].into(), p[2].into(), 1.0);
                Point::new(h.x, h.y, h.z) / h.w
            })
            .collect();
        if positions.iter().any(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(ImportError::Gltf("glTF: non-finite position".into()));
        }
        let indices: Vec<usize> = match reader.read_indices() {
            Some(r) => r.into_u32().map(|i| i as usize).collect(),
            None => (0..positions.len()).collect(),
        };
        if let Some(&bad) = indices.iter().find(|&&i| i >= positions.len()) {
            return Err(ImportError::Gltf(format!(
                "glTF: index {bad} beyond the primitive's {} vertices",
                positions.len()
            )));
        }
        let names = [primitive.material().name(), mesh.name(), node_name]
            .into_iter()
            .flatten()
            .map(str::to_string)
            .collect();
        parts.push(Part {
            names,
            mode: primitive.mode(),
            positions,
            indices,
        });
    }
    Ok(())
}

/// Triangles of a primitive's index list (strips and fans unrolled, consistently oriented).
fn triangles(mode: Mode, idx: &[usize]) -> Vec<[usize; 3]> {
    match mode {
        Mode::Triangles => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        Mode::TriangleStrip => (2..idx.len())
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i - 2], idx[i - 1], idx[i]]
                } else {
                    [idx[i - 1], idx[i - 2], idx[i]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..idx.len())
            .map(|i| [idx[0], idx[i - 1], idx[i]])
            .collect(),
        _ => Vec::new(),
    }
}

fn weld(parts: &[Part]) -> Result<Mesh, ImportError> {
    let (mut lo, mut hi) = (Point::repeat(f64::MAX), Point::repeat(f64::MIN));
    for p in parts.iter().flat_map(|p| &p.positions) {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let quantum = 1e-9 * (hi - lo).norm().max(f64::MIN_POSITIVE);
    let mut ids: BTreeMap<[i64; 3], usize> = BTreeMap::new();
    let mut positions = Vec::new();
    let (mut faces, mut fixed, mut excluded) = (Vec::new(), Vec::new(), Vec::new());
    for part in parts {
        let global: Vec<usize> = part
            .positions
            .iter()
            .map(|p| {
                let key = [p.x, p.y, p.z].map(|c| (c / quantum).round() as i64);
                *ids.entry(key).or_insert_with(|| {
                    positions.push(*p);
                    positions.len() - 1
                })
            })
            .collect();
        let starts = |prefix: &str| {
            part.names
                .iter()
                .any(|n| n.to_ascii_lowercase().starts_with(prefix))
        };
        let used = part.indices.iter().map(|&i| global[i]);
        match part.mode {
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan => {
                if starts("fixed") {
                    fixed.extend(used);
                } else {
                    let name = part.names.first().cloned().unwrap_or("surface".into());
                    for t in triangles(part.mode, &part.indices) {
                        faces.push((name.clone(), t.map(|i| global[i]).to_vec()));
                    }
                }
            }
            _ if starts("excluded") => excluded.extend(used),
            _ => fixed.extend(used),
        }
    }
    assemble(&positions, &faces, &fixed, &excluded)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::generators::double_bubble;

    #[test]
    fn exported_model_reads_back_with_its_surfaces() {
        let shape = double_bubble([1.0, 2.0], 3).unwrap();
        let glb = crate::cmc::export::glb(&shape.mesh).unwrap();
        let mesh = read_gltf_bytes(&glb).unwrap();
        assert_eq!(mesh.surfaces(), shape.mesh.surfaces());
        assert_eq!(mesh.triangles().len(), shape.mesh.triangles().len());
        // Junction vertices, written once per surface, are welded back.
        assert_eq!(mesh.vertex_count(), shape.mesh.vertex_count());
        assert_eq!(
            mesh.junction_vertices().len(),
            shape.mesh.junction_vertices().len()
        );
        let area = crate::cmc::area::total_area;
        assert!((area(&mesh) / area(&shape.mesh) - 1.0).abs() < 1e-6);
    }

    /// A GLB with a square film (four triangles around a raised centre, material `film`), its
    /// wire as a line loop in mesh `wire`, the centre as a point in mesh `excluded_tip`, and
    /// the film's node translated by (0, 0, 2).
    fn square_glb(first_index: u16) -> Vec<u8> {
        let points: [[f32; 3]; 5] = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 0.0, 1.0],
            [0.0, 0.0, 1.0],
            [0.5, 0.2, 0.5],
        ];
        let mut bin: Vec<u8> = points
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        let tris: [u16; 12] = [first_index, 4, 1, 1, 4, 2, 2, 4, 3, 3, 4, 0];
        bin.extend(tris.iter().flat_map(|i| i.to_le_bytes()));
        let json = serde_json::json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0, 1, 2]}],
            "nodes": [
                {"mesh": 0, "name": "film_object", "translation": [0.0, 0.0, 2.0]},
                {"mesh": 1, "translation": [0.0, 0.0, 2.0]},
                {"mesh": 2, "translation": [0.0, 0.0, 2.0]}
            ],
            "materials": [{"name": "film"}],
            "meshes": [
                {"name": "plane", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]},
                {"name": "wire", "primitives": [{"attributes": {"POSITION": 2}, "mode": 2}]},
                {"name": "excluded_tip", "primitives": [{"attributes": {"POSITION": 3}, "mode": 0}]}
            ],
            "buffers": [{"byteLength": 84}],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": 60},
                {"buffer": 0, "byteOffset": 60, "byteLength": 24}
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": 5, "type": "VEC3",
                 "min": [0.0, 0.0, 0.0], "max": [1.0, 0.2, 1.0]},
                {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"},
                {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                 "min": [0.0, 0.0, 0.0], "max": [1.0, 0.0, 1.0]},
                {"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 1, "type": "VEC3",
                 "min": [0.5, 0.2, 0.5], "max": [0.5, 0.2, 0.5]}
            ]
        });
        let mut json = serde_json::to_vec(&json).unwrap();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut glb = Vec::new();
        glb.extend(b"glTF");
        glb.extend(2u32.to_le_bytes());
        glb.extend((total as u32).to_le_bytes());
        glb.extend((json.len() as u32).to_le_bytes());
        glb.extend(b"JSON");
        glb.extend(json);
        glb.extend((bin.len() as u32).to_le_bytes());
        glb.extend(b"BIN\0");
        glb.extend(bin);
        glb
    }

    #[test]
    fn materials_name_surfaces_lines_fix_and_points_exclude() {
        let mesh = read_gltf_bytes(&square_glb(0)).unwrap();
        assert_eq!(mesh.surfaces(), ["film".to_string()]);
        assert_eq!(mesh.triangles().len(), 4);
        assert_eq!(mesh.vertex_count(), 5);
        let fixed = mesh.flags().iter().filter(|f| f.fixed).count();
        assert_eq!(fixed, 4);
        let tip = mesh
            .positions()
            .iter()
            .position(|p| (p.y - 0.2).abs() < 1e-6)
            .unwrap();
        assert!(!mesh.flags()[tip].fixed && mesh.flags()[tip].excluded);
        // Node translations applied.
        assert!(mesh.positions().iter().all(|p| p.z >= 2.0 - 1e-12));
    }

    #[test]
    fn bad_files_are_errors() {
        assert!(matches!(
            read_gltf_bytes(b"not a glb"),
            Err(ImportError::Gltf(_))
        ));
        // A triangle index beyond the primitive's five vertices.
        let e = read_gltf_bytes(&square_glb(9)).unwrap_err();
        assert!(e.to_string().contains("index 9"), "{e}");
    }
}
