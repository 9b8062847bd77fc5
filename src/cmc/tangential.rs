//! Relaxation between normal-coordinate rounds: Gauss–Seidel sweeps of per-vertex Newton steps
//! on the area formulation's energy, a surface vertex moving in its tangent plane and a free
//! vertex off the surfaces (on a junction) in space.
//!
//! Normal coordinates ([`super::nlp::Formulation::Normal`]) move a surface vertex along its
//! frozen normal only, so the start's tangential layout is kept; the area formulation moves it
//! in 3-D and ends lower. This relaxation supplies the missing motion. The energy is the area
//! formulation's Lagrangian in metres, the pressures `p_k` (1/m) held at a normal round's
//! multipliers,
//! ```text
//!   E(x) = A(x) − Σ_k p_k V_k(x) + (w/2) Σ_j |P_j (x_j − mean of x_j's ring)|²     (m²)
//! ```
//! over the bodies k and the smoothing terms j (those of the area formulation, with their
//! projectors `P_j` and rings, frozen when the sweeps start). Without the pressure term a step
//! on a curved bubble would lower the area by shrinking the volume at second order, which the
//! next round then has to undo at a higher area. In the volume term each triangle t of surface
//! s carries `−p_s V_t`, with `p_s = Σ_k σ_ks p_k` the pressure jump across s (σ_ks = ±1 when s
//! bounds region k) and `V_t` its cone volume from the origin: a moving vertex's star closes
//! every region around it, so the reference points drop out of every change.
//!
//! A sweep visits the movable vertices in index order; vertex v minimizes its share of E (its
//! triangles, and the terms whose vertex or ring holds it) by one Newton step `H d = −g`
//! restricted to its motion: for a surface vertex with unit normal `n_v` (area-weighted, frozen
//! when the sweeps start) `(P H P + tr(H) n nᵀ) d = −P g`, so that `d ⊥ n_v`. `H` is the 3×3
//! diagonal block: positive semidefinite for the area (a triangle's area is convex in one
//! corner), zero for the volumes (linear in one corner), `w Σ c² PᵀP` for the terms. The step is
//! halved until the share decreases and no triangle of the star turns over (at most
//! `HALVINGS` times), else the vertex stays. A motion ⊥ `n_v` changes every enclosed volume
//! at second order only (a volume's gradient at v is the sum of the star's area vectors over
//! 3, along `n_v`), so the next normal round restores the volumes in a step or two. At a
//! stationary point of the area formulation every share is stationary, and the sweeps do not
//! move it.

use nalgebra::Matrix3;

use super::area::{area_vector, triangle_area_corner_derivatives};
use super::mesh::{Mesh, Point};
use super::volume::{cone_volume, cone_volume_corner_gradient};

/// Most halvings of a vertex's Newton step before the vertex is left where it is.
const HALVINGS: usize = 6;

/// One term `(w/2)|P (x_v − mean of ring)|²` of the tangential regularization.
#[derive(Debug, Clone)]
pub struct Smoothing {
    /// The vertex pulled towards its ring's mean.
    pub vertex: usize,
    /// The projector P (dimensionless), frozen when the term is built.
    pub projector: Matrix3<f64>,
    /// The vertices whose mean it is pulled towards.
    pub ring: Vec<usize>,
}

impl Smoothing {
    /// The vertex followed by its ring.
    pub fn star(&self) -> Vec<usize> {
        std::iter::once(self.vertex)
            .chain(self.ring.iter().copied())
            .collect()
    }

    /// `x_v − mean of the ring` at `pos` (any length unit).
    pub fn offset(&self, pos: &[Point]) -> Point {
        let mean = self.ring.iter().map(|&w| pos[w]).sum::<Point>() / self.ring.len() as f64;
        pos[self.vertex] - mean
    }

    /// `∂(x_v − mean)/∂x_u = c I`: the coefficient c of star vertex u (1 at the vertex, −1/k
    /// on a ring of k).
    fn coefficient(&self, u: usize) -> f64 {
        if u == self.vertex {
            1.0
        } else {
            -1.0 / self.ring.len() as f64
        }
    }
}

