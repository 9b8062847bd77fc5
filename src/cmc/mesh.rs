//! Indexed triangle meshes made of named surfaces (seed §5.2), with the vertex flags of seed §5.3.
//!
//! - Positions are in metres; triangles are counter-clockwise seen from the side their normal
//!   `(p1 − p0) × (p2 − p0)` points to. Each surface's triangles are oriented consistently; the
//!   sign of a surface's mean curvature and its contribution to volumes follow that orientation.
//! - Edges may be shared by any number of triangles: an edge with one triangle is a boundary
//!   edge, with two a manifold edge, with three or more a junction edge where films meet (the
//!   Plateau borders of bubble clusters).
//! - Vertex flags: `fixed` (the vertex is not a variable: wire frames, tent stakes, pole caps),
//!   `excluded` (no curvature constraint at the vertex, seed §5.3: pole tips, user choice) and
//!   `guide` (the vertex must stay on a plane, a straight line or a circle, see [`Guide`]).
//! - Adjacency (vertex → triangles, edges → triangles, vertex → neighbours) is built once by
//!   [`Mesh::new`] and depends only on connectivity, so positions may change freely afterwards.
//!
//! Degenerate input (an index out of range, a repeated vertex in a triangle, a non-finite
//! coordinate, a zero-area triangle, a vertex in no triangle) is a [`MeshError`], never a panic.

use std::sync::Arc;

use nalgebra::Vector3;

/// A point or vector in metres.
pub type Point = Vector3<f64>;

/// A curve or surface a vertex must stay on, enforced as equality constraints in the NLP.
///
/// Curves are represented implicitly, as the intersection of two surfaces, so that every
/// constraint row is a smooth function of the vertex position alone:
/// - `Plane`: one row, `n̂·(x − p) = 0`;
/// - `Line`: two rows, the components of `x − p` along two unit vectors orthogonal to the line;
/// - `Circle`: two rows, `â·(x − c) = 0` (the circle's plane) and `(|x − c|² − r²)/(2r) = 0`
///   (the sphere through the circle), i.e. the circle is the plane ∩ sphere.
#[derive(Debug, Clone, PartialEq)]
pub enum Guide {
    /// The plane through `point` with normal `normal` (any length, not zero).
    Plane {
        /// A point of the plane, m.
        point: Point,
        /// The plane normal (normalized on use).
        normal: Point,
    },
    /// The straight line through `point` along `direction` (any length, not zero).
    Line {
        /// A point of the line, m.
        point: Point,
        /// The line direction (normalized on use).
        direction: Point,
    },
    /// The circle of radius `radius` around `centre` in the plane normal to `axis`.
    Circle {
        /// Centre, m.
        centre: Point,
        /// Normal of the circle's plane (normalized on use).
        axis: Point,
        /// Radius, m.
        radius: f64,
    },
}

impl Guide {
    /// Number of scalar equations the guide imposes on a vertex.
    pub fn rows(&self) -> usize {
        match self {
            Guide::Plane { .. } => 1,
            Guide::Line { .. } | Guide::Circle { .. } => 2,
        }
    }

    /// The residuals (m) and their gradients w.r.t. the vertex position, `rows()` of each.
    pub fn residuals(&self, x: &Point) -> Vec<(f64, Point)> {
        match self {
            Guide::Plane { point, normal } => {
                let n = normal.normalize();
                vec![(n.dot(&(x - point)), n)]
            }
            Guide::Line { point, direction } => {
                let (u, v) = orthonormal_pair(&direction.normalize());
                let d = x - point;
                vec![(u.dot(&d), u), (v.dot(&d), v)]
            }
            Guide::Circle {
                centre,
                axis,
                radius,
            } => {
                let a = axis.normalize();
                let d = x - centre;
                vec![
                    (a.dot(&d), a),
                    (
                        (d.norm_squared() - radius * radius) / (2.0 * radius),
                        d / *radius,
                    ),
                ]
            }
        }
    }

