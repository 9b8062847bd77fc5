//! Starting a cmc run from a previous result (`--start out/<name>/result.json`).
//!
//! A run writes its final mesh under `figures.mesh` of `result.json` ([`mesh_json`]):
//! `vertices_m` (x, y, z in metres), `triangles` (vertex indices) and `triangle_surface` (the
//! surface index of each triangle). [`nlp_from`] rebuilds the problem's NLP on that mesh: the
//! vertices keep the flags (fixed, excluded, guide) of the problem's start mesh, so the result
//! must have the start mesh's vertices in the same order (edge flips keep them; a refined or
//! split mesh, or another resolution, does not), with every fixed vertex where the problem puts
//! it; otherwise a one-line error names the two meshes.

use serde::Deserialize;
use serde_json::{Value, json};

use super::mesh::{Mesh, Point};
use super::nlp::CmcNlp;
use crate::error::{Error, InputError};
use crate::outcome::Previous;

/// The mesh as written under `figures.mesh`.
pub fn mesh_json(mesh: &Mesh) -> Value {
    let vertices: Vec<[f64; 3]> = mesh.positions().iter().map(|p| [p.x, p.y, p.z]).collect();
    json!({
        "vertices_m": vertices,
        "triangles": mesh.triangles(),
        "triangle_surface": mesh.triangle_surface(),
    })
}

#[derive(Deserialize)]
struct Saved {
    vertices_m: Vec<[f64; 3]>,
    triangles: Vec<[usize; 3]>,
    triangle_surface: Vec<usize>,
}

/// `start`'s problem (its volumes, chords and vertex flags) on the previous result's mesh.
pub fn nlp_from(start: &CmcNlp, previous: &Previous) -> Result<CmcNlp, Error> {
    let saved: Saved = serde_json::from_value(previous.figure("mesh")?.clone())
        .map_err(|e| previous.mismatch(format!("figures.mesh: {e}")))?;
    let mesh = start.mesh();
    let (vertices, triangles) = (saved.vertices_m.len(), saved.triangles.len());
    let other = |why: &str| -> InputError {
        previous.mismatch(format!(
            "its mesh ({} vertices, {} triangles) does not fit this problem's start mesh \
             ({} vertices, {} triangles): {why}",
            vertices,
            triangles,
            mesh.vertex_count(),
            mesh.triangles().len()
        ))
    };
    if saved.vertices_m.len() != mesh.vertex_count() {
        return Err(other("--start needs the same vertices (not a refined mesh)").into());
    }
    let positions: Vec<Point> = saved.vertices_m.iter().map(|&p| Point::from(p)).collect();
    let moved_fixed = (mesh.positions().iter().zip(&positions))
        .zip(mesh.flags())
        .any(|((a, b), f)| f.fixed && (a - b).norm() > 1e-9 * (1.0 + a.norm()));
    if moved_fixed {
        return Err(other("its fixed vertices are elsewhere").into());
    }
    let moved = Mesh::new(
        positions,
        saved.triangles,
        saved.triangle_surface,
        mesh.surfaces().to_vec(),
        mesh.flags().to_vec(),
        mesh.guides().to_vec(),
    )
    .map_err(|e| other(&e.to_string()))?;
    start
        .remeshed(moved)
        .map_err(|e| Error::Runtime(format!("{}: {e}", previous.path.display())))
}