/// How the relaxation may move a vertex.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Motion {
    /// Not at all (fixed, guided, a chord's end, or a vertex the rounds move in 3-D).
    Held,
    /// In its tangent plane (a vertex the rounds move along its normal).
    Tangential,
    /// In space.
    Free,
}

/// The outcome of [`relax`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Relaxation {
    /// Sweeps run.
    pub sweeps: usize,
    /// Largest move of a vertex in the last sweep, m.
    pub last_move: f64,
    /// The energy E before and after, m².
    pub energy: (f64, f64),
}

/// The positions after sweeps (module header) until a sweep moves no vertex further than
/// `tolerance` (m) or `max_sweeps` have run. `surface_pressure[s]` is the pressure jump `p_s`
/// across surface s (1/m), `terms` the regularization's terms with weight `weight` (`w`).
/// Every triangle keeps a positive area.
pub fn relax(
    mesh: &Mesh,
    surface_pressure: &[f64],
    motion: impl Fn(usize) -> Motion,
    terms: &[Smoothing],
    weight: f64,
    tolerance: f64,
    max_sweeps: usize,
) -> (Vec<Point>, Relaxation) {
    let n = mesh.vertex_count();
    let moving: Vec<(usize, Option<Point>)> = (0..n)
        .filter_map(|v| match motion(v) {
            Motion::Held => None,
            Motion::Free => Some((v, None)),
            Motion::Tangential => {
                let normal = vertex_normal(mesh, v);
                (normal != Point::zeros()).then_some((v, Some(normal)))
            }
        })
        .collect();
    let star = Star::new(mesh, terms, surface_pressure, weight);
    let mut pos = mesh.positions().to_vec();
    let mut scratch = star.scratch(&pos);
    let before = star.total_with(&pos, &scratch);
    let mut relaxation = Relaxation {
        sweeps: 0,
        last_move: 0.0,
        energy: (before, before),
    };
    while relaxation.sweeps < max_sweeps {
        relaxation.sweeps += 1;
        relaxation.last_move = moving
            .iter()
            .map(|&(v, normal)| star.step(&mut pos, v, normal, &mut scratch))
            .fold(0.0, f64::max);
        if relaxation.last_move <= tolerance {
            break;
        }
    }
    relaxation.energy.1 = star.total_with(&pos, &scratch);
    (pos, relaxation)
}

/// The positions `x₀ + ω (x₁ − x₀)` from the mesh's positions `x₀` past the relaxed ones `x₁`
/// (over-relaxation, ω ≥ 1), when no triangle there has turned over against `x₁` and the
/// energy E of [`relax`] (same pressures, terms and weight) there is below `energy_start`, E
/// at `x₀` (the relaxation's [`Relaxation::energy`]`.0`); else None.
pub fn over_relaxed(
    mesh: &Mesh,
    relaxed: &[Point],
    omega: f64,
    energy_start: f64,
    surface_pressure: &[f64],
    terms: &[Smoothing],
    weight: f64,
) -> Option<Vec<Point>> {
    let over: Vec<Point> = mesh
        .positions()
        .iter()
        .zip(relaxed)
        .map(|(a, b)| a + omega * (b - a))
        .collect();
    let unturned = (0..mesh.triangles().len()).all(|t| {
        area_vector(&corners(mesh, &over, t)).dot(&area_vector(&corners(mesh, relaxed, t))) > 0.0
    });
    let star = Star::new(mesh, terms, surface_pressure, weight);
    (unturned && star.total(&over) < energy_start).then_some(over)
}

/// Work space of [`Star::step`]: every triangle's area vector and `A_t − p_s V_t` at the
/// current positions (updated as a vertex moves: a triangle is evaluated once per move of one
/// of its corners, not once per visit of each corner), the same of the moving vertex's
/// triangles at its trial position (in [`Mesh::vertex_triangles`] order), and the offsets
/// `x − mean of ring` of its smoothing terms at the step's start.
struct Scratch {
    vectors: Vec<Point>,
    energies: Vec<f64>,
    trial_vectors: Vec<Point>,
    trial_energies: Vec<f64>,
    offsets: Vec<Point>,
}

