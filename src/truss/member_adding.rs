//! The layout LP over a ground structure too large to build, solved on a growing subset of its
//! members (member adding, Gilbert & Tyas 2003), with a certificate of optimality over all of
//! them.
//!
//! Pricing. The LP's duals y (one per balance row r of joint i, [`super::plastic`]) give each
//! joint a virtual displacement u_i = Σ_r y_r·r (zero at a pinned anchor). A potential member
//! p–q of length l and unit vector e = (x_q − x_p)/l, costing a per newton of tension and b
//! per newton of compression, with self-weight w_T, w_C kg per newton lumped half on each end,
//! has the dual terms (its column of the LP times y)
//! ```text
//!     compression:  d_C =  e·(u_q − u_p) + ½·w_C·g·(u_p + u_q)
//!     tension:      d_T = −e·(u_q − u_p) + ½·w_T·g·(u_p + u_q)
//! ```
//! and its violation is v = max(d_T/a, d_C/b) − 1 over every load case. Without self-weight and
//! with a = l/σ_T, b = l/σ_C this is Gilbert & Tyas's virtual-strain test: the member would
//! lower the LP optimum when its virtual strain e·(u_q − u_p)/l exceeds 1/σ.
//!
//! Iteration: solve every load case on the current members; price every admissible pair of
//! joints; add those with v > [`ADD_TOLERANCE`], most violated first, at most
//! max([`ADD_MIN`], current members) per iteration, closed under the caller's rule (mirror
//! images); repeat until none is left. Pricing costs O(n²·cases) per iteration for n joints;
//! the LP only ever holds the members added.
//!
//! Solvers: the LPs whose duals only price are solved by the revised simplex method
//! ([`super::simplex`], up to `SIMPLEX_ROWS` balance rows), each from the previous LP's optimal
//! basis: the added columns are nonbasic at 0, so that basis stays primal feasible and only the
//! added columns that price negative enter (pier_cantilever_linear: 212 pivots cold, then 41,
//! 4, 2). Once a vertex's duals price every pair out, the start ([`super::start`]) wants the
//! forces of the optimal face's interior, spread over tied members, not a vertex's: the
//! vertex's duals give the face (the columns of zero reduced cost, [`plastic::layout_on_face`]);
//! when it holds only basic columns the vertex is the only optimum and stands, otherwise the
//! interior point solves the LP on the face's columns alone.
//!
//! Certificate: at the end no admissible pair has v > `ADD_TOLERANCE` and the members in the
//! LP have v ≤ v_in (the residual of the duals that priced), so y/(1 + max(v_in, tolerance))
//! is feasible for the dual of the LP over every admissible pair and its dual objective is a
//! lower bound on that LP's optimum ([`Layouts::lower_bound`]). With the simplex, y is the
//! vertex's and the primal optimum the vertex or the interior point's on its face.
//!
//! Admissible pairs: the caller's rule for a pair's ends (anchors, forbidden pairs,
//! obstacles), and no joint on the segment: q must be the nearest joint to p in its direction.
//! Directions are compared quantized to 2⁻³² (a pair that rounding splits from its direction
//! is admitted: an overlapping member changes neither the LP optimum nor its certificate,
//! only the LP's size). That test costs O(n) per joint that ends a violating pair.

use std::collections::{HashMap, HashSet};

use super::lp::LpError;
use super::mass::gravity;
use super::model::{Beam, Structure, Vec3};
use super::nlp::balance_basis;
use super::plastic::{self, LpMethod, PlasticLayout};
use super::simplex::Basic;
use crate::solver::Interrupt;

/// Violation v above which a member is added (relative to its cost).
pub const ADD_TOLERANCE: f64 = 1e-6;

/// Fewest members added per iteration when that many violate.
pub const ADD_MIN: usize = 200;

/// Largest number of LP solves; the growth at least doubles the LP's size on every
/// iteration that does not end it, so this bound is never reached below a billion members.
const MAX_ITERATIONS: usize = 30;

