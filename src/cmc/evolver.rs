//! Surface Evolver datafiles (Brakke 1992, "The Surface Evolver", Experimental Mathematics
//! 1(2)) of a CMC start mesh, so the same mesh can be minimized by both programs.
//!
//! Written: `vertices` (coordinates times `scale`, `fixed` for fixed vertices), `edges` (each
//! mesh edge once, `fixed` when both ends are fixed: wire segments), `facets` (each triangle as
//! its three signed edges, in the triangle's orientation) and `bodies` (each volume constraint
//! as its signed facets with `volume` times `scale³`). Evolver's default surface tension 1 makes
//! its energy the total area (in scaled units: m² times `scale²`).
//!
//! Only what both programs mean the same way is exported: meshes with guided vertices (curve
//! and plane constraints) or volume regions closed by a fixed plane (open regions, whose
//! volume needs Evolver content integrals) are refused. Excluded vertices carry no curvature
//! constraint here; Evolver has no such constraint at all, so they export as free vertices.

use std::collections::BTreeMap;
use std::fmt::Write;

use super::mesh::Mesh;
use super::nlp::VolumeConstraint;
use super::volume::Region;

/// Why a mesh cannot be written as an Evolver datafile.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EvolverError {
    /// The mesh uses a feature the exporter does not translate.
    #[error("not exported to Surface Evolver: {0}")]
    Unsupported(String),
}

/// The datafile text of `mesh` with `volumes`, lengths multiplied by `scale`.
pub fn datafile(
    mesh: &Mesh,
    volumes: &[VolumeConstraint],
    scale: f64,
) -> Result<String, EvolverError> {
    if !mesh.guides().is_empty() {
        return Err(EvolverError::Unsupported(
            "vertices guided along curves or planes".into(),
        ));
    }
    let mut text = String::new();
    let _ = writeln!(
        text,
        "// Exported by optimize (cmc::evolver); lengths × {scale}."
    );
    let _ = writeln!(text, "\nvertices");
    for (v, p) in mesh.positions().iter().enumerate() {
        let fixed = if mesh.flags()[v].fixed { " fixed" } else { "" };
        let _ = writeln!(
            text,
            "{} {:.17e} {:.17e} {:.17e}{fixed}",
            v + 1,
            p.x * scale,
            p.y * scale,
            p.z * scale
        );
    }
    let _ = writeln!(text, "\nedges");
    let mut edge_ids: BTreeMap<(usize, usize), usize> = BTreeMap::new();
    for (e, edge) in mesh.edges().iter().enumerate() {
        let [a, b] = edge.vertices;
        edge_ids.insert((a, b), e + 1);
        let fixed = mesh.flags()[a].fixed && mesh.flags()[b].fixed;
        let _ = writeln!(
            text,
            "{} {} {}{}",
            e + 1,
            a + 1,
            b + 1,
            if fixed { " fixed" } else { "" }
        );
    }
    let signed_edge = |a: usize, b: usize| match edge_ids.get(&(a, b)) {
        Some(&id) => id as i64,
        None => -(edge_ids[&(b, a)] as i64),
    };
    let _ = writeln!(text, "\nfacets");
    for (t, &[a, b, c]) in mesh.triangles().iter().enumerate() {
        let _ = writeln!(
            text,
            "{} {} {} {}",
            t + 1,
            signed_edge(a, b),
            signed_edge(b, c),
            signed_edge(c, a)
        );
    }
    if !volumes.is_empty() {
        let _ = writeln!(text, "\nbodies");
    }
    for (k, v) in volumes.iter().enumerate() {
        if !is_closed(mesh, &v.region) {
            return Err(EvolverError::Unsupported(format!(
                "volume `{}` is closed by a fixed plane",
                v.name
            )));
        }
        let _ = write!(text, "{}", k + 1);
        for &(s, sign) in &v.region.boundary {
            for t in mesh.surface_triangles(s) {
                let id = (t + 1) as i64;
                let _ = write!(text, " {}", if sign < 0.0 { -id } else { id });
            }
        }
        match v.pressure {
            // −p·V: p scales as 1/length.
            Some(p) => writeln!(text, " pressure {:.17e}", p / scale),
            None => writeln!(text, " volume {:.17e}", v.target * scale.powi(3)),
        }
        .ok();
    }
    Ok(text)
}

