//! Topology events (Surface Evolver's `O` and `o`): popping the junctions a soap film cannot
//! keep.
//!
//! Plateau's laws allow three kinds of point in a film of equal tensions. Seen on a small
//! sphere around the point, the films cut a network (the point's *link*), which is
//! - a circle: the point lies inside one sheet;
//! - a theta graph (two nodes joined by three arcs): a triple line, three sheets at 120°;
//! - the complete graph K₄: a tetrahedral point, four triple lines at 109.47°.
//!
//! Any other junction is *non-minimal*: an edge shared by four or more sheets, or a vertex
//! whose link is another network (the centre of the cone over the octahedral or the cubical
//! frame). A small change of topology lowers the area there, so a film with such a junction is
//! at best a critical point of its fixed-topology problem, never a soap film; the stability
//! analysis of that problem cannot see it, since the instability is topological.
//!
//! [`census`] finds them: *lines* (maximal chains of edges with four or more triangles, free
//! vertices inside; edges between two fixed vertices are wires and may carry any number of
//! sheets) and *vertices* (free vertices off those lines whose link is not one of the three).
//!
//! [`pop`] changes the topology as Surface Evolver does:
//! - **Line** with k ≥ 4 sheets (in their cyclic order around it): the two neighbouring sheets
//!   with the smallest angle between them (summed along the line) are split off onto a new
//!   triple line, joined to the rest by a new strip of film between the two cells that become
//!   neighbours. Every free vertex inside the line becomes two, moved [`POP_OFFSET`] of its
//!   shortest edge apart, into the narrow cell and away from it; the line's end vertices
//!   stay and close the strip. A line of one edge is bisected first. The rest of the line has
//!   k − 1 sheets and is popped again while k − 1 ≥ 4.
//! - **Vertex**: the vertex is replaced by a small sphere of radius [`POP_RADIUS`] of its
//!   shortest edge; the sheets into it are truncated at the sphere, which the cut network
//!   divides into one region per cell around the vertex, and the largest region (by solid
//!   angle) is removed, which keeps every cell's connections (Surface Evolver's rule). Each
//!   other region becomes a patch of film: a fan of triangles from a vertex on the sphere.
//!
//! New films join the surface of the films at the junction when these are one surface, else
//! they are new surfaces (`popped line k`, `popped vertex k`). Films bounding a body
//! (a volume or pressure region) are not popped: the new films would have to join the bodies'
//! boundaries; such junctions are counted by the census and left as they are, as are
//! vertices whose link is disconnected (two cones touching) or has a face that is not a simple
//! polygon.

use std::collections::{BTreeMap, BTreeSet};

use super::mesh::{Mesh, MeshError, Point, VertexFlags, orthonormal_pair};
use super::remesh::ordered;

/// How far each copy of a popped line's vertex moves off the old line (on opposite sides), as
/// a fraction of the vertex's shortest edge.
pub const POP_OFFSET: f64 = 0.2;

/// Radius of the sphere that replaces a popped vertex, as a fraction of its shortest edge.
pub const POP_RADIUS: f64 = 0.3;

/// At most this many topology changes per [`pop`] (a line's split counts one): a guard, far
/// above what a film has (the octahedral cone needs six splits and one vertex).
pub const MAX_POPS: usize = 1_000;

/// The non-minimal junctions of a mesh ([`census`]).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Census {
    /// Lines of edges with four or more sheets: their vertices in order along the line.
    pub lines: Vec<Vec<usize>>,
    /// Free vertices off those lines whose link is neither a circle, a theta graph nor K₄.
    pub vertices: Vec<usize>,
}

impl Census {
    /// Whether the film has no non-minimal junction.
    pub fn is_minimal(&self) -> bool {
        self.lines.is_empty() && self.vertices.is_empty()
    }
}

/// One topology change made by [`pop`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PopEvent {
    /// `"line"` or `"vertex"`.
    pub kind: &'static str,
    /// Where (m): the line's middle vertex or the vertex.
    pub at: [f64; 3],
    /// Sheets on the line before the split, or cells around the vertex.
    pub sheets: usize,
    /// Triangles of the new film.
    pub new_triangles: usize,
}

/// Why a mesh could not be popped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PopError {
    /// More than [`MAX_POPS`] changes.
    #[error("more than {MAX_POPS} topology changes: the junctions do not resolve")]
    TooMany,
}

/// The non-minimal junctions of `mesh` (module header), whatever their surfaces.
pub fn census(mesh: &Mesh) -> Census {
    let lines = lines(mesh);
    let mut on_line = vec![false; mesh.vertex_count()];
    for line in &lines {
        for &v in &line[1..line.len() - 1] {
            on_line[v] = true;
        }
    }
    let vertices = (0..mesh.vertex_count())
        .filter(|&v| !on_line[v] && free(mesh, v) && !link_is_minimal(mesh, v))
        .collect();
    Census { lines, vertices }
}

