//! The variables that move each vertex of a CMC problem, and the Lagrangian Hessian's pattern
//! in per-vertex blocks.
//!
//! ```text
//!   Cartesian vertex:  x_v = y_v                      (3 columns, the scaled position)
//!   plane vertex:      x_v = x⁰_v + s_v a_v + t_v b_v   (2 columns, a_v ⊥ b_v unit vectors)
//!   normal vertex:     x_v = x⁰_v + t_v n_v           (1 column, t_v the displacement along n_v)
//!   fixed vertex:      x_v = x⁰_v                     (no column)
//! ```
//! in scaled units (positions over the characteristic length L), `n_v` a unit normal and
//! `(a_v, b_v)` the plane normal to a junction curve, frozen when the problem is built (Surface
//! Evolver's `hessian_normal`, which moves a vertex of a triple line normal to the line). The map
//! is linear with `∂x_v/∂y_v = B_v` (`I`, `[a_v b_v]` or `n_v`), so derivatives follow by the
//! chain rule without second-order terms: a gradient `g_v` becomes `B_vᵀ g_v`, a Hessian block
//! `M_uw = ∂²/∂x_u∂x_w` becomes `B_uᵀ M_uw B_w` (width(u) × width(w)).
//!
//! Hessian pattern: block `(u, w)` with `column(u) > column(w)` holds all `width(u)·width(w)`
//! entries (row-major), a diagonal block `(u, u)` its lower triangle. Stars (a triangle's
//! corners, a smoothing term's vertex and ring) get their blocks' positions once, at build
//! ([`HessianPattern::star_slots`]), so the per-iteration scatter does no lookups.

use nalgebra::Matrix3;

use super::mesh::Point;

/// How one vertex is moved.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Basis {
    Fixed,
    /// Three columns from this one: the scaled position.
    Cartesian(usize),
    /// Two columns from this one: the displacements along two orthonormal directions.
    Plane(usize, Point, Point),
    /// One column: the displacement along the unit normal.
    Normal(usize, Point),
}

impl Basis {
    /// The columns of `B_v` (unit vectors; the coordinate axes for a Cartesian vertex), in
    /// column order, and how many there are.
    #[inline]
    fn directions(self) -> ([Point; 3], usize) {
        let z = Point::zeros();
        match self {
            Basis::Fixed => ([z; 3], 0),
            Basis::Cartesian(_) => ([Point::x(), Point::y(), Point::z()], 3),
            Basis::Plane(_, a, b) => ([a, b, z], 2),
            Basis::Normal(_, n) => ([n, z, z], 1),
        }
    }
}

/// The vertex → column map of a problem (see the module header).
#[derive(Debug, Clone, Default)]
pub struct Variables {
    basis: Vec<Basis>,
    count: usize,
}

impl Variables {
    /// Columns from 0 on, in vertex order: none for a fixed vertex, one for a vertex with a
    /// frozen unit normal (`normal(v)` is `Some`), two for a vertex moving in a frozen plane
    /// (`plane(v)` is `Some`: two orthonormal vectors), three otherwise.
    pub fn new(
        fixed: impl Fn(usize) -> bool,
        normal: impl Fn(usize) -> Option<Point>,
        plane: impl Fn(usize) -> Option<(Point, Point)>,
        n: usize,
    ) -> Self {
        let mut count = 0;
        let basis = (0..n)
            .map(|v| {
                if fixed(v) {
                    return Basis::Fixed;
                }
                let column = count;
                match normal(v) {
                    Some(n) => {
                        count += 1;
                        Basis::Normal(column, n)
                    }
                    None => match plane(v) {
                        Some((a, b)) => {
                            count += 2;
                            Basis::Plane(column, a, b)
                        }
                        None => {
                            count += 3;
                            Basis::Cartesian(column)
                        }
                    },
                }
            })
            .collect();
        Variables { basis, count }
    }

    /// Number of columns.
    pub fn count(&self) -> usize {
        self.count
    }

    /// First column of vertex `v` (None when fixed).
    pub fn column(&self, v: usize) -> Option<usize> {
        match self.basis[v] {
            Basis::Fixed => None,
            Basis::Cartesian(c) | Basis::Plane(c, ..) | Basis::Normal(c, _) => Some(c),
        }
    }

    /// Columns of vertex `v`: 0, 1 or 3.
    pub fn width(&self, v: usize) -> usize {
        match self.basis[v] {
            Basis::Fixed => 0,
            Basis::Cartesian(_) => 3,
            Basis::Plane(..) => 2,
            Basis::Normal(..) => 1,
        }
    }

    /// True when vertex `v` moves along its frozen normal only.
    pub fn is_normal(&self, v: usize) -> bool {
        matches!(self.basis[v], Basis::Normal(..))
    }