/// Most balance rows for which the LPs that only price are solved by the dense revised
/// simplex method ([`super::simplex`]: O(m²) per pivot, O(m³) per refactorization); larger
/// LPs (the 3-D layouts) are all solved by the interior point.
const SIMPLEX_ROWS: usize = 200;

/// The price of one member: LP cost per newton and self-weight per newton.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MemberPrice {
    /// Cost per newton of (tension, compression), in the LP's cost unit.
    pub cost: (f64, f64),
    /// Self-weight, kg per newton of (tension, compression), if the LP lumps it on the ends.
    pub weight: Option<(f64, f64)>,
}

/// How the member set may grow: the pairs of joints that may become members (besides the
/// no-joint-on-the-segment test), and the closure of a member set under the problem's rules.
pub struct Growth<'a> {
    /// Whether a pair of joints may be a member (ends, forbidden pairs, obstacles).
    pub admits: &'a dyn Fn(Beam) -> bool,
    /// The member set closed under the problem's rules (mirror images), sorted.
    pub close: &'a dyn Fn(Vec<Beam>) -> Vec<Beam>,
}

/// The layout LP of every load case on a member set, with its certificate.
#[derive(Debug, Clone, PartialEq)]
pub struct Layouts {
    /// The members of the last LP.
    pub beams: Vec<Beam>,
    /// The LP solution per load case (forces on `beams`).
    pub cases: Vec<PlasticLayout>,
    /// LP solves.
    pub iterations: usize,
    /// Members added to the first set.
    pub added: usize,
    /// Whether every admissible pair of joints was priced (member adding), or only `beams`.
    pub all_pairs: bool,
    /// The largest violation v certified over the priced members (≥ 0).
    pub violation: f64,
    /// The last simplex basis of each case's LP (empty where none was solved).
    pub bases: Vec<Vec<BasisKey>>,
}

impl Layouts {
    /// Lower bound on the LP optimum of each case over the priced members (module header).
    pub fn lower_bound(&self) -> Vec<f64> {
        (self.cases.iter())
            .map(|c| c.dual_volume / (1.0 + self.violation))
            .collect()
    }
}

/// A basic variable of a layout LP by what it is (a member's compression or tension column, or
/// a balance row's artificial variable), so that a basis carries over to an LP whose members
/// are numbered otherwise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BasisKey {
    /// The compression column of a member.
    Compression(Beam),
    /// The tension column of a member.
    Tension(Beam),
    /// The artificial variable of a balance row.
    Row(usize),
}

/// A simplex basis of the layout LP on `beams` (columns as in [`plastic::LayoutLp`]) by key.
fn keys_of(basis: &[Basic], beams: &[Beam]) -> Vec<BasisKey> {
    (basis.iter())
        .map(|&k| match k {
            Basic::Column(j) if j < beams.len() => BasisKey::Compression(beams[j]),
            Basic::Column(j) => BasisKey::Tension(beams[j - beams.len()]),
            Basic::Artificial(r) => BasisKey::Row(r),
        })
        .collect()
}

/// The basis of keys on the LP of `beams`; None when a key's member is not among them.
fn basis_of(keys: &[BasisKey], beams: &[Beam]) -> Option<Vec<Basic>> {
    let index: HashMap<Beam, usize> = beams.iter().enumerate().map(|(j, b)| (*b, j)).collect();
    (keys.iter())
        .map(|&k| match k {
            BasisKey::Compression(b) => index.get(&b).map(|&j| Basic::Column(j)),
            BasisKey::Tension(b) => index.get(&b).map(|&j| Basic::Column(beams.len() + j)),
            BasisKey::Row(r) => Some(Basic::Artificial(r)),
        })
        .collect()
}