/// Pops every non-minimal junction of `mesh` whose films bound no body (`bounding[s]` true for
/// the surfaces that bound one): lines first, then vertices (module header). Returns the new
/// mesh and the events; the mesh is `mesh` itself when nothing could be popped.
pub fn pop(mesh: &Mesh, bounding: &[bool]) -> Result<(Mesh, Vec<PopEvent>), PopError> {
    let mut current = mesh.clone();
    let mut events = Vec::new();
    pop_each(
        &mut current,
        &mut events,
        bounding,
        lines,
        |mesh, line, index| {
            match line.as_slice() {
                // A line of one edge: bisected, then split through its midpoint.
                &[a, b] => {
                    let bisected = bisect(mesh, a, b)?;
                    let middle = bisected.vertex_count() - 1;
                    split_line(&bisected, &[a, middle, b], index)
                }
                _ => split_line(mesh, line, index),
            }
        },
    )?;
    pop_each(
        &mut current,
        &mut events,
        bounding,
        |mesh| census(mesh).vertices.into_iter().map(|v| vec![v]).collect(),
        |mesh, v, index| pop_vertex(mesh, v[0], index),
    )?;
    Ok((current, events))
}

/// Pops the junctions `candidates` finds (each as its vertices) one at a time with `attempt`
/// until none is left that touches no body and has not been refused (`attempt` gave `None`),
/// finding them anew after each change; the events are appended to `events`.
fn pop_each(
    current: &mut Mesh,
    events: &mut Vec<PopEvent>,
    bounding: &[bool],
    candidates: impl Fn(&Mesh) -> Vec<Vec<usize>>,
    attempt: impl Fn(&Mesh, &Vec<usize>, usize) -> Result<Option<(Mesh, PopEvent)>, MeshError>,
) -> Result<(), PopError> {
    let mut refused = Vec::new();
    loop {
        if events.len() >= MAX_POPS {
            return Err(PopError::TooMany);
        }
        let Some(junction) = candidates(current)
            .into_iter()
            .find(|j| !refused.contains(j) && !touches_body(current, j, bounding))
        else {
            return Ok(());
        };
        // A change whose mesh is invalid (a zero-area triangle) is refused like one that
        // does not apply.
        match attempt(current, &junction, events.len() + 1) {
            Ok(Some((next, event))) => {
                *current = next;
                events.push(event);
            }
            Ok(None) | Err(_) => refused.push(junction),
        }
    }
}

/// Whether `v` may move freely (not fixed, not guided): only such vertices are junctions that
/// can pop.
fn free(mesh: &Mesh, v: usize) -> bool {
    let f = mesh.flags()[v];
    !f.fixed && f.guide.is_none()
}

/// Whether a triangle at one of `vertices` lies in a surface that bounds a body.
fn touches_body(mesh: &Mesh, vertices: &[usize], bounding: &[bool]) -> bool {
    vertices.iter().any(|&v| {
        mesh.vertex_triangles(v)
            .iter()
            .any(|&t| bounding.get(mesh.triangle_surface()[t]) == Some(&true))
    })
}

/// The vertex of triangle `t` that is neither `a` nor `b`.
fn third(mesh: &Mesh, t: usize, a: usize, b: usize) -> usize {
    *mesh.triangles()[t]
        .iter()
        .find(|&&w| w != a && w != b)
        .expect("a triangle has three distinct vertices")
}

/// The triangles of the edge `a`–`b` sorted by the angle (rad) of their third vertex about
/// the axis `b − a` (right-handed), with the angles.
fn sheets_around(mesh: &Mesh, a: usize, b: usize, triangles: &[usize]) -> Vec<(usize, f64)> {
    let p = mesh.positions();
    let axis = (p[b] - p[a]).normalize();
    let (e1, e2) = orthonormal_pair(&axis);
    let mut sheets: Vec<(usize, f64)> = triangles
        .iter()
        .map(|&t| {
            let r = p[third(mesh, t, a, b)] - p[a];
            (t, r.dot(&e2).atan2(r.dot(&e1)))
        })
        .collect();
    sheets.sort_by(|x, y| x.1.total_cmp(&y.1).then(x.0.cmp(&y.0)));
    sheets
}