/// Whether the signed boundary surfaces of `region` close up: every edge is traversed as often
/// in one direction as in the other (signs applied).
fn is_closed(mesh: &Mesh, region: &Region) -> bool {
    let mut net: BTreeMap<(usize, usize), i64> = BTreeMap::new();
    for &(s, sign) in &region.boundary {
        let sign = if sign < 0.0 { -1 } else { 1 };
        for t in mesh.surface_triangles(s) {
            let tri = mesh.triangles()[t];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let direction = if a < b { 1 } else { -1 };
                *net.entry((a.min(b), a.max(b))).or_default() += sign * direction;
            }
        }
    }
    net.values().all(|&n| n == 0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::generators::{cube_frame, double_bubble};
    use crate::cmc::octahedron::{OctahedronTopology, octahedron_frame};

    fn constraints(shape: &crate::cmc::generators::Shape) -> Vec<VolumeConstraint> {
        shape
            .volumes
            .iter()
            .map(|(name, region, target)| {
                VolumeConstraint::with_target(name.clone(), region.clone(), *target)
            })
            .collect()
    }

    /// Vertex count, edges, facets (signed edges) and bodies (signed facets) of a datafile.
    type Sections = (usize, Vec<[usize; 2]>, Vec<[i64; 3]>, Vec<Vec<i64>>);

    /// Parses a datafile back into its sections.
    fn reread(text: &str) -> Sections {
        let mut section = "";
        let (mut vertices, mut edges, mut facets, mut bodies) = (0, vec![], vec![], vec![]);
        for line in text.lines() {
            let words: Vec<&str> = line.split_whitespace().collect();
            match words.as_slice() {
                [] => {}
                [w] if ["vertices", "edges", "facets", "bodies"].contains(w) => section = w,
                _ if words[0].starts_with("//") => {}
                _ => match section {
                    "vertices" => vertices += 1,
                    "edges" => edges.push([words[1].parse().unwrap(), words[2].parse().unwrap()]),
                    "facets" => facets.push([1, 2, 3].map(|i| words[i].parse().unwrap())),
                    _ => bodies.push(
                        words[1..words.len() - 2]
                            .iter()
                            .map(|w| w.parse().unwrap())
                            .collect(),
                    ),
                },
            }
        }
        (vertices, edges, facets, bodies)
    }

    #[test]
    fn facets_are_closed_loops_of_signed_edges() {
        let shape = double_bubble([1.0, 2.0], 3).unwrap();
        let text = datafile(&shape.mesh, &constraints(&shape), 10.0).unwrap();
        let (vertices, edges, facets, bodies) = reread(&text);
        assert_eq!(vertices, shape.mesh.vertex_count());
        assert_eq!(facets.len(), shape.mesh.triangles().len());
        let ends = |e: i64| {
            let [a, b] = edges[(e.unsigned_abs() - 1) as usize];
            if e > 0 { [a, b] } else { [b, a] }
        };
        for (t, f) in facets.iter().enumerate() {
            let tri = shape.mesh.triangles()[t];
            for k in 0..3 {
                assert_eq!(ends(f[k])[1], ends(f[(k + 1) % 3])[0], "facet {t}");
                assert_eq!(ends(f[k])[0], tri[k] + 1, "facet {t}");
            }
        }
        // The left bubble: its cap and the wall, 2 surfaces of 6·3² triangles each.
        assert_eq!(bodies.len(), 2);
        assert_eq!(bodies[0].len(), 2 * 6 * 9);
        assert!(text.contains(&format!("volume {:.17e}", 1000.0)));
    }

    #[test]
    fn wires_are_fixed_and_unsupported_meshes_refused() {
        let shape = cube_frame(1.0, Some(0.05), 2).unwrap();
        let text = datafile(&shape.mesh, &constraints(&shape), 1.0).unwrap();
        let fixed_edges = text
            .lines()
            .skip_while(|l| *l != "edges")
            .take_while(|l| *l != "facets")
            .filter(|l| l.ends_with("fixed"))
            .count();
        assert_eq!(fixed_edges, 12 * 2);
        let octa = octahedron_frame(1.0, OctahedronTopology::Tetrahedral, 2).unwrap();
        assert!(datafile(&octa.mesh, &[], 1.0).is_ok());
        let mut guided = shape.mesh.clone();
        guided.add_guide(crate::cmc::mesh::Guide::Plane {
            point: crate::cmc::mesh::Point::zeros(),
            normal: crate::cmc::mesh::Point::y(),
        });
        assert!(datafile(&guided, &[], 1.0).is_err());
    }
}