/// Solves the layout LP of every case on `structure`'s beams, priced by `price` (by member
/// length, m); with `growth`, adds violating members until none is left (module header).
/// `axes` balance directions; loads as in [`plastic::layout_with_costs`]. Should a larger LP
/// fail (the interior-point method's failure: adding columns keeps an LP feasible), the last
/// solved one is returned with the largest violation it left, so its bound still holds.
///
/// With `growth` and [`LpMethod::InteriorFace`] (and at most `SIMPLEX_ROWS` rows), the LPs
/// whose duals only price are solved by the revised simplex method, each from the previous
/// one's optimal basis (per case; the first from `warm` if given, e.g. a previous pass's
/// [`Layouts::bases`]); once a vertex's duals price every pair out, the forces are the
/// vertex's or the interior point's on its optimal face (module header). A simplex failure
/// other than an interrupt leaves that LP to `method`.
pub fn solve(
    structure: &Structure,
    axes: usize,
    price: &dyn Fn(f64) -> MemberPrice,
    growth: Option<&Growth>,
    method: LpMethod,
    warm: &[Vec<BasisKey>],
    interrupt: &Interrupt,
) -> Result<Layouts, LpError> {
    let cases = structure.joints.first().map_or(0, |j| j.loads.len());
    let mut current = structure.clone();
    let mut added = 0;
    // The last solved iteration and the largest violation it left, should a larger LP fail.
    let mut previous: Option<Layouts> = None;
    let rows: usize = (structure.joints.iter())
        .map(|j| balance_basis(&j.kind, axes).len())
        .sum();
    let vertex = growth.is_some() && method == LpMethod::InteriorFace && rows <= SIMPLEX_ROWS;
    let mut bases = warm.to_vec();
    bases.resize(cases, Vec::new());
    for iteration in 1..=MAX_ITERATIONS {
        let prices: Vec<MemberPrice> = (0..current.beams.len())
            .map(|j| price(current.length(j)))
            .collect();
        let costs: Vec<(f64, f64)> = prices.iter().map(|p| p.cost).collect();
        let weights: Option<Vec<(f64, f64)>> = prices.iter().map(|p| p.weight).collect();
        let weights = weights.as_deref();
        let mut solved = Ok(Vec::with_capacity(cases));
        for (c, basis) in bases.iter_mut().enumerate() {
            let by_vertex = vertex.then(|| {
                let start = basis_of(basis, &current.beams);
                let s = plastic::layout_by_simplex(
                    &current,
                    c,
                    axes,
                    &costs,
                    weights,
                    start.as_deref(),
                    interrupt,
                );
                s.map(|(layout, b)| {
                    *basis = keys_of(&b, &current.beams);
                    layout
                })
            });
            let layout = match by_vertex {
                Some(Ok(layout)) => Ok(layout),
                Some(Err(LpError::Interrupted)) => Err(LpError::Interrupted),
                _ => plastic::layout_with_costs(
                    &current, c, axes, &costs, weights, method, interrupt,
                ),
            };
            match (layout, solved.as_mut()) {
                (Ok(layout), Ok(all)) => all.push(layout),
                (Err(e), Ok(_)) => solved = Err(e),
                _ => {}
            }
            if solved.is_err() {
                break;
            }
        }
        let layouts = match (solved, previous) {
            (Ok(layouts), _) => layouts,
            // An interrupted LP ends the layout at once.
            (Err(LpError::Interrupted), _) => return Err(LpError::Interrupted),
            // Adding columns keeps the LP feasible: a failure is the interior-point method's
            // on the larger LP; the smaller one's solution stands, uncertified.
            (Err(_), Some(previous)) => return Ok(previous),
            (Err(e), None) => return Err(e),
        };
        let displacements: Vec<Vec<Vec3>> = (layouts.iter())
            .map(|l| plastic::virtual_displacements(&current, axes, &l.duals))
            .collect();
        let violation = |beam: Beam| {
            let length = (current.joints[beam.ends[1]].position
                - current.joints[beam.ends[0]].position)
                .norm();
            member_violation(&current, beam, &price(length), &displacements)
        };
        let inside = (current.beams.iter())
            .map(|&b| violation(b))
            .fold(0.0, f64::max);
        let violators = match growth {
            Some(growth) => admissible_violators(&current, growth, &violation),
            None => Vec::new(),
        };
        let done = |violation: f64| Layouts {
            beams: current.beams.clone(),
            cases: layouts.clone(),
            iterations: iteration,
            added,
            all_pairs: growth.is_some(),
            violation,
            bases: bases.clone(),
        };
        let Some(growth) = growth.filter(|_| !violators.is_empty()) else {
            let tolerance = if growth.is_some() { ADD_TOLERANCE } else { 0.0 };
            let certified = done(inside.max(tolerance));
            if vertex {
                return with_interior_forces(
                    certified, &current, axes, &costs, weights, method, interrupt,
                );
            }
            return Ok(certified);
        };
        // Not certified over every pair: the largest violation left is the honest figure.
        let uncertified = done(violators[0].0.max(inside));
        if iteration == MAX_ITERATIONS {
            return Ok(uncertified);
        }
        previous = Some(uncertified);
        let limit = ADD_MIN.max(current.beams.len());
        let before = current.beams.len();
        let mut beams = current.beams.clone();
        beams.extend(violators.iter().take(limit).map(|v| v.1));
        current.beams = (growth.close)(beams);
        added += current.beams.len() - before;
    }
    unreachable!("the loop returns on its last iteration")
}