/// Lines of edges with four or more triangles (not between two fixed vertices), as vertex
/// chains. A chain runs through free vertices on exactly two such edges of the same
/// valence; it ends elsewhere (closed loops start and end at their smallest vertex).
fn lines(mesh: &Mesh) -> Vec<Vec<usize>> {
    let flags = mesh.flags();
    let high: Vec<usize> = (0..mesh.edges().len())
        .filter(|&k| {
            let e = &mesh.edges()[k];
            e.triangles.len() >= 4 && !(flags[e.vertices[0]].fixed && flags[e.vertices[1]].fixed)
        })
        .collect();
    let mut at: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for &k in &high {
        for v in mesh.edges()[k].vertices {
            at.entry(v).or_default().push(k);
        }
    }
    let valence = |k: usize| mesh.edges()[k].triangles.len();
    let other = |k: usize, v: usize| {
        let [a, b] = mesh.edges()[k].vertices;
        if a == v { b } else { a }
    };
    // Inside a line: free, on two edges of the same valence, its star one fan per sheet.
    let through = |v: usize| {
        at.get(&v).is_some_and(|ks| {
            ks.len() == 2
                && valence(ks[0]) == valence(ks[1])
                && free(mesh, v)
                && fans_at(mesh, v, other(ks[0], v), other(ks[1], v))
                    .is_some_and(|fans| fans.len() == valence(ks[0]))
        })
    };
    let inner: BTreeSet<usize> = at.keys().copied().filter(|&v| through(v)).collect();
    let mut used = vec![false; mesh.edges().len()];
    let mut chains = Vec::new();
    // Open chains from their ends first, then the closed loops left.
    let ends = at.keys().copied().filter(|v| !inner.contains(v));
    for start in ends.chain(inner.iter().copied()) {
        for &first in &at[&start] {
            if used[first] {
                continue;
            }
            let mut chain = vec![start];
            let (mut v, mut k) = (start, first);
            loop {
                used[k] = true;
                let next = other(k, v);
                chain.push(next);
                if next == start || !inner.contains(&next) {
                    break;
                }
                let Some(&onward) = at[&next].iter().find(|&&j| !used[j]) else {
                    break;
                };
                (v, k) = (next, onward);
            }
            chains.push(chain);
        }
    }
    chains
}

/// The mesh with the edge `a`–`b` bisected: a new free vertex at its midpoint, every triangle
/// on it split in two.
fn bisect(mesh: &Mesh, a: usize, b: usize) -> Result<Mesh, MeshError> {
    let mut edit = Surgery::of(mesh);
    let flags = mesh.flags();
    let m = edit.vertex(
        (mesh.positions()[a] + mesh.positions()[b]) / 2.0,
        VertexFlags {
            excluded: flags[a].excluded && flags[b].excluded,
            ..VertexFlags::default()
        },
    );
    for (t, &tri) in mesh.triangles().iter().enumerate() {
        let Some((p, q, r)) = ordered(tri, [a, b]) else {
            continue;
        };
        edit.triangles[t] = [p, m, r];
        edit.triangle([m, q, r], mesh.triangle_surface()[t]);
    }
    edit.build()
}

/// The shortest edge at `v`, m.
fn shortest_edge(mesh: &Mesh, v: usize) -> f64 {
    let p = mesh.positions();
    mesh.neighbours(v)
        .iter()
        .map(|&w| (p[w] - p[v]).norm())
        .fold(f64::INFINITY, f64::min)
}