    /// Scaled position of vertex `v` at `x`, its start being `start` (scaled).
    pub fn position(&self, v: usize, start: Point, x: &[f64]) -> Point {
        match self.basis[v] {
            Basis::Fixed => start,
            Basis::Cartesian(c) => Point::new(x[c], x[c + 1], x[c + 2]),
            Basis::Plane(c, a, b) => start + x[c] * a + x[c + 1] * b,
            Basis::Normal(c, n) => start + x[c] * n,
        }
    }

    /// Writes vertex `v`'s start values (`start` its scaled position) into `x`.
    pub fn set_start(&self, v: usize, start: Point, x: &mut [f64]) {
        match self.basis[v] {
            Basis::Fixed => {}
            Basis::Cartesian(c) => x[c..c + 3].copy_from_slice(start.as_slice()),
            Basis::Plane(c, ..) => x[c..c + 2].fill(0.0),
            Basis::Normal(c, _) => x[c] = 0.0,
        }
    }

    /// `grad[columns of v] += B_vᵀ g`.
    pub fn add_gradient(&self, grad: &mut [f64], v: usize, g: Point) {
        match self.basis[v] {
            Basis::Fixed => {}
            Basis::Cartesian(c) => {
                grad[c] += g.x;
                grad[c + 1] += g.y;
                grad[c + 2] += g.z;
            }
            Basis::Plane(c, a, b) => {
                grad[c] += a.dot(&g);
                grad[c + 1] += b.dot(&g);
            }
            Basis::Normal(c, n) => grad[c] += n.dot(&g),
        }
    }

    /// Writes `B_vᵀ g` at `jac[*k..]` and advances `k` by the width of `v`.
    pub fn put_jacobian(&self, jac: &mut [f64], k: &mut usize, v: usize, g: Point) {
        match self.basis[v] {
            Basis::Fixed => {}
            Basis::Cartesian(_) => {
                jac[*k..*k + 3].copy_from_slice(g.as_slice());
                *k += 3;
            }
            Basis::Plane(_, a, b) => {
                jac[*k] = a.dot(&g);
                jac[*k + 1] = b.dot(&g);
                *k += 2;
            }
            Basis::Normal(_, n) => {
                jac[*k] = n.dot(&g);
                *k += 1;
            }
        }
    }

    /// `B_uᵀ m B_w` in the top-left `width(u) × width(w)` corner of a 3×3 matrix.
    fn project(&self, u: usize, w: usize, m: &Matrix3<f64>) -> Matrix3<f64> {
        let mut p = *m;
        match self.basis[u] {
            Basis::Normal(_, n) => {
                let row = n.transpose() * p;
                p.set_row(0, &row);
            }
            Basis::Plane(_, a, b) => {
                let (ra, rb) = (a.transpose() * p, b.transpose() * p);
                p.set_row(0, &ra);
                p.set_row(1, &rb);
            }
            _ => {}
        }
        match self.basis[w] {
            Basis::Normal(_, n) => {
                let col = p * n;
                p.set_column(0, &col);
            }
            Basis::Plane(_, a, b) => {
                let (ca, cb) = (p * a, p * b);
                p.set_column(0, &ca);
                p.set_column(1, &cb);
            }
            _ => {}
        }
        p
    }
}

/// Position of a block in the values, or none (a fixed vertex, or the upper triangle).
const NO_SLOT: usize = usize::MAX;

/// Lower-triangle pattern of the Lagrangian Hessian in per-vertex blocks (module header).
#[derive(Debug, Default)]
pub struct HessianPattern {
    /// `blocks[u]`: `(w, position of block (u, w) in the values)` for the blocks in row u
    /// (`column(u) ≥ column(w)`), in insertion order.
    blocks: Vec<Vec<(usize, usize)>>,
    entries: Vec<(usize, usize)>,
}

impl HessianPattern {
    /// The pattern's `(row, column)` entries, in values order.
    pub fn entries(&self) -> &[(usize, usize)] {
        &self.entries
    }

    /// Adds the block coupling `u` and `w` (either order).
    pub fn insert(&mut self, vars: &Variables, u: usize, w: usize) {
        let (Some(cu), Some(cw)) = (vars.column(u), vars.column(w)) else {
            return;
        };
        let (u, w, cu, cw) = if cu >= cw {
            (u, w, cu, cw)
        } else {
            (w, u, cw, cu)
        };
        if self.find(u, w).is_some() {
            return;
        }
        if self.blocks.len() <= u {
            self.blocks.resize_with(u + 1, Vec::new);
        }
        self.blocks[u].push((w, self.entries.len()));
        for r in 0..vars.width(u) {
            for c in 0..vars.width(w) {
                if u != w || c <= r {
                    self.entries.push((cu + r, cw + c));
                }
            }
        }
    }

    /// Adds every block coupling two vertices of `star`.
    pub fn insert_star(&mut self, vars: &Variables, star: &[usize]) {
        for &u in star {
            for &w in star {
                self.insert(vars, u, w);
            }
        }
    }