    /// Whether the guide's parameters are finite and non-degenerate.
    fn is_valid(&self) -> bool {
        let finite = |p: &Point| p.iter().all(|c| c.is_finite());
        match self {
            Guide::Plane { point, normal } => {
                finite(point) && finite(normal) && normal.norm() > 0.0
            }
            Guide::Line { point, direction } => {
                finite(point) && finite(direction) && direction.norm() > 0.0
            }
            Guide::Circle {
                centre,
                axis,
                radius,
            } => finite(centre) && finite(axis) && axis.norm() > 0.0 && *radius > 0.0,
        }
    }
}

/// Two unit vectors orthogonal to the unit vector `d` and to each other.
pub fn orthonormal_pair(d: &Point) -> (Point, Point) {
    let helper = if d.x.abs() < 0.9 {
        Point::x()
    } else {
        Point::y()
    };
    let u = d.cross(&helper).normalize();
    let v = d.cross(&u);
    (u, v)
}

/// Per-vertex flags (seed §5.3).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct VertexFlags {
    /// The vertex does not move (not a variable of the optimization).
    pub fixed: bool,
    /// The vertex carries no curvature constraint.
    pub excluded: bool,
    /// Index into [`Mesh::guides`] of the curve or plane the vertex must stay on.
    pub guide: Option<usize>,
}

/// Why a mesh is not usable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// A triangle names a vertex that does not exist.
    #[error("triangle {triangle} uses vertex {index}, but there are only {count} vertices")]
    IndexOutOfRange {
        /// Triangle index.
        triangle: usize,
        /// The offending vertex index.
        index: usize,
        /// Number of vertices.
        count: usize,
    },
    /// A triangle uses the same vertex twice.
    #[error("triangle {0} uses a vertex twice")]
    RepeatedVertex(usize),
    /// A coordinate is NaN or infinite.
    #[error("vertex {0} has a non-finite coordinate")]
    NonFinite(usize),
    /// A triangle has (numerically) zero area.
    #[error("triangle {0} has zero area")]
    Degenerate(usize),
    /// A vertex belongs to no triangle.
    #[error("vertex {0} belongs to no triangle")]
    Unused(usize),
    /// A triangle names a surface that does not exist.
    #[error("triangle {triangle} is in surface {surface}, but there are only {count} surfaces")]
    UnknownSurface {
        /// Triangle index.
        triangle: usize,
        /// The offending surface index.
        surface: usize,
        /// Number of surfaces.
        count: usize,
    },
    /// A vertex refers to a guide that does not exist or is degenerate.
    #[error("vertex {0} refers to a missing or degenerate guide")]
    BadGuide(usize),
    /// Lengths of per-vertex or per-triangle arrays disagree.
    #[error("{0}")]
    Inconsistent(String),
}

/// An edge and the triangles that share it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Edge {
    /// The two vertices, smaller index first.
    pub vertices: [usize; 2],
    /// Triangles containing the edge (1: boundary, 2: manifold, ≥ 3: junction).
    pub triangles: Vec<usize>,
}

/// A triangle mesh of named surfaces with adjacency.
#[derive(Debug, Clone)]
pub struct Mesh {
    positions: Vec<Point>,
    triangles: Vec<[usize; 3]>,
    triangle_surface: Vec<usize>,
    surfaces: Vec<String>,
    flags: Vec<VertexFlags>,
    guides: Vec<Guide>,
    /// Found once from the triangles and shared by the clones (the connectivity never changes
    /// after [`Mesh::new`]; a clone that moves the vertices copies only the positions).
    adjacency: Arc<Adjacency>,
}

/// A mesh's adjacency, a function of its triangles alone.
#[derive(Debug)]
struct Adjacency {
    vertex_triangles: Vec<Vec<usize>>,
    neighbours: Vec<Vec<usize>>,
    edges: Vec<Edge>,
    /// [`Mesh::is_interior_manifold`] of each vertex.
    interior_manifold: Vec<bool>,
}