/// Splits the two closest sheets off the line `chain` (at least three vertices) onto a new
/// triple line joined to the rest by a strip of film (module header); `None` when a vertex
/// inside the line does not have one fan of triangles per sheet.
fn split_line(
    mesh: &Mesh,
    chain: &[usize],
    index: usize,
) -> Result<Option<(Mesh, PopEvent)>, MeshError> {
    let m = chain.len() - 1;
    let edge_triangles = |i: usize| -> Vec<usize> {
        let (a, b) = (chain[i], chain[i + 1]);
        mesh.vertex_triangles(a)
            .iter()
            .copied()
            .filter(|&t| mesh.triangles()[t].contains(&b))
            .collect()
    };
    // Sheet j's triangle on edge i, following the fans through the inner vertices.
    let first = sheets_around(mesh, chain[0], chain[1], &edge_triangles(0));
    let k = first.len();
    let mut sheet_triangles: Vec<Vec<usize>> = vec![first.iter().map(|s| s.0).collect()];
    let mut fans: Vec<Vec<Vec<usize>>> = Vec::new();
    for i in 1..m {
        let Some(vertex_fans) = fans_at(mesh, chain[i], chain[i - 1], chain[i + 1]) else {
            return Ok(None);
        };
        if vertex_fans.len() != k {
            return Ok(None);
        }
        let next_edge = edge_triangles(i);
        let mut order = Vec::with_capacity(k);
        let mut sheet_fans = Vec::with_capacity(k);
        for &t in &sheet_triangles[i - 1] {
            let Some(fan) = vertex_fans.iter().find(|f| f.contains(&t)) else {
                return Ok(None);
            };
            let on_next: Vec<usize> = fan
                .iter()
                .copied()
                .filter(|t| next_edge.contains(t))
                .collect();
            if on_next.len() != 1 {
                return Ok(None);
            }
            order.push(on_next[0]);
            sheet_fans.push(fan.clone());
        }
        sheet_triangles.push(order);
        fans.push(sheet_fans);
    }
    // The cell between sheets c and c + 1 with the smallest angle summed along the line.
    let p = mesh.positions();
    let mut gaps = vec![0.0; k];
    for (i, triangles) in sheet_triangles.iter().enumerate() {
        let (a, b) = (chain[i], chain[i + 1]);
        let angles: BTreeMap<usize, f64> =
            sheets_around(mesh, a, b, triangles).into_iter().collect();
        for (c, gap) in gaps.iter_mut().enumerate() {
            let d = angles[&triangles[(c + 1) % k]] - angles[&triangles[c]];
            *gap += d.rem_euclid(std::f64::consts::TAU);
        }
    }
    let c = (0..k)
        .min_by(|&x, &y| gaps[x].total_cmp(&gaps[y]).then(x.cmp(&y)))
        .expect("a line has sheets");
    let split_off = [c, (c + 1) % k];

    let mut edit = Surgery::of(mesh);
    let line_triangles: Vec<usize> = sheet_triangles.iter().flatten().copied().collect();
    let strip = edit.new_film_surface(mesh, &line_triangles, "line", index);
    // (the split-off copy, the other copy) of each line vertex; the ends are not split.
    let mut copies: Vec<(usize, usize)> = chain.iter().map(|&v| (v, v)).collect();
    for i in 1..m {
        let v = chain[i];
        let axis = (p[chain[i + 1]] - p[chain[i - 1]]).normalize();
        let across = |t: usize| {
            let w = third(mesh, t, chain[i], chain[i + 1]);
            let r = p[w] - p[v];
            (r - axis * r.dot(&axis)).normalize()
        };
        let bisector =
            across(sheet_triangles[i][split_off[0]]) + across(sheet_triangles[i][split_off[1]]);
        let bisector = if bisector.norm() > 1e-9 {
            bisector.normalize()
        } else {
            orthonormal_pair(&axis).0
        };
        let offset = POP_OFFSET * shortest_edge(mesh, v);
        edit.positions[v] = p[v] + bisector * offset;
        let other = edit.vertex(p[v] - bisector * offset, mesh.flags()[v]);
        copies[i] = (v, other);
        for (j, fan) in fans[i - 1].iter().enumerate() {
            if split_off.contains(&j) {
                continue;
            }
            for &t in fan {
                for corner in edit.triangles[t].iter_mut() {
                    if *corner == v {
                        *corner = other;
                    }
                }
            }
        }
    }
    let before = edit.triangles.len();
    for i in 0..m {
        let ((a1, a2), (b1, b2)) = (copies[i], copies[i + 1]);
        let quad: Vec<[usize; 3]> = match (a1 == a2, b1 == b2) {
            (true, true) => Vec::new(),
            (true, false) => vec![[a1, b1, b2]],
            (false, true) => vec![[a1, b1, a2]],
            (false, false) => vec![[a1, b1, b2], [a1, b2, a2]],
        };
        for tri in quad {
            edit.triangle(tri, strip);
        }
    }
    edit.finish("line", &p[chain[m / 2]], k, before).map(Some)
}

/// The fans of triangles around the inner line vertex `v` (its line neighbours `prev` and
/// `next`): the star's triangles joined across the edges from `v` to other vertices; `None`
/// when a fan does not hold exactly one triangle of each line edge.
fn fans_at(mesh: &Mesh, v: usize, prev: usize, next: usize) -> Option<Vec<Vec<usize>>> {
    let star = mesh.vertex_triangles(v);
    let mut fan_of: Vec<usize> = (0..star.len()).collect();
    fn root(fan_of: &mut [usize], mut i: usize) -> usize {
        while fan_of[i] != i {
            fan_of[i] = fan_of[fan_of[i]];
            i = fan_of[i];
        }
        i
    }
    for i in 0..star.len() {
        for j in i + 1..star.len() {
            let shared = mesh.triangles()[star[i]].iter().any(|&w| {
                w != v && w != prev && w != next && mesh.triangles()[star[j]].contains(&w)
            });
            if shared {
                let (ri, rj) = (root(&mut fan_of, i), root(&mut fan_of, j));
                fan_of[ri.max(rj)] = ri.min(rj);
            }
        }
    }
    let mut groups: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (i, &t) in star.iter().enumerate() {
        let r = root(&mut fan_of, i);
        groups.entry(r).or_default().push(t);
    }
    let fans: Vec<Vec<usize>> = groups.into_values().collect();
    let on = |t: usize, w: usize| mesh.triangles()[t].contains(&w);
    fans.iter()
        .all(|fan| {
            fan.iter().filter(|&&t| on(t, prev)).count() == 1
                && fan.iter().filter(|&&t| on(t, next)).count() == 1
        })
        .then_some(fans)
}

/// The corners of triangle `t` after its corner `v`, in the triangle's order: the edge
/// opposite `v`, oriented with the triangle.
fn opposite_edge(mesh: &Mesh, t: usize, v: usize) -> (usize, usize) {
    let tri = mesh.triangles()[t];
    let i = tri
        .iter()
        .position(|&w| w == v)
        .expect("the triangle holds v");
    (tri[(i + 1) % 3], tri[(i + 2) % 3])
}