/// One vertex's share of the energy and its Newton step.
struct Star<'a> {
    mesh: &'a Mesh,
    terms: &'a [Smoothing],
    /// The terms whose vertex or ring holds vertex v, in increasing order:
    /// `term_list[term_starts[v]..term_starts[v + 1]]`.
    term_starts: Vec<usize>,
    term_list: Vec<usize>,
    /// `PᵀP` of each term.
    gram: Vec<Matrix3<f64>>,
    surface_pressure: &'a [f64],
    weight: f64,
}

impl<'a> Star<'a> {
    fn new(
        mesh: &'a Mesh,
        terms: &'a [Smoothing],
        surface_pressure: &'a [f64],
        weight: f64,
    ) -> Star<'a> {
        // Each (vertex, term) pair once, in term order: counted, then placed.
        let n = mesh.vertex_count();
        let pairs = || {
            let mut last = vec![usize::MAX; n];
            terms
                .iter()
                .enumerate()
                .flat_map(|(k, term)| {
                    std::iter::once(term.vertex)
                        .chain(term.ring.iter().copied())
                        .map(move |u| (u, k))
                })
                .filter(move |&(u, k)| std::mem::replace(&mut last[u], k) != k)
        };
        let mut term_starts = vec![0; n + 1];
        for (u, _) in pairs() {
            term_starts[u + 1] += 1;
        }
        for v in 0..n {
            term_starts[v + 1] += term_starts[v];
        }
        let mut next = term_starts.clone();
        let mut term_list = vec![0; term_starts[n]];
        for (u, k) in pairs() {
            term_list[next[u]] = k;
            next[u] += 1;
        }
        Star {
            mesh,
            terms,
            term_starts,
            term_list,
            gram: terms
                .iter()
                .map(|term| term.projector.transpose() * term.projector)
                .collect(),
            surface_pressure,
            weight,
        }
    }

    /// The terms whose vertex or ring holds `v`, in increasing order.
    fn terms_of(&self, v: usize) -> &[usize] {
        &self.term_list[self.term_starts[v]..self.term_starts[v + 1]]
    }

    /// The work space of [`Star::step`] for the positions `pos`.
    fn scratch(&self, pos: &[Point]) -> Scratch {
        let (vectors, energies) = (0..self.mesh.triangles().len())
            .map(|t| {
                let c = corners(self.mesh, pos, t);
                let vector = area_vector(&c);
                (vector, self.area_less_work(&c, t, vector))
            })
            .unzip();
        Scratch {
            vectors,
            energies,
            trial_vectors: Vec::new(),
            trial_energies: Vec::new(),
            offsets: Vec::new(),
        }
    }

    /// Moves vertex `v` by its damped Newton step, in the plane ⊥ `normal` when given;
    /// returns the move, m. `scratch` ([`Star::scratch`]) holds the triangles at `pos` and
    /// is kept so.
    fn step(
        &self,
        pos: &mut [Point],
        v: usize,
        normal: Option<Point>,
        scratch: &mut Scratch,
    ) -> f64 {
        let (mut gradient, mut hessian, old_share) = self.derivatives(pos, v, scratch);
        if let Some(n) = normal {
            let p = Matrix3::identity() - n * n.transpose();
            hessian = p * hessian * p + hessian.trace() * n * n.transpose();
            gradient = p * gradient;
        }
        // A flat star with w = 0 has no tangential stiffness: nothing to gain there.
        let Some(cholesky) = hessian.cholesky() else {
            return 0.0;
        };
        let mut step = -cholesky.solve(&gradient);
        let start = pos[v];
        for _ in 0..=HALVINGS {
            pos[v] = start + step;
            if self
                .unturned_share(pos, v, step, scratch)
                .is_some_and(|share| share < old_share)
            {
                for (k, &t) in self.mesh.vertex_triangles(v).iter().enumerate() {
                    scratch.vectors[t] = scratch.trial_vectors[k];
                    scratch.energies[t] = scratch.trial_energies[k];
                }
                return step.norm();
            }
            step *= 0.5;
        }
        pos[v] = start;
        0.0
    }

    /// The share of `v` (the terms of E that depend on `x_v`) after it moved by `step` when no triangle around `v`
    /// has turned over against its area vector in `scratch` (before the move), else None; the
    /// triangles' area vectors and energies there become `scratch`'s trial ones. A term's
    /// offset is linear in `x_v`: `o + c·step` from its offset `o` at the start in `scratch`.
    fn unturned_share(
        &self,
        pos: &[Point],
        v: usize,
        step: Point,
        scratch: &mut Scratch,
    ) -> Option<f64> {
        let mut triangles = 0.0;
        scratch.trial_vectors.clear();
        scratch.trial_energies.clear();
        for &t in self.mesh.vertex_triangles(v) {
            let c = corners(self.mesh, pos, t);
            let vector = area_vector(&c);
            if vector.dot(&scratch.vectors[t]) <= 0.0 {
                return None;
            }
            let energy = self.area_less_work(&c, t, vector);
            scratch.trial_vectors.push(vector);
            scratch.trial_energies.push(energy);
            triangles += energy;
        }
        let terms: f64 = self
            .terms_of(v)
            .iter()
            .zip(&scratch.offsets)
            .map(|(&k, &offset)| {
                self.offset_energy(k, offset + self.terms[k].coefficient(v) * step)
            })
            .sum();
        Some(triangles + terms)
    }

    /// `A_t − p_s V_t` of triangle t (m²).
    fn triangle_energy(&self, pos: &[Point], t: usize) -> f64 {
        let c = corners(self.mesh, pos, t);
        self.area_less_work(&c, t, area_vector(&c))
    }

    /// `A_t − p_s V_t` of triangle t with corners `c` and area vector `vector` (m²); no cone
    /// volume where `p_s = 0` (the same value: `a − 0·V = a`).
    fn area_less_work(&self, c: &[Point; 3], t: usize, vector: Point) -> f64 {
        let p = self.surface_pressure[self.mesh.triangle_surface()[t]];
        if p == 0.0 {
            return vector.norm();
        }
        vector.norm() - p * cone_volume(c, &Point::zeros())
    }

    /// `(w/2)|P_k (x − mean)|²` of term k (m²).
    fn term_energy(&self, pos: &[Point], k: usize) -> f64 {
        self.offset_energy(k, self.terms[k].offset(pos))
    }

    /// `(w/2)|P_k o|²` of term k at the offset `o = x − mean` (m²).
    fn offset_energy(&self, k: usize, offset: Point) -> f64 {
        0.5 * self.weight * (self.terms[k].projector * offset).norm_squared()
    }

    /// The terms of E that depend on `x_v`, m².
    #[cfg(test)]
    fn share(&self, pos: &[Point], v: usize) -> f64 {
        let triangles: f64 = self
            .mesh
            .vertex_triangles(v)
            .iter()
            .map(|&t| self.triangle_energy(pos, t))
            .sum();
        triangles + self.terms_share(pos, v)
    }

    /// The smoothing terms' part of the share of `v`, m².
    #[cfg(test)]
    fn terms_share(&self, pos: &[Point], v: usize) -> f64 {
        self.terms_of(v)
            .iter()
            .map(|&k| self.term_energy(pos, k))
            .sum()
    }

    /// Gradient (m) and diagonal Hessian block (dimensionless) of the share w.r.t. `x_v`, and
    /// the share (m²), from the triangles in `scratch` ([`Star::scratch`] at `pos`); `scratch`'s
    /// offsets become those of the terms of `v`.
    fn derivatives(
        &self,
        pos: &[Point],
        v: usize,
        scratch: &mut Scratch,
    ) -> (Point, Matrix3<f64>, f64) {
        let mut gradient = Point::zeros();
        let mut hessian = Matrix3::zeros();
        let mut triangles = 0.0;
        for &t in self.mesh.vertex_triangles(v) {
            let c = corners(self.mesh, pos, t);
            let vector = scratch.vectors[t];
            triangles += scratch.energies[t];
            let p = self.surface_pressure[self.mesh.triangle_surface()[t]];
            let Some(k) = self.mesh.triangles()[t].iter().position(|&u| u == v) else {
                continue;
            };
            let (area_gradient, area_hessian) = triangle_area_corner_derivatives(&c, &vector, k);
            // No cone-volume gradient where p = 0 (the same sum: adding −0·g adds ±0).
            gradient += if p == 0.0 {
                area_gradient
            } else {
                area_gradient - p * cone_volume_corner_gradient(&c, &Point::zeros(), k)
            };
            hessian += area_hessian;
        }
        scratch.offsets.clear();
        for &k in self.terms_of(v) {
            let term = &self.terms[k];
            let c = term.coefficient(v);
            let pp = self.gram[k];
            let offset = term.offset(pos);
            scratch.offsets.push(offset);
            gradient += self.weight * c * pp * offset;
            hessian += self.weight * c * c * pp;
        }
        let terms: f64 = self
            .terms_of(v)
            .iter()
            .zip(&scratch.offsets)
            .map(|(&k, &offset)| self.offset_energy(k, offset))
            .sum();
        (gradient, hessian, triangles + terms)
    }

    /// E at `pos` (the volumes' cones from the origin), m².
    fn total(&self, pos: &[Point]) -> f64 {
        let triangles: f64 = (0..self.mesh.triangles().len())
            .map(|t| self.triangle_energy(pos, t))
            .sum();
        triangles + self.terms_total(pos)
    }

    /// [`Star::total`] with the triangles' energies from `scratch` ([`Star::scratch`] at
    /// `pos`), m².
    fn total_with(&self, pos: &[Point], scratch: &Scratch) -> f64 {
        let triangles: f64 = scratch.energies.iter().sum();
        triangles + self.terms_total(pos)
    }

    /// The smoothing terms' part of E at `pos`, m².
    fn terms_total(&self, pos: &[Point]) -> f64 {
        (0..self.terms.len())
            .map(|k| self.term_energy(pos, k))
            .sum()
    }
}

