//! Binary glTF 2.0 (`.glb`) writer shared by all modules.
//!
//! A module describes a [`Scene`] (materials, triangle meshes, a node tree, optional animations)
//! and [`Scene::to_glb`] serializes it: one binary buffer holding every vertex, index and
//! keyframe array (4-byte aligned), a JSON chunk built with `serde_json`, and the GLB container
//! (12-byte header, JSON chunk padded with spaces, BIN chunk padded with zeros).
//!
//! Conventions (glTF's own): metres, y up, right-handed; rotations are unit quaternions stored
//! `[x, y, z, w]`; animation times in seconds; colours are linear RGBA in [0, 1].

use serde_json::{Value, json};

/// A PBR material with a flat base colour.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Display name.
    pub name: String,
    /// Linear RGBA base colour, each in [0, 1]; alpha < 1 makes the material blended.
    pub base_color: [f32; 4],
    /// Metallic factor in [0, 1].
    pub metallic: f32,
    /// Roughness factor in [0, 1].
    pub roughness: f32,
    /// Render both faces (films, membranes).
    pub double_sided: bool,
}

impl Material {
    /// A matte, single-sided material of the given colour.
    pub fn matte(name: &str, base_color: [f32; 4]) -> Self {
        Material {
            name: name.to_string(),
            base_color,
            metallic: 0.0,
            roughness: 0.8,
            double_sided: false,
        }
    }
}

/// An indexed triangle mesh with per-vertex normals and one material.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Display name.
    pub name: String,
    /// Vertex positions in metres.
    pub positions: Vec<[f32; 3]>,
    /// Unit vertex normals, one per position.
    pub normals: Vec<[f32; 3]>,
    /// Triangles, three indices each, counter-clockwise seen from the front.
    pub indices: Vec<u32>,
    /// Index into [`Scene::materials`].
    pub material: usize,
}

/// A node of the scene tree.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Display name (links, joints, surfaces).
    pub name: String,
    /// Index into [`Scene::meshes`], if the node shows one.
    pub mesh: Option<usize>,
    /// Translation relative to the parent, metres.
    pub translation: [f32; 3],
    /// Rotation relative to the parent, unit quaternion `[x, y, z, w]`.
    pub rotation: [f32; 4],
    /// Child nodes (indices into [`Scene::nodes`]).
    pub children: Vec<usize>,
    /// Application data written as the node's glTF `extras` (e.g. a beam's force, length and
    /// mass), if any.
    pub extras: Option<Value>,
}

impl Node {
    /// A node at the parent's origin showing `mesh`.
    pub fn with_mesh(name: &str, mesh: usize) -> Self {
        Node {
            name: name.to_string(),
            mesh: Some(mesh),
            translation: [0.0; 3],
            rotation: [0.0, 0.0, 0.0, 1.0],
            children: Vec::new(),
            extras: None,
        }
    }
}

/// Keyframes of one node, sampled at the animation's common times with linear interpolation.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// Index into [`Scene::nodes`].
    pub node: usize,
    /// One translation per time, or empty.
    pub translations: Vec<[f32; 3]>,
    /// One rotation per time (`[x, y, z, w]`), or empty.
    pub rotations: Vec<[f32; 4]>,
}

/// An animation: node tracks sampled at common, increasing times (seconds).
#[derive(Debug, Clone, PartialEq)]
pub struct Animation {
    /// Display name.
    pub name: String,
    /// Sample times in seconds, strictly increasing.
    pub times: Vec<f32>,
    /// Node tracks.
    pub tracks: Vec<Track>,
}

/// Everything a `.glb` file holds.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scene {
    /// Materials.
    pub materials: Vec<Material>,
    /// Meshes.
    pub meshes: Vec<Mesh>,
    /// Nodes.
    pub nodes: Vec<Node>,
    /// Nodes at the top of the tree.
    pub roots: Vec<usize>,
    /// Animations.
    pub animations: Vec<Animation>,
}

/// Why a scene cannot be written.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GltfError {
    /// An index, a count or a value is inconsistent.
    #[error("cannot write glTF: {0}")]
    Invalid(String),
}

const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// Accumulates the binary chunk and the bufferView/accessor JSON that describe it.
#[derive(Default)]
struct Blob {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Blob {
    /// Appends `data` as a new buffer view and returns its index.
    fn view(&mut self, data: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut view = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": data.len()});
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        self.bin.extend_from_slice(data);
        self.views.push(view);
        self.views.len() - 1
    }