/// The link of vertex `v`: for each neighbour (a node), the star triangles through the edge
/// to it (its arcs), each with the arc's other node.
fn link(mesh: &Mesh, v: usize) -> BTreeMap<usize, Vec<(usize, usize)>> {
    let mut arcs: BTreeMap<usize, Vec<(usize, usize)>> = BTreeMap::new();
    for &t in mesh.vertex_triangles(v) {
        let (a, b) = opposite_edge(mesh, t, v);
        arcs.entry(a).or_default().push((t, b));
        arcs.entry(b).or_default().push((t, a));
    }
    arcs
}

/// Whether the link of `v` is a circle, a theta graph or K₄ (module header); a vertex on a
/// free boundary (a node of one arc) counts as minimal (it is not inside the film).
fn link_is_minimal(mesh: &Mesh, v: usize) -> bool {
    let arcs = link(mesh, v);
    if arcs.values().any(|a| a.len() == 1) {
        return true;
    }
    if arcs.values().any(|a| a.len() > 3) {
        return false;
    }
    let branches: Vec<usize> = arcs
        .iter()
        .filter(|(_, a)| a.len() == 3)
        .map(|(&w, _)| w)
        .collect();
    // Follow an arc from `from` through two-arc nodes until a branch node or `from` again: the
    // node reached and the nodes passed on the way.
    let walk = |from: usize, (t0, first): (usize, usize)| -> (usize, usize) {
        let (mut prev_t, mut node) = (t0, first);
        let mut passed = 0;
        while arcs[&node].len() == 2 && node != from && passed <= arcs.len() {
            let &(t, onward) = arcs[&node]
                .iter()
                .find(|&&(t, _)| t != prev_t)
                .expect("a two-arc node has another arc");
            (prev_t, node) = (t, onward);
            passed += 1;
        }
        (node, passed)
    };
    match branches.len() {
        0 => {
            // One cycle through every node.
            let (&start, first) = arcs.iter().next().expect("a vertex has triangles");
            walk(start, first[0]) == (start, arcs.len() - 1)
        }
        2 => arcs[&branches[0]]
            .iter()
            .all(|&arc| walk(branches[0], arc).0 == branches[1]),
        4 => {
            let mut pairs: Vec<(usize, usize)> = Vec::new();
            for &b in &branches {
                for &arc in &arcs[&b] {
                    let (end, _) = walk(b, arc);
                    if end == b {
                        return false;
                    }
                    pairs.push((b.min(end), b.max(end)));
                }
            }
            pairs.sort_unstable();
            pairs.dedup();
            pairs.len() == 6
        }
        _ => false,
    }
}

