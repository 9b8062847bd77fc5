//! Consistent winding of imported surfaces.
//!
//! Two faces of one surface that share an edge are consistently oriented when they traverse it
//! in opposite directions (their normals then agree by the right-hand rule). Per connected
//! patch of a surface, a breadth-first walk from its first face decides for every face whether
//! it agrees with that first face; the faces in the minority (in a patch with one reversed face,
//! that face) are the inconsistent ones, and the first of them is reported. A patch whose walk
//! meets itself with opposite verdicts is not orientable (a Möbius strip) and is reported at the
//! face where that happens. Edges shared by more than two faces of one surface are ignored.

use std::collections::{HashMap, VecDeque};

/// A face wound against its neighbours: `face` (0-based, in input order) disagrees with its
/// neighbour `neighbour` across an edge they both traverse the same way.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Inconsistent {
    /// The face to reverse.
    pub face: usize,
    /// A neighbour it disagrees with.
    pub neighbour: usize,
}

/// An undirected edge (smaller vertex first) within a named surface.
type SurfaceEdge<'a> = (&'a str, usize, usize);

/// The first inconsistently wound face of `faces` (`(surface name, polygon)` pairs), if any.
pub fn inconsistent_face(faces: &[(String, Vec<usize>)]) -> Option<Inconsistent> {
    // Undirected edge within a surface → (face, traverses it from the smaller vertex).
    let mut edges: HashMap<SurfaceEdge<'_>, Vec<(usize, bool)>> = HashMap::new();
    for (f, (surface, poly)) in faces.iter().enumerate() {
        for k in 0..poly.len() {
            let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
            edges
                .entry((surface.as_str(), a.min(b), a.max(b)))
                .or_default()
                .push((f, a < b));
        }
    }
    // Neighbours across manifold edges: (other face, same direction?).
    let mut neighbours: Vec<Vec<(usize, bool)>> = vec![Vec::new(); faces.len()];
    for users in edges.values() {
        if let [(f, df), (g, dg)] = users[..]
            && f != g
        {
            neighbours[f].push((g, df == dg));
            neighbours[g].push((f, df == dg));
        }
    }
    let mut flipped: Vec<Option<bool>> = vec![None; faces.len()];
    for start in 0..faces.len() {
        if flipped[start].is_some() {
            continue;
        }
        flipped[start] = Some(false);
        let mut patch = vec![start];
        let mut queue = VecDeque::from([start]);
        while let Some(f) = queue.pop_front() {
            let here = flipped[f].unwrap_or(false);
            for &(g, same) in &neighbours[f] {
                let want = here ^ same;
                match flipped[g] {
                    None => {
                        flipped[g] = Some(want);
                        patch.push(g);
                        queue.push_back(g);
                    }
                    Some(got) if got != want => {
                        return Some(Inconsistent {
                            face: g.max(f),
                            neighbour: g.min(f),
                        });
                    }
                    Some(_) => {}
                }
            }
        }
        let reversed: Vec<usize> = patch
            .iter()
            .copied()
            .filter(|&f| flipped[f] == Some(true))
            .collect();
        if reversed.is_empty() {
            continue;
        }
        let minority_reversed = 2 * reversed.len() <= patch.len();
        let face = patch
            .iter()
            .copied()
            .filter(|&f| (flipped[f] == Some(true)) == minority_reversed)
            .min()
            .unwrap_or(start);
        let neighbour = neighbours[face]
            .iter()
            .map(|&(g, _)| g)
            .find(|&g| flipped[g] != flipped[face])
            .unwrap_or(start);
        return Some(Inconsistent { face, neighbour });
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The eight faces of an octahedron, wound outward.
    fn octahedron() -> Vec<(String, Vec<usize>)> {
        // 0 +x, 1 −x, 2 +y, 3 −y, 4 +z, 5 −z.
        let tris = [
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        tris.iter().map(|t| ("s".to_string(), t.to_vec())).collect()
    }

    #[test]
    fn a_consistent_or_wholly_reversed_surface_passes() {
        assert_eq!(inconsistent_face(&octahedron()), None);
        let mut all = octahedron();
        for (_, t) in &mut all {
            t.reverse();
        }
        assert_eq!(inconsistent_face(&all), None);
    }

    #[test]
    fn one_reversed_face_is_named() {
        for k in 0..8 {
            let mut faces = octahedron();
            faces[k].1.reverse();
            let bad = inconsistent_face(&faces).expect("found");
            assert_eq!(bad.face, k);
            assert_ne!(bad.neighbour, k);
        }
    }

    #[test]
    fn separate_surfaces_do_not_constrain_each_other() {
        let mut faces = octahedron();
        for (name, t) in faces.iter_mut().skip(4) {
            *name = "other".into();
            t.reverse();
        }
        assert_eq!(inconsistent_face(&faces), None);
    }
}