/// The corners of triangle `t` at `pos`.
fn corners(mesh: &Mesh, pos: &[Point], t: usize) -> [Point; 3] {
    let [a, b, c] = mesh.triangles()[t];
    [pos[a], pos[b], pos[c]]
}

/// Unit area-weighted normal at a vertex (zero vector if it vanishes).
pub fn vertex_normal(mesh: &Mesh, v: usize) -> Point {
    let n: Point = mesh
        .vertex_triangles(v)
        .iter()
        .map(|&t| area_vector(&mesh.corners(t)))
        .sum();
    n.try_normalize(0.0).unwrap_or_else(Point::zeros)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::generators;

    /// Moves every vertex `i` by `offset(i as f64, fixed)`.
    fn jitter(mesh: &mut Mesh, offset: impl Fn(f64, bool) -> Point) {
        let moved: Vec<Point> = mesh
            .positions()
            .iter()
            .enumerate()
            .map(|(i, p)| p + offset(i as f64, mesh.flags()[i].fixed))
            .collect();
        mesh.set_positions(moved).unwrap();
    }

    /// Over-relaxing a relaxation of a jittered film: ω = 1 returns the relaxed positions (to roundoff)
    /// (every triangle kept, E below the start), a huge ω is refused.
    #[test]
    fn over_relaxation_is_refused_when_it_turns_triangles_or_raises_the_energy() {
        let mut mesh = generators::cube_frame(0.05, None, 3).unwrap().mesh;
        jitter(&mut mesh, |t, fixed| {
            if fixed {
                Point::zeros()
            } else {
                1e-3 * Point::new(t.sin(), (1.7 * t).cos(), 0.0)
            }
        });
        let pressures = vec![0.0; mesh.surfaces().len()];
        let motion = |v: usize| {
            if mesh.flags()[v].fixed {
                Motion::Held
            } else {
                Motion::Free
            }
        };
        let (relaxed, relaxation) = relax(&mesh, &pressures, motion, &[], 0.0, 0.0, 3);
        assert!(relaxation.energy.1 < relaxation.energy.0);
        // ω = 1 is the relaxation itself: accepted, unchanged.
        let over = over_relaxed(
            &mesh,
            &relaxed,
            1.0,
            relaxation.energy.0,
            &pressures,
            &[],
            0.0,
        )
        .unwrap();
        assert!(
            over.iter()
                .zip(&relaxed)
                .all(|(a, b)| (a - b).norm() < 1e-12)
        );
        assert!(
            over_relaxed(
                &mesh,
                &relaxed,
                1e3,
                relaxation.energy.0,
                &pressures,
                &[],
                0.0
            )
            .is_none()
        );
    }

    /// A vertex's share of E: its gradient and diagonal Hessian block against central
    /// differences of the share (and of that gradient), on a jittered cube frame with a bubble
    /// (films, junction lines and a body), pressures on every surface and smoothing terms.
    #[test]
    fn a_vertex_shares_derivatives_match_central_differences() {
        let mut mesh = generators::cube_frame(0.05, Some(2e-5), 3).unwrap().mesh;
        jitter(&mut mesh, |t, _| {
            2e-3 * Point::new((1.3 * t).sin(), (2.1 * t).cos(), (0.7 * t).sin())
        });
        let n = mesh.vertex_count();
        let terms: Vec<Smoothing> = (0..n)
            .step_by(3)
            .map(|v| {
                let normal = vertex_normal(&mesh, v);
                Smoothing {
                    vertex: v,
                    projector: Matrix3::identity() - normal * normal.transpose(),
                    ring: mesh.neighbours(v).to_vec(),
                }
            })
            .collect();
        let pressures: Vec<f64> = (0..mesh.surfaces().len())
            .map(|s| 30.0 + 7.0 * s as f64)
            .collect();
        let star = Star::new(&mesh, &terms, &pressures, 0.7);
        let h = 1e-6;
        let mut pos = mesh.positions().to_vec();
        for v in (0..n).step_by(5) {
            let mut scratch = star.scratch(&pos);
            let (gradient, hessian, share) = star.derivatives(&pos, v, &mut scratch);
            assert_eq!(share, star.share(&pos, v));
            let centre = pos[v];
            // The trial share from the start's offsets matches the share at the moved vertex.
            let step = Point::new(1e-5, -2e-5, 5e-6);
            pos[v] = centre + step;
            let trial = star.unturned_share(&pos, v, step, &mut scratch);
            assert_eq!(scratch.trial_energies.len(), mesh.vertex_triangles(v).len());
            let moved = star.share(&pos, v);
            pos[v] = centre;
            assert!(
                trial.is_some_and(|t| (t - moved).abs() <= 1e-12 * (1.0 + moved.abs())),
                "vertex {v}: {trial:?} vs {moved}"
            );
            for a in 0..3 {
                pos[v][a] = centre[a] + h;
                let (plus, g_plus) = (
                    star.share(&pos, v),
                    star.derivatives(&pos, v, &mut star.scratch(&pos)).0,
                );
                pos[v][a] = centre[a] - h;
                let (minus, g_minus) = (
                    star.share(&pos, v),
                    star.derivatives(&pos, v, &mut star.scratch(&pos)).0,
                );
                pos[v][a] = centre[a];
                let slope = (plus - minus) / (2.0 * h);
                assert!(
                    (slope - gradient[a]).abs() <= 1e-6 * (1.0 + gradient.norm()),
                    "vertex {v} axis {a}: {slope} vs {}",
                    gradient[a]
                );
                let column = (g_plus - g_minus) / (2.0 * h);
                for b in 0..3 {
                    assert!(
                        (column[b] - hessian[(b, a)]).abs() <= 1e-5 * (1.0 + hessian.norm()),
                        "vertex {v} H[{b},{a}]: {} vs {}",
                        column[b],
                        hessian[(b, a)]
                    );
                }
            }
        }
    }
}