/// Replaces vertex `v` by a small sphere cut by its sheets, the largest region removed (module
/// header); `None` when the link is disconnected, has a node on more than three arcs, or a
/// face that is not a simple polygon of three or more nodes.
fn pop_vertex(mesh: &Mesh, v: usize, index: usize) -> Result<Option<(Mesh, PopEvent)>, MeshError> {
    let arcs = link(mesh, v);
    if arcs.values().any(|a| a.len() < 2 || a.len() > 3) {
        return Ok(None);
    }
    let p = mesh.positions();
    let direction: BTreeMap<usize, Point> = arcs
        .keys()
        .map(|&w| (w, (p[w] - p[v]).normalize()))
        .collect();
    // Rotation at each node: its arcs by angle counter-clockwise about the node's direction
    // seen from outside the sphere.
    let tangent = |at: usize, to: usize| {
        let n = direction[&at];
        let d = direction[&to];
        d - n * d.dot(&n)
    };
    let rotation: BTreeMap<usize, Vec<(usize, usize)>> = arcs
        .iter()
        .map(|(&w, list)| {
            let n = direction[&w];
            let (e1, _) = orthonormal_pair(&n);
            let e2 = n.cross(&e1);
            let mut sorted = list.clone();
            let angle = |&(_, z): &(usize, usize)| {
                let d = tangent(w, z);
                d.dot(&e2).atan2(d.dot(&e1))
            };
            sorted.sort_by(|x, y| angle(x).total_cmp(&angle(y)).then(x.0.cmp(&y.0)));
            (w, sorted)
        })
        .collect();
    // Faces with their interior on the left: arriving at b along arc t from a, leave along
    // the arc before t in b's counter-clockwise rotation.
    let mut used: BTreeSet<(usize, usize)> = BTreeSet::new();
    let mut faces: Vec<Vec<usize>> = Vec::new();
    for (&a, list) in &rotation {
        for &(t, b) in list {
            if used.contains(&(t, a)) {
                continue;
            }
            let mut face = Vec::new();
            let (mut from, mut arc, mut to) = (a, t, b);
            loop {
                if !used.insert((arc, from)) {
                    return Ok(None);
                }
                face.push(from);
                let around = &rotation[&to];
                let i = around
                    .iter()
                    .position(|&(s, z)| s == arc && z == from)
                    .expect("an arc is in both rotations");
                let (next_arc, next_to) = around[(i + around.len() - 1) % around.len()];
                (from, arc, to) = (to, next_arc, next_to);
                if (arc, from) == (t, a) {
                    break;
                }
            }
            faces.push(face);
        }
    }
    let simple = |f: &Vec<usize>| {
        let mut sorted = f.clone();
        sorted.sort_unstable();
        sorted.dedup();
        sorted.len() == f.len() && f.len() >= 3
    };
    // Euler: a connected link on the sphere has 2 − nodes + arcs faces.
    let arc_count = mesh.vertex_triangles(v).len();
    if faces.len() + arcs.len() != 2 + arc_count || !faces.iter().all(simple) {
        return Ok(None);
    }
    // Solid angles by Gauss–Bonnet: 2π minus the turning angles of the face walked with its
    // interior on the left.
    let solid_angle = |face: &Vec<usize>| {
        let m = face.len();
        let turning: f64 = (0..m)
            .map(|i| {
                let (prev, at, next) = (face[(i + m - 1) % m], face[i], face[(i + 1) % m]);
                let n = direction[&at];
                let forward = -tangent(at, prev);
                let out = tangent(at, next);
                n.cross(&forward).dot(&out).atan2(forward.dot(&out))
            })
            .sum();
        std::f64::consts::TAU - turning
    };
    let angles: Vec<f64> = faces.iter().map(solid_angle).collect();
    let largest = (0..faces.len())
        .max_by(|&x, &y| angles[x].total_cmp(&angles[y]).then(y.cmp(&x)))
        .expect("a link has faces");

    let radius = POP_RADIUS * shortest_edge(mesh, v);
    let mut edit = Surgery::of(mesh);
    let patch = edit.new_film_surface(mesh, mesh.vertex_triangles(v), "vertex", index);
    let on_sphere: BTreeMap<usize, usize> = direction
        .iter()
        .map(|(&w, d)| (w, edit.vertex(p[v] + d * radius, VertexFlags::default())))
        .collect();
    for &t in mesh.vertex_triangles(v) {
        let (a, b) = opposite_edge(mesh, t, v);
        edit.triangles[t] = [on_sphere[&a], a, b];
        edit.triangle(
            [on_sphere[&a], b, on_sphere[&b]],
            mesh.triangle_surface()[t],
        );
    }
    let before = edit.triangles.len();
    let mut centre_used = false;
    for (f, face) in faces.iter().enumerate() {
        if f == largest {
            continue;
        }
        let mean: Point = face.iter().map(|w| direction[w]).sum();
        let centre_position = p[v] + mean.normalize() * radius;
        let centre = if centre_used {
            edit.vertex(centre_position, VertexFlags::default())
        } else {
            centre_used = true;
            edit.positions[v] = centre_position;
            edit.flags[v] = VertexFlags::default();
            v
        };
        for i in 0..face.len() {
            let (a, b) = (face[i], face[(i + 1) % face.len()]);
            edit.triangle([centre, on_sphere[&a], on_sphere[&b]], patch);
        }
    }
    edit.finish("vertex", &p[v], faces.len(), before).map(Some)
}

/// Merges the endpoints of every edge shorter than `fraction` of the mesh's median edge
/// length whose two vertices are free (the shortest first, one at a time): the triangles on the
/// edge go, a triangle that then repeats another's corners goes, the merged vertex sits at the
/// edge's midpoint. This is how a film that shrinks to nothing leaves the mesh (Surface
/// Evolver's `t`); the junction it leaves is popped next. Returns the mesh and the number of
/// merges (the mesh itself when there are none).
pub fn collapse_short_edges(mesh: &Mesh, fraction: f64) -> Result<(Mesh, usize), PopError> {
    let threshold = fraction * mesh.median_edge_length();
    let mut current = mesh.clone();
    let mut merges = 0;
    // Edges whose merge would leave an invalid mesh (a zero-area triangle), by their ends'
    // positions (indices shift with every merge).
    let mut refused: Vec<[Point; 2]> = Vec::new();
    loop {
        if merges + refused.len() >= MAX_POPS {
            return Err(PopError::TooMany);
        }
        let p = current.positions();
        let shortest = current
            .edges()
            .iter()
            .filter(|e| e.vertices.iter().all(|&v| free(&current, v)))
            .filter(|e| !refused.contains(&e.vertices.map(|v| p[v])))
            .map(|e| ((p[e.vertices[0]] - p[e.vertices[1]]).norm(), e.vertices))
            .filter(|&(length, _)| length < threshold)
            .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let Some((_, [a, b])) = shortest else {
            break;
        };
        match merge_vertices(&current, a, b) {
            Ok(merged) => {
                current = merged;
                merges += 1;
            }
            Err(_) => refused.push([p[a], p[b]]),
        }
    }
    Ok((current, merges))
}