    /// Appends float vectors of `N` components; returns the accessor index.
    fn floats<const N: usize>(
        &mut self,
        data: &[[f32; N]],
        target: Option<u32>,
        bounds: bool,
    ) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let view = self.view(&bytes, target);
        let kind = match N {
            1 => "SCALAR",
            3 => "VEC3",
            _ => "VEC4",
        };
        let mut accessor =
            json!({"bufferView": view, "componentType": FLOAT, "count": data.len(), "type": kind});
        if bounds {
            let mut min = [f32::INFINITY; N];
            let mut max = [f32::NEG_INFINITY; N];
            for v in data {
                for k in 0..N {
                    min[k] = min[k].min(v[k]);
                    max[k] = max[k].max(v[k]);
                }
            }
            accessor["min"] = json!(min.to_vec());
            accessor["max"] = json!(max.to_vec());
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    fn indices(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessors.push(json!({
            "bufferView": view, "componentType": UNSIGNED_INT, "count": data.len(), "type": "SCALAR"
        }));
        self.accessors.len() - 1
    }
}

impl Scene {
    /// Checks indices, counts and finiteness; every writer error is found here.
    fn validate(&self) -> Result<(), GltfError> {
        let bad = |s: String| Err(GltfError::Invalid(s));
        for mesh in &self.meshes {
            let n = mesh.positions.len();
            if mesh.normals.len() != n {
                return bad(format!(
                    "mesh `{}` has {} normals for {n} positions",
                    mesh.name,
                    mesh.normals.len()
                ));
            }
            if mesh.material >= self.materials.len() {
                return bad(format!("mesh `{}` names a missing material", mesh.name));
            }
            if !mesh.indices.len().is_multiple_of(3)
                || mesh.indices.iter().any(|&i| i as usize >= n)
            {
                return bad(format!("mesh `{}` has invalid triangle indices", mesh.name));
            }
            if mesh
                .positions
                .iter()
                .chain(&mesh.normals)
                .flatten()
                .any(|v| !v.is_finite())
            {
                return bad(format!("mesh `{}` has non-finite coordinates", mesh.name));
            }
        }
        for node in &self.nodes {
            if node.mesh.is_some_and(|m| m >= self.meshes.len())
                || node.children.iter().any(|&c| c >= self.nodes.len())
            {
                return bad(format!(
                    "node `{}` refers to a missing mesh or node",
                    node.name
                ));
            }
        }
        if self.roots.iter().any(|&r| r >= self.nodes.len()) {
            return bad("a scene root refers to a missing node".into());
        }
        for anim in &self.animations {
            let t = anim.times.len();
            if t == 0
                || anim.times.iter().any(|t| !t.is_finite())
                || anim.times.windows(2).any(|w| w[1] <= w[0])
            {
                return bad(format!("animation `{}` needs increasing times", anim.name));
            }
            for track in &anim.tracks {
                let counts_ok = [track.translations.len(), track.rotations.len()]
                    .iter()
                    .all(|&c| c == 0 || c == t);
                if track.node >= self.nodes.len() || !counts_ok {
                    return bad(format!(
                        "animation `{}` has an inconsistent track",
                        anim.name
                    ));
                }
            }
        }
        Ok(())
    }