/// `vertex` (certified by the simplex's duals) with each case's primal solution replaced by
/// the interior point's on the same LP's optimal face ([`plastic::layout_on_face`], from the
/// vertex's duals): its forces spread over tied members, the start the geometry solve expects
/// ([`super::start`]). The certificate stays the vertex's: its duals priced every pair. Should
/// the face's LP fail, the whole LP is solved by `method`; should that fail, the vertex stands.
fn with_interior_forces(
    mut vertex: Layouts,
    structure: &Structure,
    axes: usize,
    costs: &[(f64, f64)],
    weights: Option<&[(f64, f64)]>,
    method: LpMethod,
    interrupt: &Interrupt,
) -> Result<Layouts, LpError> {
    for (c, layout) in vertex.cases.iter_mut().enumerate() {
        let basis = basis_of(&vertex.bases[c], &vertex.beams).unwrap_or_default();
        let lp = plastic::layout_lp(structure, c, axes, costs, weights);
        let on_face = plastic::layout_on_face(&lp, layout, &basis, interrupt);
        let interior = match on_face {
            Err(e) if e != LpError::Interrupted => {
                plastic::layout_with_costs(structure, c, axes, costs, weights, method, interrupt)
            }
            solved => solved,
        };
        match interior {
            Ok(interior) => {
                layout.volume = interior.volume;
                layout.forces = interior.forces;
                layout.primal_residual = interior.primal_residual;
            }
            Err(LpError::Interrupted) => return Err(LpError::Interrupted),
            Err(_) => {}
        }
    }
    vertex.iterations += 1;
    Ok(vertex)
}