/// The mesh with vertex `b` merged into `a` (module header of [`collapse_short_edges`]);
/// vertices left in no triangle are dropped.
fn merge_vertices(mesh: &Mesh, a: usize, b: usize) -> Result<Mesh, MeshError> {
    let mut edit = Surgery::of(mesh);
    edit.positions[a] = (mesh.positions()[a] + mesh.positions()[b]) / 2.0;
    edit.flags[a].excluded &= mesh.flags()[b].excluded;
    edit.triangles.clear();
    edit.surface_of.clear();
    let mut seen = BTreeSet::new();
    for (t, tri) in mesh.triangles().iter().enumerate() {
        if tri.contains(&a) && tri.contains(&b) {
            continue;
        }
        let merged = tri.map(|v| if v == b { a } else { v });
        let mut corners = merged;
        corners.sort_unstable();
        if seen.insert(corners) {
            edit.triangle(merged, mesh.triangle_surface()[t]);
        }
    }
    edit.drop_unused_vertices();
    edit.build()
}

/// A mesh under change: its arrays, edited in place and rebuilt into a [`Mesh`].
struct Surgery {
    positions: Vec<Point>,
    flags: Vec<VertexFlags>,
    triangles: Vec<[usize; 3]>,
    surface_of: Vec<usize>,
    surfaces: Vec<String>,
    guides: Vec<super::mesh::Guide>,
}

impl Surgery {
    /// The arrays of `mesh`.
    fn of(mesh: &Mesh) -> Surgery {
        Surgery {
            positions: mesh.positions().to_vec(),
            flags: mesh.flags().to_vec(),
            triangles: mesh.triangles().to_vec(),
            surface_of: mesh.triangle_surface().to_vec(),
            surfaces: mesh.surfaces().to_vec(),
            guides: mesh.guides().to_vec(),
        }
    }

    /// Appends a vertex at `p` (m) with `flags`; its index.
    fn vertex(&mut self, p: Point, flags: VertexFlags) -> usize {
        self.positions.push(p);
        self.flags.push(flags);
        self.positions.len() - 1
    }

    /// Appends a triangle of surface `s`.
    fn triangle(&mut self, tri: [usize; 3], s: usize) {
        self.triangles.push(tri);
        self.surface_of.push(s);
    }

    /// The surface of a popped junction's new film: the surface of every triangle of `mesh`
    /// at the junction when they share one (a film of one surface stays one surface, and its
    /// vertices stay inside it), otherwise a new surface `popped {kind} {index}`.
    fn new_film_surface(
        &mut self,
        mesh: &Mesh,
        at_junction: &[usize],
        kind: &str,
        index: usize,
    ) -> usize {
        let of = |t: usize| mesh.triangle_surface()[t];
        match at_junction.first() {
            Some(&t) if at_junction.iter().all(|&u| of(u) == of(t)) => of(t),
            _ => {
                self.surfaces.push(format!("popped {kind} {index}"));
                self.surfaces.len() - 1
            }
        }
    }

    /// Removes the vertices in no triangle, renumbering the rest in order.
    fn drop_unused_vertices(&mut self) {
        let mut used = vec![false; self.positions.len()];
        for tri in &self.triangles {
            for &v in tri {
                used[v] = true;
            }
        }
        let mut index = vec![usize::MAX; used.len()];
        let mut kept = 0;
        for v in (0..used.len()).filter(|&v| used[v]) {
            index[v] = kept;
            self.positions[kept] = self.positions[v];
            self.flags[kept] = self.flags[v];
            kept += 1;
        }
        self.positions.truncate(kept);
        self.flags.truncate(kept);
        for tri in &mut self.triangles {
            *tri = tri.map(|v| index[v]);
        }
    }

    /// The validated mesh.
    fn build(self) -> Result<Mesh, MeshError> {
        Mesh::new(
            self.positions,
            self.triangles,
            self.surface_of,
            self.surfaces,
            self.flags,
            self.guides,
        )
    }