impl Mesh {
    /// Builds a mesh and its adjacency; checks every index, coordinate and triangle area.
    pub fn new(
        positions: Vec<Point>,
        triangles: Vec<[usize; 3]>,
        triangle_surface: Vec<usize>,
        surfaces: Vec<String>,
        flags: Vec<VertexFlags>,
        guides: Vec<Guide>,
    ) -> Result<Mesh, MeshError> {
        let n = positions.len();
        if flags.len() != n {
            return Err(MeshError::Inconsistent(format!(
                "{} vertex flags for {n} vertices",
                flags.len()
            )));
        }
        if triangle_surface.len() != triangles.len() {
            return Err(MeshError::Inconsistent(format!(
                "{} surface labels for {} triangles",
                triangle_surface.len(),
                triangles.len()
            )));
        }
        if let Some(i) = positions
            .iter()
            .position(|p| p.iter().any(|c| !c.is_finite()))
        {
            return Err(MeshError::NonFinite(i));
        }
        for (t, tri) in triangles.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&v| v >= n) {
                return Err(MeshError::IndexOutOfRange {
                    triangle: t,
                    index,
                    count: n,
                });
            }
            if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
                return Err(MeshError::RepeatedVertex(t));
            }
            if triangle_surface[t] >= surfaces.len() {
                return Err(MeshError::UnknownSurface {
                    triangle: t,
                    surface: triangle_surface[t],
                    count: surfaces.len(),
                });
            }
        }
        for (v, f) in flags.iter().enumerate() {
            if let Some(g) = f.guide
                && !guides.get(g).is_some_and(Guide::is_valid)
            {
                return Err(MeshError::BadGuide(v));
            }
        }
        let mut vertex_triangles = vec![Vec::new(); n];
        // Each triangle's three edges (sorted vertex pair, triangle), then sorted by the pair
        // (stably: a pair's triangles stay in index order): the edges in pair order.
        let mut sides: Vec<([usize; 2], usize)> = Vec::with_capacity(3 * triangles.len());
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                vertex_triangles[tri[k]].push(t);
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                sides.push(([a.min(b), a.max(b)], t));
            }
        }
        if let Some(v) = vertex_triangles.iter().position(Vec::is_empty) {
            return Err(MeshError::Unused(v));
        }
        sides.sort_by_key(|&(pair, _)| pair);
        let mut neighbours = vec![Vec::new(); n];
        let edges: Vec<Edge> = sides
            .chunk_by(|a, b| a.0 == b.0)
            .map(|group| {
                let vertices = group[0].0;
                neighbours[vertices[0]].push(vertices[1]);
                neighbours[vertices[1]].push(vertices[0]);
                Edge {
                    vertices,
                    triangles: group.iter().map(|&(_, t)| t).collect(),
                }
            })
            .collect();
        for list in &mut neighbours {
            list.sort_unstable();
        }
        let interior_manifold = (0..n)
            .map(|v| {
                let star = &vertex_triangles[v];
                neighbours[v].len() == star.len()
                    && neighbours[v]
                        .iter()
                        .all(|&w| star.iter().filter(|&&t| triangles[t].contains(&w)).count() == 2)
            })
            .collect();
        let mesh = Mesh {
            positions,
            triangles,
            triangle_surface,
            surfaces,
            flags,
            guides,
            adjacency: Arc::new(Adjacency {
                vertex_triangles,
                neighbours,
                edges,
                interior_manifold,
            }),
        };
        mesh.check_areas()?;
        Ok(mesh)
    }

    /// Errors on the first triangle whose area is below 1e-12 of its longest edge squared.
    pub fn check_areas(&self) -> Result<(), MeshError> {
        for t in 0..self.triangles.len() {
            let [a, b, c] = self.corners(t);
            let twice_area = (b - a).cross(&(c - a)).norm();
            let longest = (b - a)
                .norm_squared()
                .max((c - b).norm_squared())
                .max((a - c).norm_squared());
            if twice_area.is_nan() || twice_area <= 1e-12 * longest {
                return Err(MeshError::Degenerate(t));
            }
        }
        Ok(())
    }

    /// Vertex positions, m.
    pub fn positions(&self) -> &[Point] {
        &self.positions
    }

    /// Replaces all positions (same count); errors on non-finite values or zero-area triangles.
    pub fn set_positions(&mut self, positions: Vec<Point>) -> Result<(), MeshError> {
        if positions.len() != self.positions.len() {
            return Err(MeshError::Inconsistent(format!(
                "{} positions for {} vertices",
                positions.len(),
                self.positions.len()
            )));
        }
        if let Some(i) = positions
            .iter()
            .position(|p| p.iter().any(|c| !c.is_finite()))
        {
            return Err(MeshError::NonFinite(i));
        }
        self.positions = positions;
        self.check_areas()
    }

    /// Triangles as vertex-index triples.
    pub fn triangles(&self) -> &[[usize; 3]] {
        &self.triangles
    }

    /// The surface index of each triangle.
    pub fn triangle_surface(&self) -> &[usize] {
        &self.triangle_surface
    }

    /// Surface names.
    pub fn surfaces(&self) -> &[String] {
        &self.surfaces
    }

    /// Index of the surface called `name`.
    pub fn surface_index(&self, name: &str) -> Option<usize> {
        self.surfaces.iter().position(|s| s == name)
    }

    /// Vertex flags.
    pub fn flags(&self) -> &[VertexFlags] {
        &self.flags
    }

    /// Positions of the fixed vertices (the wires), m, in vertex order.
    pub fn fixed_positions(&self) -> impl Iterator<Item = &Point> {
        self.positions
            .iter()
            .zip(&self.flags)
            .filter(|(_, f)| f.fixed)
            .map(|(p, _)| p)
    }

    /// Guides referred to by [`VertexFlags::guide`].
    pub fn guides(&self) -> &[Guide] {
        &self.guides
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// The three corner positions of triangle `t`.
    pub fn corners(&self, t: usize) -> [Point; 3] {
        let [a, b, c] = self.triangles[t];
        [self.positions[a], self.positions[b], self.positions[c]]
    }

    /// Triangles containing vertex `v`.
    pub fn vertex_triangles(&self, v: usize) -> &[usize] {
        &self.adjacency.vertex_triangles[v]
    }

    /// Vertices sharing an edge with `v`, ascending.
    pub fn neighbours(&self, v: usize) -> &[usize] {
        &self.adjacency.neighbours[v]
    }

    /// All edges, sorted by vertex pair.
    pub fn edges(&self) -> &[Edge] {
        &self.adjacency.edges
    }

    /// Every edge's length, ascending, m.
    pub fn sorted_edge_lengths(&self) -> Vec<f64> {
        let p = &self.positions;
        let mut lengths: Vec<f64> = self
            .edges()
            .iter()
            .map(|e| (p[e.vertices[0]] - p[e.vertices[1]]).norm())
            .collect();
        lengths.sort_by(f64::total_cmp);
        lengths
    }

    /// The median edge length (the upper one of an even count), m; 0 without edges.
    pub fn median_edge_length(&self) -> f64 {
        let lengths = self.sorted_edge_lengths();
        lengths.get(lengths.len() / 2).copied().unwrap_or(0.0)
    }

    /// Triangles of surface `s`.
    pub fn surface_triangles(&self, s: usize) -> impl Iterator<Item = usize> + '_ {
        (0..self.triangles.len()).filter(move |&t| self.triangle_surface[t] == s)
    }

    /// The surfaces whose triangles touch vertex `v`, ascending.
    pub fn vertex_surfaces(&self, v: usize) -> Vec<usize> {
        let mut s: Vec<usize> = self.adjacency.vertex_triangles[v]
            .iter()
            .map(|&t| self.triangle_surface[t])
            .collect();
        s.sort_unstable();
        s.dedup();
        s
    }

    /// Whether the star of `v` is a closed disk: every edge at `v` is shared by exactly two of
    /// its triangles (so `v` is neither on a boundary nor on a junction).
    pub fn is_interior_manifold(&self, v: usize) -> bool {
        self.adjacency.interior_manifold[v]
    }

    /// The surface at whose vertex `v` a curvature constraint applies, if any: `v` is not
    /// fixed, excluded or guided, its star is a closed disk and lies in one surface (seed §5.3:
    /// curvature is defined only where the surface is locally manifold).
    pub fn curvature_surface(&self, v: usize) -> Option<usize> {
        let f = self.flags[v];
        if f.fixed || f.excluded || f.guide.is_some() {
            return None;
        }
        let star = &self.adjacency.vertex_triangles[v];
        let s = self.triangle_surface[*star.first()?];
        (star.iter().all(|&t| self.triangle_surface[t] == s) && self.is_interior_manifold(v))
            .then_some(s)
    }

    /// Vertices on junction edges (edges shared by three or more triangles).
    pub fn junction_vertices(&self) -> Vec<usize> {
        let mut v: Vec<usize> = self
            .edges()
            .iter()
            .filter(|e| e.triangles.len() >= 3)
            .flat_map(|e| e.vertices)
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// Marks every vertex on a boundary edge (an edge of exactly one triangle) as fixed.
    pub fn fix_boundary(&mut self) {
        let boundary: Vec<usize> = self
            .edges()
            .iter()
            .filter(|e| e.triangles.len() == 1)
            .flat_map(|e| e.vertices)
            .collect();
        for v in boundary {
            self.flags[v].fixed = true;
        }
    }

    /// Sets the flags of vertex `v`.
    pub fn set_flags(&mut self, v: usize, flags: VertexFlags) -> Result<(), MeshError> {
        if v >= self.positions.len() {
            return Err(MeshError::Inconsistent(format!("no vertex {v}")));
        }
        if let Some(g) = flags.guide
            && !self.guides.get(g).is_some_and(Guide::is_valid)
        {
            return Err(MeshError::BadGuide(v));
        }
        self.flags[v] = flags;
        Ok(())
    }

    /// Adds a guide and returns its index for [`VertexFlags::guide`].
    pub fn add_guide(&mut self, guide: Guide) -> usize {
        self.guides.push(guide);
        self.guides.len() - 1
    }
}

