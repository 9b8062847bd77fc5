//! Start meshes from Wavefront OBJ files, so start shapes can be modelled in Blender or Maya.
//!
//! Read: `v x y z` (metres), `f` polygons (`i`, `i/t`, `i//n`, `i/t/n`; negative indices count
//! back; polygons are split into fans), `o` and `g` names, `l` polylines and `p` points. Other
//! statements (`vn`, `vt`, `usemtl`, `mtllib`, `s`, comments) are ignored.
//!
//! Naming convention:
//! - faces belong to the surface named by the most recent `g` (or, without one, `o`) statement;
//!   faces before any name go to surface `surface`;
//! - `l` and `p` elements (Blender exports loose edges and loose vertices this way) mark wires:
//!   their vertices are fixed, unless the current group name starts with `excluded`, in which
//!   case they are only excluded from curvature constraints;
//! - faces in a group whose name starts with `fixed` are not films: their vertices are fixed;
//! - vertices that end up in no film are dropped.
//!
//! Checks shared with the glTF reader (`assemble`): at most [`MAX_IMPORT_SIZE`] vertices and
//! as many faces, and every surface consistently wound ([`super::orientation`]): a face wound
//! against its neighbours is an error naming it (reorienting silently would hide a modelling
//! mistake, and which side is "out" is the modeller's choice, checked against the volumes'
//! signs when the problem is built).

use std::collections::BTreeMap;

use super::mesh::{Mesh, MeshBuilder, MeshError, Point};
use super::orientation::inconsistent_face;

/// Why an OBJ file could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ImportError {
    /// A statement could not be parsed.
    #[error("line {line}: {message}")]
    Syntax {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The mesh is degenerate.
    #[error("{0}")]
    Mesh(#[from] MeshError),
    /// A glTF file could not be read or lacks what a start mesh needs.
    #[error("{0}")]
    Gltf(String),
    /// A face is wound against its neighbours in the same surface.
    #[error(
        "face {} of surface `{surface}` is wound against its neighbour face {} (they traverse \
         a shared edge in the same direction); reverse it",
        face + 1,
        neighbour + 1
    )]
    Orientation {
        /// 0-based face index, in file order.
        face: usize,
        /// 0-based index of a neighbour it disagrees with.
        neighbour: usize,
        /// The surface both belong to.
        surface: String,
    },
    /// The mesh is larger than [`MAX_IMPORT_SIZE`].
    #[error("the mesh has more than {MAX_IMPORT_SIZE} {what}")]
    TooLarge {
        /// "vertices" or "faces".
        what: &'static str,
    },
}

/// Most vertices, and most faces, an imported mesh may have.
pub const MAX_IMPORT_SIZE: usize = 200_000;

/// Reads an OBJ text into a mesh (see the module header for the conventions).
pub fn read_obj(text: &str) -> Result<Mesh, ImportError> {
    let mut positions: Vec<Point> = Vec::new();
    let mut faces: Vec<(String, Vec<usize>)> = Vec::new();
    let mut fixed: Vec<usize> = Vec::new();
    let mut excluded: Vec<usize> = Vec::new();
    let mut group = String::from("surface");
    let mut has_group = false;
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let err = |message: String| ImportError::Syntax { line, message };
        let content = raw.split('#').next().unwrap_or("").trim();
        let mut words = content.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        let rest: Vec<&str> = words.collect();
        match keyword {
            "v" => {
                if rest.len() < 3 {
                    return Err(err("a vertex needs three coordinates".into()));
                }
                let c: Result<Vec<f64>, _> = rest[..3].iter().map(|w| w.parse::<f64>()).collect();
                let c = c.map_err(|_| err(format!("bad coordinate in `{content}`")))?;
                if c.iter().any(|v| !v.is_finite()) {
                    return Err(err("non-finite coordinate".into()));
                }
                if positions.len() == MAX_IMPORT_SIZE {
                    return Err(ImportError::TooLarge { what: "vertices" });
                }
                positions.push(Point::new(c[0], c[1], c[2]));
            }
            "f" | "l" | "p" => {
                let indices: Result<Vec<usize>, ImportError> = rest
                    .iter()
                    .map(|w| resolve(w, positions.len()).map_err(&err))
                    .collect();
                let indices = indices?;
                let lower = group.to_ascii_lowercase();
                if keyword == "f" {
                    if indices.len() < 3 {
                        return Err(err("a face needs at least three vertices".into()));
                    }
                    if lower.starts_with("fixed") {
                        fixed.extend(&indices);
                    } else if faces.len() == MAX_IMPORT_SIZE {
                        return Err(ImportError::TooLarge { what: "faces" });
                    } else {
                        faces.push((group.clone(), indices));
                    }
                } else if lower.starts_with("excluded") {
                    excluded.extend(&indices);
                } else {
                    fixed.extend(&indices);
                }
            }
            "g" | "o" => {
                let name = rest.join(" ");
                if keyword == "g" || !has_group {
                    group = if name.is_empty() {
                        "surface".into()
                    } else {
                        name
                    };
                }
                has_group |= keyword == "g";
            }
            _ => {}
        }
    }
    assemble(&positions, &faces, &fixed, &excluded)
}