    /// Position of block `(u, w)` where `∂²/∂x_u∂x_w` is added, or [`NO_SLOT`] for pairs
    /// that add nothing (a fixed vertex, or `column(u) < column(w)`: the transpose arrives as
    /// `(w, u)`).
    fn slot(&self, vars: &Variables, u: usize, w: usize) -> usize {
        match (vars.column(u), vars.column(w)) {
            (Some(cu), Some(cw)) if cu >= cw => self.find(u, w).unwrap_or(NO_SLOT),
            _ => NO_SLOT,
        }
    }

    /// Position of block `(u, w)` in the values when it is in the pattern.
    fn find(&self, u: usize, w: usize) -> Option<usize> {
        self.blocks
            .get(u)?
            .iter()
            .find(|&&(other, _)| other == w)
            .map(|&(_, slot)| slot)
    }

    /// The slots of every ordered pair of `star` (row-major, `star.len()²`), for
    /// [`HessianPattern::add_at`].
    pub fn star_slots(&self, vars: &Variables, star: &[usize]) -> Vec<usize> {
        star.iter()
            .flat_map(|&u| star.iter().map(move |&w| (u, w)))
            .map(|(u, w)| self.slot(vars, u, w))
            .collect()
    }

    /// [`HessianPattern::star_slots`] of a triangle's corners, without allocating.
    pub fn triangle_slots(&self, vars: &Variables, corners: &[usize; 3]) -> [usize; 9] {
        std::array::from_fn(|k| self.slot(vars, corners[k / 3], corners[k % 3]))
    }

    /// Adds `factor · B_uᵀ m B_w` at `slot` (from [`HessianPattern::star_slots`]), `m =
    /// ∂²/∂x_u∂x_w` (rows of u, columns of w).
    pub fn add_at(
        values: &mut [f64],
        vars: &Variables,
        slot: usize,
        u: usize,
        w: usize,
        m: &Matrix3<f64>,
        factor: f64,
    ) {
        if slot == NO_SLOT {
            return;
        }
        let p = vars.project(u, w, m);
        let mut k = slot;
        for r in 0..vars.width(u) {
            for c in 0..vars.width(w) {
                if u != w || c <= r {
                    values[k] += factor * p[(r, c)];
                    k += 1;
                }
            }
        }
    }

    /// Adds `factor · B_uᵀ m B_w` at `slot` like [`HessianPattern::add_at`], `m` given by
    /// `row(x) = mᵀ x` (x a direction of u's position): a normal vertex contracts one
    /// direction, `n_u`, instead of forming the block.
    #[inline]
    pub fn add_rows_at(
        values: &mut [f64],
        vars: &Variables,
        slot: usize,
        u: usize,
        w: usize,
        row: impl Fn(&Point) -> Point,
        factor: f64,
    ) {
        if slot == NO_SLOT {
            return;
        }
        let (diagonal, column) = (u == w, vars.basis[w]);
        match (vars.basis[u], column) {
            (Basis::Fixed, _) | (_, Basis::Fixed) => {}
            (Basis::Normal(_, n), Basis::Normal(_, nw)) => {
                values[slot] += factor * row(&n).dot(&nw)
            }
            (Basis::Normal(_, n), Basis::Cartesian(_)) => {
                let g = row(&n);
                for c in 0..3 {
                    values[slot + c] += factor * g[c];
                }
            }
            (Basis::Cartesian(_), Basis::Normal(..) | Basis::Cartesian(_)) => {
                let mut k = slot;
                for r in 0..3 {
                    let g = row(&Point::ith(r, 1.0));
                    if let Basis::Normal(_, nw) = column {
                        values[k] += factor * g.dot(&nw);
                        k += 1;
                        continue;
                    }
                    for c in 0..3 {
                        if !diagonal || c <= r {
                            values[k] += factor * g[c];
                            k += 1;
                        }
                    }
                }
            }
            (basis, _) => {
                // A plane vertex on either side: one row per direction of u, contracted with
                // each direction of w.
                let (rows, nr) = basis.directions();
                let (cols, nc) = column.directions();
                let mut k = slot;
                for (r, d) in rows.iter().enumerate().take(nr) {
                    let g = row(d);
                    for (c, e) in cols.iter().enumerate().take(nc) {
                        if !diagonal || c <= r {
                            values[k] += factor * g.dot(e);
                            k += 1;
                        }
                    }
                }
            }
        }
    }

    /// Adds `factor · B_uᵀ m B_w` to block `(u, w)` (one lookup; see
    /// [`HessianPattern::add_at`]).
    pub fn add(
        &self,
        values: &mut [f64],
        vars: &Variables,
        u: usize,
        w: usize,
        m: &Matrix3<f64>,
        factor: f64,
    ) {
        HessianPattern::add_at(values, vars, self.slot(vars, u, w), u, w, m, factor);
    }
}