    /// The mesh and the event of a pop of `kind` at `at` (m) among `sheets` films or cells,
    /// whose new film's triangles are those from index `before` on.
    fn finish(
        self,
        kind: &'static str,
        at: &Point,
        sheets: usize,
        before: usize,
    ) -> Result<(Mesh, PopEvent), MeshError> {
        let event = PopEvent {
            kind,
            at: [at.x, at.y, at.z],
            sheets,
            new_triangles: self.triangles.len() - before,
        };
        Ok((self.build()?, event))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::area::total_area;
    use crate::cmc::mesh::MeshBuilder;
    use crate::cmc::octahedron::{OctahedronTopology, octahedron_frame};

    /// The cone over the unit cube frame: one free centre, a triangle to every wire.
    fn cube_cone() -> Mesh {
        let mut b = MeshBuilder::new();
        let films = b.surface("films");
        let corners: Vec<usize> = (0..8)
            .map(|k| {
                let bit = |i: usize| if k & (1 << i) == 0 { 0.0 } else { 1.0 };
                b.fixed(Point::new(bit(0), bit(1), bit(2)))
            })
            .collect();
        let centre = b.vertex(Point::new(0.5, 0.5, 0.5));
        for k in 0..8usize {
            for i in 0..3 {
                let j = k | (1 << i);
                if j != k {
                    b.triangle(films, [centre, corners[k], corners[j]]);
                }
            }
        }
        b.build().unwrap()
    }

    #[test]
    fn the_octahedral_cone_has_six_quadruple_lines_and_one_non_minimal_vertex() {
        let cone = octahedron_frame(1.0, OctahedronTopology::Cone, 3)
            .unwrap()
            .mesh;
        let census = census(&cone);
        assert_eq!(census.lines.len(), 6);
        assert!(census.lines.iter().all(|l| l.len() == 4));
        let centre = (0..cone.vertex_count())
            .find(|&v| cone.positions()[v].norm() < 1e-12)
            .unwrap();
        assert_eq!(census.vertices, vec![centre]);
    }

    #[test]
    fn the_stable_octahedral_starts_have_only_triple_lines_and_tetrahedral_points() {
        for topology in [
            OctahedronTopology::Tetrahedral,
            OctahedronTopology::Square,
            OctahedronTopology::Quadrilateral,
            OctahedronTopology::Pentagon,
            OctahedronTopology::Hexagon,
        ] {
            let mesh = octahedron_frame(1.0, topology, 2).unwrap().mesh;
            assert!(census(&mesh).is_minimal(), "{topology:?}");
            let (same, events) = pop(&mesh, &[]).unwrap();
            assert!(events.is_empty());
            assert_eq!(same.triangles(), mesh.triangles());
        }
    }

    #[test]
    fn popping_the_octahedral_cone_splits_six_lines_and_the_centre() {
        let cone = octahedron_frame(1.0, OctahedronTopology::Cone, 3)
            .unwrap()
            .mesh;
        let (popped, events) = pop(&cone, &[false]).unwrap();
        assert!(census(&popped).is_minimal(), "{:?}", census(&popped));
        let kinds: Vec<&str> = events.iter().map(|e| e.kind).collect();
        assert_eq!(kinds, [["line"; 6].as_slice(), &["vertex"]].concat());
        assert!(events[..6].iter().all(|e| e.sheets == 4));
        // The centre's link after the line pops: eight cells.
        assert_eq!(events[6].sheets, 8);
        // Small new films: the area changes by a few per cent at most.
        let (before, after) = (total_area(&cone), total_area(&popped));
        assert!((after - before).abs() < 0.05 * before, "{before} → {after}");
        // Every edge now has at most three sheets, except the wires.
        let flags = popped.flags();
        assert!(popped.edges().iter().all(|e| e.triangles.len() <= 3
            || (flags[e.vertices[0]].fixed && flags[e.vertices[1]].fixed)));
    }

    #[test]
    fn a_one_edge_line_is_bisected_before_it_is_split() {
        let cone = octahedron_frame(1.0, OctahedronTopology::Cone, 1)
            .unwrap()
            .mesh;
        assert!(census(&cone).lines.iter().all(|l| l.len() == 2));
        let (popped, events) = pop(&cone, &[false]).unwrap();
        assert!(census(&popped).is_minimal());
        assert_eq!(events.iter().filter(|e| e.kind == "line").count(), 6);
    }

    #[test]
    fn popping_the_cube_cone_opens_a_sphere_with_one_cell_removed() {
        let cone = cube_cone();
        let census_before = census(&cone);
        assert!(census_before.lines.is_empty());
        assert_eq!(census_before.vertices, vec![8]);
        let (popped, events) = pop(&cone, &[false]).unwrap();
        assert_eq!(events.len(), 1);
        assert_eq!((events[0].kind, events[0].sheets), ("vertex", 6));
        // Five square patches of four triangles each.
        assert_eq!(events[0].new_triangles, 20);
        assert_eq!(popped.triangles().len(), 12 * 2 + 20);
        assert!(census(&popped).is_minimal());
        let (before, after) = (total_area(&cone), total_area(&popped));
        assert!((after - before).abs() < 0.1 * before, "{before} → {after}");
    }

    #[test]
    fn films_bounding_a_body_are_not_popped() {
        let cone = cube_cone();
        let (same, events) = pop(&cone, &[true]).unwrap();
        assert!(events.is_empty());
        assert_eq!(same.triangles(), cone.triangles());
        assert_eq!(census(&same).vertices.len(), 1);
    }
}