    /// Serializes the scene as a binary glTF 2.0 file.
    pub fn to_glb(&self) -> Result<Vec<u8>, GltfError> {
        self.validate()?;
        let mut blob = Blob::default();
        let materials: Vec<Value> = self
            .materials
            .iter()
            .map(|m| {
                let mut v = json!({
                    "name": m.name,
                    "pbrMetallicRoughness": {
                        "baseColorFactor": m.base_color,
                        "metallicFactor": m.metallic,
                        "roughnessFactor": m.roughness
                    },
                    "doubleSided": m.double_sided
                });
                if m.base_color[3] < 1.0 {
                    v["alphaMode"] = json!("BLEND");
                }
                v
            })
            .collect();
        let meshes: Vec<Value> = self
            .meshes
            .iter()
            .map(|m| {
                let position = blob.floats(&m.positions, Some(ARRAY_BUFFER), true);
                let normal = blob.floats(&m.normals, Some(ARRAY_BUFFER), false);
                let indices = blob.indices(&m.indices);
                json!({"name": m.name, "primitives": [{
                    "attributes": {"POSITION": position, "NORMAL": normal},
                    "indices": indices, "material": m.material, "mode": 4
                }]})
            })
            .collect();
        let nodes: Vec<Value> = self
            .nodes
            .iter()
            .map(|n| {
                let mut v =
                    json!({"name": n.name, "translation": n.translation, "rotation": n.rotation});
                if let Some(mesh) = n.mesh {
                    v["mesh"] = json!(mesh);
                }
                if !n.children.is_empty() {
                    v["children"] = json!(n.children);
                }
                if let Some(extras) = &n.extras {
                    v["extras"] = extras.clone();
                }
                v
            })
            .collect();
        let animations: Vec<Value> = self
            .animations
            .iter()
            .map(|a| {
                let times: Vec<[f32; 1]> = a.times.iter().map(|&t| [t]).collect();
                let input = blob.floats(&times, None, true);
                let (mut samplers, mut channels) = (Vec::new(), Vec::new());
                for track in &a.tracks {
                    let mut add = |path: &str, output: usize| {
                        channels.push(json!({"sampler": samplers.len(), "target": {"node": track.node, "path": path}}));
                        samplers.push(json!({"input": input, "output": output, "interpolation": "LINEAR"}));
                    };
                    if !track.translations.is_empty() {
                        let output = blob.floats(&track.translations, None, false);
                        add("translation", output);
                    }
                    if !track.rotations.is_empty() {
                        let output = blob.floats(&track.rotations, None, false);
                        add("rotation", output);
                    }
                }
                json!({"name": a.name, "samplers": samplers, "channels": channels})
            })
            .collect();
        while !blob.bin.len().is_multiple_of(4) {
            blob.bin.push(0);
        }
        let mut root = json!({
            "asset": {"version": "2.0", "generator": concat!("optimize ", env!("CARGO_PKG_VERSION"))},
            "scene": 0,
            "scenes": [{"nodes": self.roots}],
            "nodes": nodes,
            "meshes": meshes,
            "materials": materials,
            "accessors": blob.accessors,
            "bufferViews": blob.views,
            "buffers": [{"byteLength": blob.bin.len()}]
        });
        if !animations.is_empty() {
            root["animations"] = json!(animations);
        }
        let mut json_chunk =
            serde_json::to_vec(&root).map_err(|e| GltfError::Invalid(e.to_string()))?;
        while !json_chunk.len().is_multiple_of(4) {
            json_chunk.push(b' ');
        }
        let total = 12 + 8 + json_chunk.len() + 8 + blob.bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json_chunk.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json_chunk);
        out.extend_from_slice(&(blob.bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&blob.bin);
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::shapes;

    fn scene() -> Scene {
        let mut scene = Scene::default();
        scene
            .materials
            .push(Material::matte("steel", [0.6, 0.6, 0.65, 1.0]));
        let mut mesh = shapes::cylinder([0.0; 3], [1.0, 2.0, 0.0], 0.1, 12);
        mesh.name = "beam".into();
        scene.meshes.push(mesh);
        scene.nodes.push(Node::with_mesh("beam", 0));
        scene.roots.push(0);
        scene.animations.push(Animation {
            name: "motion".into(),
            times: vec![0.0, 0.5, 1.0],
            tracks: vec![Track {
                node: 0,
                translations: vec![[0.0; 3], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]],
                rotations: vec![[0.0, 0.0, 0.0, 1.0]; 3],
            }],
        });
        scene
    }

    #[test]
    fn glb_reads_back_with_the_gltf_crate() {
        let scene = scene();
        let bytes = scene.to_glb().unwrap();
        let crate::io::gltf_read::Loaded {
            document: doc,
            buffers,
        } = crate::io::gltf_read::read_slice(&bytes, None).expect("valid glb");
        let mesh = doc.meshes().next().unwrap();
        let prim = mesh.primitives().next().unwrap();
        let reader = prim.reader(|b| Some(buffers[b.index()].as_slice()));
        let positions: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
        assert_eq!(positions, scene.meshes[0].positions);
        let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
        assert_eq!(indices, scene.meshes[0].indices);
        let anim = doc.animations().next().unwrap();
        assert_eq!(anim.channels().count(), 2);
        let channel = anim.channels().next().unwrap();
        let times: Vec<f32> = channel
            .reader(|b| Some(buffers[b.index()].as_slice()))
            .read_inputs()
            .unwrap()
            .collect();
        assert_eq!(times, vec![0.0, 0.5, 1.0]);
    }

    #[test]
    fn inconsistent_scenes_are_refused() {
        let mut bad = scene();
        bad.meshes[0].indices.push(10_000);
        assert!(bad.to_glb().is_err());
        let mut bad = scene();
        bad.animations[0].times = vec![0.0, 0.0, 1.0];
        assert!(bad.to_glb().is_err());
        let mut bad = scene();
        bad.meshes[0].positions[0][1] = f32::NAN;
        assert!(bad.to_glb().is_err());
    }
}