/// Builds the mesh of imported polygons: `faces` are `(surface name, vertex indices)` polygons
/// (split into fans), `fixed` and `excluded` flag vertices. Only vertices used by faces are
/// kept, renumbered in order of first use. Shared by the OBJ and glTF readers, it checks the
/// sizes and the winding (module header).
pub(super) fn assemble(
    positions: &[Point],
    faces: &[(String, Vec<usize>)],
    fixed: &[usize],
    excluded: &[usize],
) -> Result<Mesh, ImportError> {
    if positions.len() > MAX_IMPORT_SIZE {
        return Err(ImportError::TooLarge { what: "vertices" });
    }
    if faces.len() > MAX_IMPORT_SIZE {
        return Err(ImportError::TooLarge { what: "faces" });
    }
    if let Some(bad) = inconsistent_face(faces) {
        return Err(ImportError::Orientation {
            face: bad.face,
            neighbour: bad.neighbour,
            surface: faces[bad.face].0.clone(),
        });
    }
    let mut builder = MeshBuilder::new();
    let mut renumber: BTreeMap<usize, usize> = BTreeMap::new();
    for (name, poly) in faces {
        let s = builder.surface(name);
        let ids: Vec<usize> = poly
            .iter()
            .map(|&v| {
                *renumber
                    .entry(v)
                    .or_insert_with(|| builder.vertex(positions[v]))
            })
            .collect();
        for i in 1..ids.len() - 1 {
            builder.triangle(s, [ids[0], ids[i], ids[i + 1]]);
        }
    }
    for v in fixed {
        if let Some(&id) = renumber.get(v) {
            builder.flags_mut(id).fixed = true;
        }
    }
    for v in excluded {
        if let Some(&id) = renumber.get(v) {
            builder.flags_mut(id).excluded = true;
        }
    }
    Ok(builder.build()?)
}

/// A 0-based vertex index from an OBJ reference (`7`, `7/1`, `7//2`, `-1`).
fn resolve(word: &str, count: usize) -> Result<usize, String> {
    let first = word.split('/').next().unwrap_or("");
    let i: i64 = first
        .parse()
        .map_err(|_| format!("bad vertex reference `{word}`"))?;
    let index = if i > 0 {
        i - 1
    } else if i < 0 {
        count as i64 + i
    } else {
        -1
    };
    if index < 0 || index >= count as i64 {
        return Err(format!(
            "vertex reference `{word}` is out of range (only {count} vertices so far)"
        ));
    }
    Ok(index as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SQUARE_FILM: &str = "\
# a unit square film with a raised centre, wire around it
o frame
v 0 0 0
v 1 0 0
v 1 0 1
v 0 0 1
v 0.5 0.2 0.5
g film
f 1 2 5
f 2/1 3/2 5/3
f 3//1 4//1 5//1
f -2 -5 -1
g wire
l 1 2 3 4 1
g excluded tip
p 5
";

    #[test]
    fn groups_become_surfaces_and_wires_become_fixed() {
        let mesh = read_obj(SQUARE_FILM).unwrap();
        assert_eq!(mesh.surfaces(), ["film".to_string()]);
        assert_eq!(mesh.triangles().len(), 4);
        let fixed: Vec<bool> = mesh.flags().iter().map(|f| f.fixed).collect();
        assert_eq!(fixed.iter().filter(|&&f| f).count(), 4);
        let tip = mesh
            .positions()
            .iter()
            .position(|p| (p.y - 0.2).abs() < 1e-15)
            .unwrap();
        assert!(!mesh.flags()[tip].fixed && mesh.flags()[tip].excluded);
    }

    #[test]
    fn bad_files_report_their_line() {
        let e = read_obj("v 0 0 0\nv 1 0 0\nf 1 2 3\n").unwrap_err();
        assert!(matches!(e, ImportError::Syntax { line: 3, .. }), "{e}");
        let e = read_obj("v 0 0 x\n").unwrap_err();
        assert!(matches!(e, ImportError::Syntax { line: 1, .. }), "{e}");
        let e = read_obj("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").unwrap_err();
        assert!(
            matches!(e, ImportError::Mesh(MeshError::Degenerate(0))),
            "{e}"
        );
    }
}
