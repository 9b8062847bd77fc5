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
//! Certificate: at the end no admissible pair has v > `ADD_TOLERANCE` and the members in the
//! LP have v ≤ v_in (the interior point's residual), so y/(1 + max(v_in, tolerance)) is
//! feasible for the dual of the LP over every admissible pair and its dual objective is a
//! lower bound on that LP's optimum ([`Layouts::lower_bound`]).
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
use super::plastic::{self, LpMethod, PlasticLayout};
use crate::solver::Interrupt;

/// Violation v above which a member is added (relative to its cost).
pub const ADD_TOLERANCE: f64 = 1e-6;

/// Fewest members added per iteration when that many violate.
pub const ADD_MIN: usize = 200;

/// Largest number of LP solves; the growth at least doubles the LP's size on every
/// iteration that does not end it, so this bound is never reached below a billion members.
const MAX_ITERATIONS: usize = 30;

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
}

impl Layouts {
    /// Lower bound on the LP optimum of each case over the priced members (module header).
    pub fn lower_bound(&self) -> Vec<f64> {
        (self.cases.iter())
            .map(|c| c.dual_volume / (1.0 + self.violation))
            .collect()
    }
}

/// Solves the layout LP of every case on `structure`'s beams, priced by `price` (by member
/// length, m); with `growth`, adds violating members until none is left (module header).
/// `axes` balance directions; loads as in [`plastic::layout_with_costs`]. Should a larger LP
/// fail (the interior-point method's failure: adding columns keeps an LP feasible), the last
/// solved one is returned with the largest violation it left, so its bound still holds.
pub fn solve(
    structure: &Structure,
    axes: usize,
    price: &dyn Fn(f64) -> MemberPrice,
    growth: Option<&Growth>,
    method: LpMethod,
    interrupt: &Interrupt,
) -> Result<Layouts, LpError> {
    let cases = structure.joints.first().map_or(0, |j| j.loads.len());
    let mut current = structure.clone();
    let mut added = 0;
    // The last solved iteration and the largest violation it left, should a larger LP fail.
    let mut previous: Option<Layouts> = None;
    for iteration in 1..=MAX_ITERATIONS {
        let prices: Vec<MemberPrice> = (0..current.beams.len())
            .map(|j| price(current.length(j)))
            .collect();
        let costs: Vec<(f64, f64)> = prices.iter().map(|p| p.cost).collect();
        let weights: Option<Vec<(f64, f64)>> = prices.iter().map(|p| p.weight).collect();
        let solved = (0..cases)
            .map(|c| {
                let weights = weights.as_deref();
                plastic::layout_with_costs(&current, c, axes, &costs, weights, method, interrupt)
            })
            .collect::<Result<Vec<_>, _>>();
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
        };
        let Some(growth) = growth.filter(|_| !violators.is_empty()) else {
            let tolerance = if growth.is_some() { ADD_TOLERANCE } else { 0.0 };
            return Ok(done(inside.max(tolerance)));
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
            &Interrupt::new(),
        )
        .unwrap();
        let sparse = cantilever(nx, ny, 4);
        let admits = |b: Beam| {
            let [a, c] = b.ends;
            !(sparse.joints[a].is_anchor() && sparse.joints[c].is_anchor())
        };
        let close = |mut beams: Vec<Beam>| {
            beams.sort();
            beams
        };
        let growth = Growth {
            admits: &admits,
            close: &close,
        };
        let grown = solve(
            &sparse,
            2,
            &unit_price,
            Some(&growth),
            LpMethod::InteriorPoint,
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