/// The violation v of `beam` (module header) over the cases' virtual displacements.
fn member_violation(
    structure: &Structure,
    beam: Beam,
    price: &MemberPrice,
    displacements: &[Vec<Vec3>],
) -> f64 {
    let [p, q] = beam.ends;
    let d = structure.joints[q].position - structure.joints[p].position;
    let e = d / d.norm();
    let (cost_t, cost_c) = price.cost;
    let (w_t, w_c) = price.weight.unwrap_or((0.0, 0.0));
    (displacements.iter())
        .map(|u| {
            let stretch = e.dot(&(u[q] - u[p]));
            let lift = 0.5 * gravity().dot(&(u[p] + u[q]));
            let compression = (stretch + w_c * lift) / cost_c;
            let tension = (-stretch + w_t * lift) / cost_t;
            compression.max(tension) - 1.0
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Admissible pairs not in the structure with violation above [`ADD_TOLERANCE`], most violated
/// first (ties by pair), with their violations.
fn admissible_violators(
    structure: &Structure,
    growth: &Growth,
    violation: &dyn Fn(Beam) -> f64,
) -> Vec<(f64, Beam)> {
    let mut found = admissible_where(structure, growth, |b| {
        let v = violation(b);
        (v > ADD_TOLERANCE).then_some(v)
    });
    found.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    found
}

/// Every admissible pair of joints not in the structure (module header), in pair order: the
/// members that member adding may price.
pub fn admissible_pairs(structure: &Structure, growth: &Growth) -> Vec<Beam> {
    (admissible_where(structure, growth, |_| Some(())).into_iter())
        .map(|(_, b)| b)
        .collect()
}

/// The pairs p < q not in the structure for which `value` is some, that `growth` admits and
/// whose q is the nearest joint to p in its direction, with their values, in pair order.
/// `value` is tested first: it may be the cheaper filter.
fn admissible_where<T>(
    structure: &Structure,
    growth: &Growth,
    value: impl Fn(Beam) -> Option<T>,
) -> Vec<(T, Beam)> {
    let joints = &structure.joints;
    let present: HashSet<Beam> = structure.beams.iter().copied().collect();
    let mut found = Vec::new();
    for p in 0..joints.len() {
        let mine: Vec<(T, Beam)> = (p + 1..joints.len())
            .map(|q| Beam::new(p, q))
            .filter(|b| !present.contains(b))
            .filter_map(|b| value(b).map(|v| (v, b)))
            .filter(|&(_, b)| (growth.admits)(b))
            .collect();
        if mine.is_empty() {
            continue;
        }
        let nearest = nearest_by_direction(structure, p);
        found.extend(mine.into_iter().filter(|(_, b)| {
            let q = b.ends[1];
            nearest.get(&direction_key(structure, p, q)) == Some(&q)
        }));
    }
    found
}

/// The direction from joint p to joint q, quantized to 2⁻³² (module header).
fn direction_key(structure: &Structure, p: usize, q: usize) -> [i64; 3] {
    let d = structure.joints[q].position - structure.joints[p].position;
    let e = d / d.norm();
    let scale = 2f64.powi(32);
    [0, 1, 2].map(|k| (e[k] * scale).round() as i64)
}

/// For every direction from joint p, the nearest joint in it (ties by index).
fn nearest_by_direction(structure: &Structure, p: usize) -> HashMap<[i64; 3], usize> {
    let joints = &structure.joints;
    let mut nearest: HashMap<[i64; 3], (f64, usize)> = HashMap::new();
    for q in (0..joints.len()).filter(|&q| q != p) {
        let distance = (joints[q].position - joints[p].position).norm();
        nearest
            .entry(direction_key(structure, p, q))
            .and_modify(|best| {
                if distance < best.0 {
                    *best = (distance, q);
                }
            })
            .or_insert((distance, q));
    }
    nearest.into_iter().map(|(k, (_, q))| (k, q)).collect()
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use super::*;
    use crate::truss::ground;
    use crate::truss::model::{Joint, JointKind, Support};
    use crate::truss::testing::planar_joint;

    /// A cantilever on an `nx` × `ny` grid of step 1: the left column pinned, a unit load down
    /// at the middle of the right column; beams to the `neighbours` nearest joints.
    fn cantilever(nx: usize, ny: usize, neighbours: usize) -> Structure {
        let mut joints: Vec<Joint> = Vec::new();
        for i in 0..nx {
            for k in 0..ny {
                let kind = if i == 0 {
                    JointKind::Anchor(Support::Pinned)
                } else if i == nx - 1 && k == ny / 2 {
                    JointKind::Load
                } else {
                    JointKind::Free
                };
                let mut joint = planar_joint(i as f64, k as f64, kind);
                if joint.kind == JointKind::Load {
                    joint.loads[0] = Vec3::new(0.0, -1.0, 0.0);
                }
                joints.push(joint);
            }
        }
        let beams = ground::connect(&joints, neighbours, &BTreeSet::new(), &[], &[], 1e-9);
        Structure { joints, beams }
    }

    /// The test growth rule: no member joins two anchors.
    fn not_between_anchors(s: &Structure, b: Beam) -> bool {
        let [a, c] = b.ends;
        !(s.joints[a].is_anchor() && s.joints[c].is_anchor())
    }

    /// The test closure: the members sorted.
    fn sorted(mut beams: Vec<Beam>) -> Vec<Beam> {
        beams.sort();
        beams
    }

    fn unit_price(length: f64) -> MemberPrice {
        MemberPrice {
            cost: (length, 0.5 * length),
            weight: None,
        }
    }

    #[test]
    fn member_adding_reaches_the_full_ground_structure_optimum_with_a_certificate() {
        let (nx, ny) = (7, 5);
        let full = cantilever(nx, ny, nx * ny);
        let reference = solve(
            &full,
            2,
            &unit_price,
            None,
            LpMethod::Simplex,
            &[],
            &Interrupt::new(),
        )
        .unwrap();
        let sparse = cantilever(nx, ny, 4);
        let admits = |b: Beam| not_between_anchors(&sparse, b);
        let growth = Growth {
            admits: &admits,
            close: &sorted,
        };
        let grown = solve(
            &sparse,
            2,
            &unit_price,
            Some(&growth),
            LpMethod::InteriorPoint,
            &[],
            &Interrupt::new(),
        )
        .unwrap();
        let (optimum, volume) = (reference.cases[0].volume, grown.cases[0].volume);
        assert!(
            (volume - optimum).abs() < 1e-7 * optimum,
            "member adding {volume} vs full {optimum}"
        );
        assert!(grown.all_pairs && grown.added > 0 && grown.iterations > 1);
        assert!(
            grown.beams.len() < full.beams.len(),
            "{}",
            grown.beams.len()
        );
        let bound = grown.lower_bound()[0];
        assert!(bound <= optimum * (1.0 + 1e-12) && bound > optimum * (1.0 - 2e-6));
        // The certificate: every member of the full ground structure priced with the final duals.
        let u = plastic::virtual_displacements(
            &Structure {
                joints: sparse.joints.clone(),
                beams: grown.beams.clone(),
            },
            2,
            &grown.cases[0].duals,
        );
        let worst = (0..full.beams.len())
            .map(|j| {
                member_violation(
                    &full,
                    full.beams[j],
                    &unit_price(full.length(j)),
                    std::slice::from_ref(&u),
                )
            })
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(worst <= grown.violation, "{worst} > {}", grown.violation);
        assert!(worst <= ADD_TOLERANCE, "{worst}");
        // The full LP's optimum members are all among the priced pairs' nearest ones: a pair
        // through a joint is never added.
        for b in &grown.beams {
            assert!(full.beams.contains(b), "{b:?} passes through a joint");
        }
    }

    #[test]
    fn the_warm_started_simplex_prices_like_the_interior_point_on_ground_structures() {
        let interrupt = Interrupt::new();
        // Each LP of the full 7 × 5 and 6 × 4 ground structures: the same optimum both ways.
        for (nx, ny) in [(7, 5), (6, 4)] {
            let full = cantilever(nx, ny, nx * ny);
            let costs: Vec<(f64, f64)> = (0..full.beams.len())
                .map(|j| unit_price(full.length(j)).cost)
                .collect();
            let layout = |method| {
                plastic::layout_with_costs(&full, 0, 2, &costs, None, method, &interrupt).unwrap()
            };
            let interior = layout(LpMethod::InteriorFace);
            let (vertex, basis) =
                plastic::layout_by_simplex(&full, 0, 2, &costs, None, None, &interrupt).unwrap();
            let gap = (vertex.volume - interior.volume).abs() / interior.volume;
            assert!(gap < 1e-9, "{nx} × {ny}: {gap}");
            assert!((vertex.dual_volume - vertex.volume).abs() < 1e-9 * vertex.volume);
            assert!(vertex.primal_residual < 1e-9 && vertex.dual_infeasibility < 1e-9);
            // From its own optimal basis: no pivot, the same vertex.
            let (again, _) =
                plastic::layout_by_simplex(&full, 0, 2, &costs, None, Some(&basis), &interrupt)
                    .unwrap();
            assert_eq!(again.forces, vertex.forces);
        }
        // Member adding by the simplex (`InteriorFace`): the full LP's optimum, certified, and
        // the forces of the interior point on the last LP's optimal face.
        let (nx, ny) = (7, 5);
        let full = cantilever(nx, ny, nx * ny);
        let reference = solve(
            &full,
            2,
            &unit_price,
            None,
            LpMethod::Simplex,
            &[],
            &interrupt,
        )
        .unwrap()
        .cases[0]
            .volume;
        let sparse = cantilever(nx, ny, 4);
        let admits = |b: Beam| not_between_anchors(&sparse, b);
        let growth = Growth {
            admits: &admits,
            close: &sorted,
        };
        let method = LpMethod::InteriorFace;
        let grown = solve(
            &sparse,
            2,
            &unit_price,
            Some(&growth),
            method,
            &[],
            &interrupt,
        )
        .unwrap();
        let volume = grown.cases[0].volume;
        assert!(
            (volume - reference).abs() < 1e-7 * reference,
            "{volume} vs {reference}"
        );
        assert!(grown.bases[0].len() == grown.cases[0].duals.len());
        let bound = grown.lower_bound()[0];
        assert!(bound <= reference * (1.0 + 1e-12) && bound > reference * (1.0 - 2e-6));
        let on_last = Structure {
            joints: sparse.joints.clone(),
            beams: grown.beams.clone(),
        };
        // The last LP by the interior point: the same optimum, and the forces of the same
        // members (the optimal face's relative interior; the split over tied members differs).
        let last = solve(&on_last, 2, &unit_price, None, method, &[], &interrupt).unwrap();
        let (whole, face) = (&last.cases[0], &grown.cases[0]);
        assert!((whole.volume - face.volume).abs() < 1e-9 * whole.volume);
        assert!(face.primal_residual < 1e-9, "{}", face.primal_residual);
        let largest = whole.forces.iter().fold(0.0, |a: f64, f| a.max(f.abs()));
        let support =
            |f: &[f64]| -> Vec<bool> { f.iter().map(|v| v.abs() > 1e-6 * largest).collect() };
        assert_eq!(support(&whole.forces), support(&face.forces));
        // Warm from the last bases, the next pass starts at an optimal vertex.
        let again = solve(
            &on_last,
            2,
            &unit_price,
            Some(&growth),
            method,
            &grown.bases,
            &interrupt,
        )
        .unwrap();
        assert_eq!(again.iterations, 2, "one vertex, one solve on its face");
    }

    #[test]
    fn the_admissible_pairs_complete_the_ground_structure_whose_lp_member_adding_solves() {
        let (nx, ny) = (6, 4);
        let full = cantilever(nx, ny, nx * ny);
        let sparse = cantilever(nx, ny, 4);
        let admits = |b: Beam| {
            let [a, c] = b.ends;
            !(sparse.joints[a].is_anchor() && sparse.joints[c].is_anchor())
        };
        let close = |beams: Vec<Beam>| beams;
        let growth = Growth {
            admits: &admits,
            close: &close,
        };
        let added = admissible_pairs(&sparse, &growth);
        let mut whole = sparse.clone();
        whole.beams.extend(&added);
        let distinct: HashSet<Beam> = whole.beams.iter().copied().collect();
        assert_eq!(distinct.len(), whole.beams.len(), "a pair listed twice");
        for b in &added {
            assert!(!sparse.beams.contains(b) && admits(*b), "{b:?}");
            assert!(full.beams.contains(b), "{b:?} passes through a joint");
        }
        // Every pair of the full ground structure that the rule admits is there.
        let admitted = (full.beams.iter()).filter(|b| admits(**b)).count();
        assert_eq!(distinct.len(), admitted);
        let interrupt = Interrupt::new();
        let volume = |s: &Structure| {
            let costs: Vec<(f64, f64)> = (0..s.beams.len())
                .map(|j| unit_price(s.length(j)).cost)
                .collect();
            plastic::layout_with_costs(s, 0, 2, &costs, None, LpMethod::Simplex, &interrupt)
                .unwrap()
                .volume
        };
        let grown = solve(
            &sparse,
            2,
            &unit_price,
            Some(&growth),
            LpMethod::InteriorPoint,
            &[],
            &interrupt,
        )
        .unwrap();
        let (whole_lp, adding) = (volume(&whole), grown.cases[0].volume);
        assert!(
            (whole_lp - adding).abs() < 1e-7 * whole_lp,
            "{whole_lp} vs {adding}"
        );
    }
}