/// Incremental construction of a [`Mesh`]: surfaces by name, vertices with flags, triangles.
#[derive(Debug, Clone, Default)]
pub struct MeshBuilder {
    positions: Vec<Point>,
    flags: Vec<VertexFlags>,
    triangles: Vec<[usize; 3]>,
    triangle_surface: Vec<usize>,
    surfaces: Vec<String>,
    guides: Vec<Guide>,
}

impl MeshBuilder {
    /// An empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Index of surface `name`, created on first use.
    pub fn surface(&mut self, name: &str) -> usize {
        match self.surfaces.iter().position(|s| s == name) {
            Some(i) => i,
            None => {
                self.surfaces.push(name.to_string());
                self.surfaces.len() - 1
            }
        }
    }

    /// Adds a free vertex and returns its index.
    pub fn vertex(&mut self, p: Point) -> usize {
        self.vertex_with(p, VertexFlags::default())
    }

    /// Adds a fixed vertex and returns its index.
    pub fn fixed(&mut self, p: Point) -> usize {
        self.vertex_with(
            p,
            VertexFlags {
                fixed: true,
                ..Default::default()
            },
        )
    }

    /// Adds a vertex with the given flags.
    pub fn vertex_with(&mut self, p: Point, flags: VertexFlags) -> usize {
        self.positions.push(p);
        self.flags.push(flags);
        self.positions.len() - 1
    }

    /// Adds a triangle to surface `s`.
    pub fn triangle(&mut self, s: usize, tri: [usize; 3]) {
        self.triangles.push(tri);
        self.triangle_surface.push(s);
    }

    /// Adds a guide and returns its index.
    pub fn guide(&mut self, g: Guide) -> usize {
        self.guides.push(g);
        self.guides.len() - 1
    }

    /// Position of vertex `v` so far.
    pub fn position(&self, v: usize) -> Point {
        self.positions[v]
    }

    /// Number of vertices so far.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Mutable flags of vertex `v`.
    pub fn flags_mut(&mut self, v: usize) -> &mut VertexFlags {
        &mut self.flags[v]
    }

    /// Validates and builds the mesh.
    pub fn build(self) -> Result<Mesh, MeshError> {
        Mesh::new(
            self.positions,
            self.triangles,
            self.triangle_surface,
            self.surfaces,
            self.flags,
            self.guides,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> MeshBuilder {
        let mut b = MeshBuilder::new();
        let s = b.surface("skin");
        let v = [
            b.vertex(Point::new(0.0, 0.0, 0.0)),
            b.vertex(Point::new(1.0, 0.0, 0.0)),
            b.vertex(Point::new(0.0, 1.0, 0.0)),
            b.vertex(Point::new(0.0, 0.0, 1.0)),
        ];
        for tri in [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]] {
            b.triangle(s, tri.map(|k| v[k]));
        }
        b
    }

    #[test]
    fn closed_tetrahedron_has_manifold_vertices() {
        let m = tetra().build().unwrap();
        assert_eq!(m.edges().len(), 6);
        assert!(m.edges().iter().all(|e| e.triangles.len() == 2));
        for v in 0..4 {
            assert!(m.is_interior_manifold(v));
            assert_eq!(m.curvature_surface(v), Some(0));
            assert_eq!(m.neighbours(v).len(), 3);
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        let mut b = tetra();
        b.triangle(0, [0, 1, 7]);
        assert!(matches!(
            b.build(),
            Err(MeshError::IndexOutOfRange { index: 7, .. })
        ));
        let mut b = tetra();
        b.positions[2].y = f64::NAN;
        assert_eq!(b.build().unwrap_err(), MeshError::NonFinite(2));
        let mut b = tetra();
        b.positions[3] = Point::new(0.5, 0.5, 0.0);
        assert_eq!(b.build().unwrap_err(), MeshError::Degenerate(3));
        let mut b = tetra();
        b.triangle(0, [1, 1, 2]);
        assert_eq!(b.build().unwrap_err(), MeshError::RepeatedVertex(4));
        let mut b = tetra();
        b.vertex(Point::new(5.0, 5.0, 5.0));
        assert_eq!(b.build().unwrap_err(), MeshError::Unused(4));
        let mut b = tetra();
        b.flags_mut(1).guide = Some(0);
        assert_eq!(b.build().unwrap_err(), MeshError::BadGuide(1));
    }

    #[test]
    fn junction_edges_are_allowed() {
        // Three triangles sharing the edge (0, 1): a Y-shaped junction.
        let mut b = MeshBuilder::new();
        let (s0, s1, s2) = (b.surface("a"), b.surface("b"), b.surface("c"));
        let v0 = b.vertex(Point::new(0.0, 0.0, 0.0));
        let v1 = b.vertex(Point::new(0.0, 0.0, 1.0));
        let a = b.vertex(Point::new(1.0, 0.0, 0.5));
        let c = b.vertex(Point::new(-0.5, 0.8, 0.5));
        let d = b.vertex(Point::new(-0.5, -0.8, 0.5));
        b.triangle(s0, [v0, a, v1]);
        b.triangle(s1, [v0, c, v1]);
        b.triangle(s2, [v0, d, v1]);
        let m = b.build().unwrap();
        assert_eq!(m.junction_vertices(), vec![v0, v1]);
        assert_eq!(m.curvature_surface(v0), None);
        assert_eq!(m.vertex_surfaces(v0), vec![0, 1, 2]);
    }

    #[test]
    fn guide_residuals_vanish_on_the_guide() {
        let circle = Guide::Circle {
            centre: Point::new(1.0, 2.0, 3.0),
            axis: Point::new(0.0, 0.0, 2.0),
            radius: 0.5,
        };
        let on = Point::new(1.0 + 0.3, 2.0 + 0.4, 3.0);
        assert!(circle.residuals(&on).iter().all(|(r, _)| r.abs() < 1e-15));
        let line = Guide::Line {
            point: Point::new(0.0, 1.0, 0.0),
            direction: Point::new(1.0, 1.0, 0.0),
        };
        let on = Point::new(2.0, 3.0, 0.0);
        assert!(line.residuals(&on).iter().all(|(r, _)| r.abs() < 1e-15));
        let off = Point::new(2.0, 3.0, 0.25);
        let norm: f64 = line.residuals(&off).iter().map(|(r, _)| r * r).sum();
        assert!((norm.sqrt() - 0.25).abs() < 1e-15);
    }
}
