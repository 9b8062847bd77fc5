//! Staged start: a plastic layout LP on the fixed ground structure gives the geometry solve
//! forces that balance the loads, and the beams it leaves idle are dropped before that solve.
//!
//! Stage 1 (sizing at fixed geometry, a linear program solved by the sparse interior-point
//! method of [`super::lp::solve_sparse`]): per load case
//! ```text
//!     min Σ_j (a_j·t_j + b_j·c_j)   s.t. force balance (the NLP's rows),
//!                                        t, c ≥ 0,  λ = c − t   (N, + compression)
//! ```
//! with per-newton costs that follow the mass model at the start lengths L_j (m):
//! - tension `a_j = k_T·L_j`;
//! - compression, linear law `b_j = w·k_C·L_j`; Euler law `b_j = w·k_C·L_j²/√F`, the secant of
//!   `k_C·√c·L²` through 0 and the largest load F (members carrying about F are priced exactly,
//!   lighter ones too cheaply, heavier ones too dearly);
//! - the `length` objective prices every newton by `L_j` (the load path).
//!
//! Self-weight (when the model has it): each beam's mass is estimated by the same per-newton
//! laws (`m_j ≈ k_T·L_j·t_j + b_j·c_j`, without the tension-preference weight) and lumped half on
//! each end, which keeps the balance rows linear in t and c. Exact for linear mass; for Euler
//! mass it is the secant estimate. Without it, a joint the LP leaves on a straight chord of
//! two collinear members has no member to carry that chord's weight: the geometry solve can
//! only balance it by bending the chord, which an obstacle plane through the chord (a roof's
//! ceiling line) forbids, and the solve ends locally infeasible. Should the LP with self-weight
//! have no solution, the LP without it is used.
//!
//! With `linear` mass and no self-weight, stage 1 is exactly the plastic layout optimum of the
//! ground structure. Stage 2 (the caller) optimizes geometry and sizes from these forces.
//!
//! Signs: stage 2 keeps each active member's LP sign (it may go idle, not reverse): only the
//! part of that sign is a variable (`ForceParts`). The Euler mass's slope at zero compression
//! is steep (G′(0) ∝ 1/√δ), so the unused compression part of a tension member would couple to
//! the member's length with a large mixed second derivative and make the Lagrangian Hessian
//! strongly indefinite.
//!
//! Pruning: beams whose |λ| is at most `IDLE_FRACTION` of the largest in every case are dropped,
//! and free joints left without beams with them. Idle beams are the degenerate part of the
//! geometry problem: their mass and balance terms vanish, so their joints' positions do not
//! enter any active constraint and the reduced Hessian is singular along them.
//!
//! Interior point, not simplex: the LP has thousands of columns on the larger ground structures
//! and is highly degenerate (most balance rows have a zero right-hand side), which made the
//! dense simplex take minutes. The interior-point solution lies on the optimal face but need
//! not be a vertex; where the optimum is not unique it spreads the force over the tied members.
//! No crossover is needed: the start uses only each member's sign and whether it is idle, and
//! members off the optimal face end with forces of the order of the solver tolerance (1e-10
//! relative), far below `IDLE_FRACTION`. With member adding on planar layouts the pricing LPs
//! are solved by the simplex and the last one's forces come from its vertex's optimal face
//! ([`super::member_adding`]): the vertex itself where it is the only optimum, otherwise the
//! interior point on the face's columns.
//!
//! Tension runs: a free joint without load on a straight tie (two collinear tension members,
//! plus at most hangers carrying `RUN_SIDE_FRACTION` of the tie force, which the self-weight LP
//! adds to hold up the joint's own lumped weight) adds nothing to the design: tension mass
//! k_T·t·L is linear in length, so the run weighs the same as one member between its far ends,
//! and the joint can slide along the tie at no cost, a flat direction of the geometry problem
//! (and chains of such joints on a line collapse pairwise to l_min during the solve). Such joints
//! are removed: one member joining the run's far ends is added to the ground structure and the
//! LP solved again, which then needs no hangers (roof trusses on a 1 m lattice: 9–11 joints on
//! the tie, each a flat direction, gone). Compression runs are replaced the same way when
//! compression mass is linear in length (`linear` mass or the length objective; fink_roof_linear
//! then converges in 19 iterations instead of 112) and kept otherwise: the Euler mass
//! k_C·√c·L² of two halves is half that of the whole member, so an intermediate joint is a real
//! design choice there.
//!
//! Symmetry: the LP is solved on the whole ground structure; with mirror planes the forces are
//! averaged with their mirror images plane by plane (the average of two balanced force sets is
//! balanced when the loads are symmetric), so that pruning keeps mirror pairs together; the
//! mirror images of kept joints are kept in any case.
//! Obstacles: beams that cut a sphere obstacle, and joints inside one, are left out of the LP when
//! the rest can carry the loads.

use super::ground::FullConnectivity;
use super::lp::LpError;
use super::mass::Compression;
use super::member_adding::{self, BasisKey, Growth, MemberPrice};
use super::model::{Beam, Mirror, Objective, Obstacle, Settings, Structure};
use super::nlp::ForceParts;
use super::plastic::{self, LayoutLp, LpMethod};
use crate::solver::Interrupt;

/// Beams carrying at most this fraction of the largest |λ| in every case are idle.
pub const IDLE_FRACTION: f64 = 1e-6;

/// A joint on a straight tie is merged away when its other members together carry at most
/// this fraction of the tie's force: hangers that only hold up the joint's own lumped weight
/// (module header, "Tension runs").
pub const RUN_SIDE_FRACTION: f64 = 1e-3;

/// Layout LP re-solves after tension runs were replaced.
const RUN_PASSES: usize = 3;

/// The result of stage 1.
#[derive(Debug, Clone, PartialEq)]
pub struct LayoutStart {
    /// The pruned structure (joints renumbered in their original order).
    pub structure: Structure,
    /// LP forces on the pruned structure, N, case-major.
    pub forces: Vec<f64>,
    /// The sign of each LP force (both parts where a case leaves the beam idle), case-major.
    pub parts: Vec<ForceParts>,
    /// What the last layout LP solved and certified.
    pub lp: LpReport,
    /// Beams dropped as idle or cutting an obstacle.
    pub dropped_beams: usize,
    /// Free joints dropped.
    pub dropped_joints: usize,
}

/// The layout LP's optimum and certificate (the model's units: kg, or m·N for the length
/// objective; with Euler compression the LP prices by the secant, so its cost is an estimate).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LpReport {
    /// LP objective per case.
    pub cost: Vec<f64>,
    /// Lower bound per case on the LP optimum over every priced member, from the duals
    /// ([`member_adding::Layouts::lower_bound`]).
    pub lower_bound: Vec<f64>,
    /// Whether every admissible pair of joints was priced (`[connect] full`), or only the
    /// ground structure's beams.
    pub all_pairs: bool,
    /// Largest relative violation of the dual constraints over the priced members (the
    /// bound divides the dual objective by 1 + this).
    pub max_violation: f64,
    /// Members in the last LP.
    pub members: usize,
    /// Members added by pricing (every pass).
    pub members_added: usize,
    /// LP solves per case (every pass; member adding's pricing LPs by the simplex and the
    /// interior-point solves alike).
    pub solves: usize,
}

/// Per-newton LP cost of a beam of `length` m, (tension, compression) (module header).
pub fn cost_per_newton(length: f64, settings: &Settings, force_scale: f64) -> (f64, f64) {
    if settings.objective == Objective::Length {
        return (length, length);
    }
    let weight = match settings.objective {
        Objective::MassTensionPreference(w) => w,
        _ => 1.0,
    };
    let (t, c) = mass_per_newton(length, settings, force_scale);
    (t, weight * c)
}

/// A beam's mass per newton of (tension, compression) at `length` m, kg/N: the tension law,
/// and the linear law or the Euler secant through the largest load `force_scale` (module
/// header). The LP's self-weight uses these.
pub fn mass_per_newton(length: f64, settings: &Settings, force_scale: f64) -> (f64, f64) {
    let mass = &settings.mass;
    let compression = match mass.compression {
        Compression::Linear { k_c } => k_c * length,
        Compression::Euler { k_c } => k_c * length * length / force_scale.sqrt(),
    };
    (mass.k_t * length, compression)
}

/// Stage 1 on `structure` (module header); with `full`, the LP is over every admissible pair of
/// joints by member adding, starting from the structure's beams. Fails only if no subset
/// tried can carry the loads, or with [`LpError::Interrupted`] at once when `interrupt` is
/// raised.
pub fn layout_start(
    structure: &Structure,
    settings: &Settings,
    full: Option<&FullConnectivity>,
    interrupt: &Interrupt,
) -> Result<LayoutStart, LpError> {
    let clear: Vec<bool> = (structure.beams.iter())
        .map(|b| clears_spheres(structure, b, &settings.obstacles))
        .collect();
    let lp = |usable: &[bool], self_weight| {
        let grow = full.map(|f| (f, usable == clear.as_slice()));
        solve_on(structure, settings, usable, self_weight, grow, interrupt)
    };
    let retry = |e: LpError| e != LpError::Interrupted;
    let attempt = |self_weight: bool| match lp(&clear, self_weight) {
        Err(e) if retry(e) && clear.iter().any(|&c| !c) => {
            lp(&vec![true; structure.beams.len()], self_weight)
        }
        result => result,
    };
    match attempt(settings.self_weight) {
        Err(e) if retry(e) && settings.self_weight => attempt(false),
        result => result,
    }
}

/// Whether a beam and its end joints stay outside every sphere obstacle.
fn clears_spheres(structure: &Structure, beam: &Beam, obstacles: &[Obstacle]) -> bool {
    let [a, b] = beam.ends;
    let (pa, pb) = (structure.joints[a].position, structure.joints[b].position);
    obstacles.iter().all(|o| match o {
        Obstacle::Sphere { center, radius } => {
            let (d, _) = super::geometry::segment_point_distance(&pa, &pb, center);
            d >= *radius * (1.0 - 1e-9)
        }
        Obstacle::HalfSpace { .. } => true,
    })
}

/// Solves the LP on the beams marked `usable` (with the beams' estimated weight lumped on their
/// ends if `self_weight`; growing the member set over every admissible pair with `grow`, whose
/// flag says whether added members must clear the sphere obstacles), symmetrizes, replaces
/// tension runs by single members and solves again on the ground structure with those members
/// added (at most `RUN_PASSES` times: the new members need no hangers, which the LP then
/// drops), prunes.
fn solve_on(
    structure: &Structure,
    settings: &Settings,
    usable: &[bool],
    self_weight: bool,
    grow: Option<(&FullConnectivity, bool)>,
    interrupt: &Interrupt,
) -> Result<LayoutStart, LpError> {
    let mut usable = usable.to_vec();
    let (mut ground, mut forces, mut lp, mut columns, mut bases) = lp_forces(
        structure,
        settings,
        &usable,
        self_weight,
        grow,
        &[],
        interrupt,
    )?;
    for _ in 0..RUN_PASSES {
        usable.resize(ground.beams.len(), true);
        let Some((merged, _)) = merge_runs(
            &ground,
            forces.clone(),
            settings.max_length,
            settings.compression_linear_in_length(),
        ) else {
            break;
        };
        usable.resize(merged.beams.len(), true);
        // No member added where none was before: the LP on `merged` is the one just solved,
        // column for column, and would return the same forces.
        let unchanged = (merged.beams.iter().zip(&usable))
            .filter_map(|(b, &u)| u.then_some(*b))
            .eq(columns.iter().copied());
        if unchanged {
            break;
        }
        let (added, solves) = (lp.members_added, lp.solves);
        (ground, forces, lp, columns, bases) = lp_forces(
            &merged,
            settings,
            &usable,
            self_weight,
            grow,
            &bases,
            interrupt,
        )?;
        lp.members_added += added;
        lp.solves += solves;
    }
    Ok(prune(&ground, forces, lp, &settings.symmetry))
}

/// What [`lp_forces`] returns: the ground structure, forces, report, the last LP's members and
/// its simplex bases.
type SolvedLp = (
    Structure,
    Vec<Vec<f64>>,
    LpReport,
    Vec<Beam>,
    Vec<Vec<BasisKey>>,
);

/// The LP of [`solve_on`]: the ground structure with the members pricing added (appended), its
/// forces (N, `[case][beam]`, symmetrized), the LP's report, the last LP's members in its
/// column order and member adding's last simplex bases (to start the next pass's simplex from,
/// `warm`: the joints and rows stay, the members only grow).
fn lp_forces(
    structure: &Structure,
    settings: &Settings,
    usable: &[bool],
    self_weight: bool,
    grow: Option<(&FullConnectivity, bool)>,
    warm: &[Vec<BasisKey>],
    interrupt: &Interrupt,
) -> Result<SolvedLp, LpError> {
    let scaled = Scaled::new(structure, settings, usable);
    let (sub, force_scale, cost_scale) = (&scaled.structure, scaled.force_scale, scaled.cost_scale);
    let price = |length: f64| scaled.price(length, settings, self_weight);
    let scaled_ref = &scaled;
    let growth = grow.map(|(full, must_clear)| {
        let admits = move |beam: Beam| scaled_ref.admits(full, must_clear, settings, beam);
        let close = move |beams: Vec<Beam>| full.close(&sub.joints, beams, settings);
        (admits, close)
    });
    let growth = growth
        .as_ref()
        .map(|(admits, close)| Growth { admits, close });
    let axes = settings.balance_axes();
    // Thousands of members: the crossover's dense simplex would dominate (`lp::solve_sparse`).
    let method = match growth {
        Some(_) => LpMethod::InteriorFace,
        None => LpMethod::InteriorPoint,
    };
    let layouts =
        member_adding::solve(sub, axes, &price, growth.as_ref(), method, warm, interrupt)?;
    let mut ground = structure.clone();
    let mut index: std::collections::HashMap<Beam, usize> = (ground.beams.iter().enumerate())
        .map(|(j, b)| (*b, j))
        .collect();
    let columns: Vec<usize> = (layouts.beams.iter())
        .map(|b| {
            *index.entry(*b).or_insert_with(|| {
                ground.beams.push(*b);
                ground.beams.len() - 1
            })
        })
        .collect();
    let mut forces = vec![vec![0.0; ground.beams.len()]; layouts.cases.len()];
    for (case_forces, sol) in forces.iter_mut().zip(&layouts.cases) {
        for (k, &j) in columns.iter().enumerate() {
            case_forces[j] = sol.forces[k] * force_scale;
        }
    }
    for mirror in &settings.symmetry {
        if let Some(image) = mirror_beams(&ground, mirror) {
            for case_forces in forces.iter_mut() {
                let old = case_forces.clone();
                for (j, f) in case_forces.iter_mut().enumerate() {
                    *f = 0.5 * (old[j] + old[image[j]]);
                }
            }
        }
    }
    let unscale = cost_scale * force_scale;
    let report = LpReport {
        cost: layouts.cases.iter().map(|c| c.volume * unscale).collect(),
        lower_bound: layouts.lower_bound().iter().map(|b| b * unscale).collect(),
        all_pairs: layouts.all_pairs,
        max_violation: layouts.violation,
        members: layouts.beams.len(),
        members_added: layouts.added,
        solves: layouts.iterations,
    };
    Ok((ground, forces, report, layouts.beams, layouts.bases))
}

/// The ground structure of the start's LPs in O(1) numbers: the usable beams, the loads divided
/// by the largest load `force_scale` (N), and the per-newton costs by the largest usable beam's
/// `cost_scale`; an LP objective times `force_scale·cost_scale` is in the cost's unit (kg, or m
/// for the length objective).
struct Scaled {
    structure: Structure,
    force_scale: f64,
    cost_scale: f64,
}

impl Scaled {
    fn new(structure: &Structure, settings: &Settings, usable: &[bool]) -> Self {
        let force_scale = (structure.joints.iter())
            .flat_map(|j| j.loads.iter())
            .map(|f| f.norm())
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        let sub = Structure {
            joints: (structure.joints.iter())
                .map(|j| {
                    let mut j = j.clone();
                    for f in j.loads.iter_mut() {
                        *f /= force_scale;
                    }
                    j
                })
                .collect(),
            beams: (structure.beams.iter().zip(usable))
                .filter_map(|(b, &u)| u.then_some(*b))
                .collect(),
        };
        let cost_scale = (0..sub.beams.len())
            .map(|j| {
                let c = cost_per_newton(sub.length(j), settings, force_scale);
                c.0.max(c.1)
            })
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        Scaled {
            structure: sub,
            force_scale,
            cost_scale,
        }
    }

    /// The scaled LP price of a member of `length` m, with its self-weight if `self_weight`.
    fn price(&self, length: f64, settings: &Settings, self_weight: bool) -> MemberPrice {
        let (t, c) = cost_per_newton(length, settings, self.force_scale);
        MemberPrice {
            cost: (t / self.cost_scale, c / self.cost_scale),
            weight: self_weight.then(|| mass_per_newton(length, settings, self.force_scale)),
        }
    }

    /// Whether member adding may add `beam`: `full`'s rules for its ends and, if `must_clear`,
    /// clear of the sphere obstacles.
    fn admits(
        &self,
        full: &FullConnectivity,
        must_clear: bool,
        settings: &Settings,
        beam: Beam,
    ) -> bool {
        full.admits_ends(&self.structure.joints, beam, &settings.obstacles)
            && (!must_clear || clears_spheres(&self.structure, &beam, &settings.obstacles))
    }
}

/// The layout LP of load case `case` over the whole ground structure that the start's member
/// adding prices (the beams clear of the sphere obstacles and every admissible pair of joints,
/// see [`member_adding::admissible_pairs`]), with the start's scaling and self-weight setting,
/// and the factor that turns its objective into kg (m for the length objective): the same LP
/// for other LP solvers. The start's first LP on a structure; its later LPs, after tension runs
/// are merged, have other members.
pub fn full_layout_lp(
    structure: &Structure,
    settings: &Settings,
    full: &FullConnectivity,
    case: usize,
) -> (LayoutLp, f64) {
    let clear: Vec<bool> = (structure.beams.iter())
        .map(|b| clears_spheres(structure, b, &settings.obstacles))
        .collect();
    let mut scaled = Scaled::new(structure, settings, &clear);
    let admits = |beam: Beam| scaled.admits(full, true, settings, beam);
    let close = |beams: Vec<Beam>| beams;
    let growth = Growth {
        admits: &admits,
        close: &close,
    };
    let added = member_adding::admissible_pairs(&scaled.structure, &growth);
    scaled.structure.beams.extend(added);
    let prices: Vec<MemberPrice> = (0..scaled.structure.beams.len())
        .map(|j| scaled.price(scaled.structure.length(j), settings, settings.self_weight))
        .collect();
    let costs: Vec<(f64, f64)> = prices.iter().map(|p| p.cost).collect();
    let weights: Option<Vec<(f64, f64)>> = prices.iter().map(|p| p.weight).collect();
    let axes = settings.balance_axes();
    let lp = plastic::layout_lp(&scaled.structure, case, axes, &costs, weights.as_deref());
    (lp, scaled.force_scale * scaled.cost_scale)
}

/// Replaces every tension run through a free joint by one member (module header, "Tension
/// runs"), and every compression run too when `compression` (compression mass linear in
/// length, see [`Settings::compression_linear_in_length`]): a free joint without external load
/// whose two strongest members are collinear and of one sign in every case, the others
/// together carrying at most [`RUN_SIDE_FRACTION`] of them, loses all its members; a member joining the far ends of the two carries their mean
/// force (added to the ground-structure member there, if any). Repeated until no joint
/// qualifies, so a chain of such joints becomes one member. Not where the merged member would
/// exceed `max_length` (m). Forces in N, `[case][beam]`; returns the structure with the added
/// members and the forces (the replaced members keep zero force), or None when no joint
/// qualifies.
fn merge_runs(
    structure: &Structure,
    mut forces: Vec<Vec<f64>>,
    max_length: Option<f64>,
    compression: bool,
) -> Option<(Structure, Vec<Vec<f64>>)> {
    let largest = (forces.iter().flatten())
        .map(|f| f.abs())
        .fold(0.0, f64::max);
    let idle = IDLE_FRACTION * largest;
    let mut beams = structure.beams.clone();
    let mut index: std::collections::HashMap<Beam, usize> =
        beams.iter().enumerate().map(|(j, b)| (*b, j)).collect();
    let joints = &structure.joints;
    let unloaded = |i: usize| joints[i].loads.iter().all(|f| f.norm() == 0.0);
    let mut changed = false;
    loop {
        let mut incident = vec![Vec::new(); joints.len()];
        for (j, b) in beams.iter().enumerate() {
            if forces.iter().any(|f| f[j].abs() > idle) {
                for e in b.ends {
                    incident[e].push(j);
                }
            }
        }
        let peak = |j: usize| forces.iter().map(|f| f[j].abs()).fold(0.0, f64::max);
        let run = (0..joints.len()).find_map(|i| {
            if !joints[i].is_free() || !unloaded(i) || incident[i].len() < 2 {
                return None;
            }
            let mut members = incident[i].clone();
            members.sort_by(|&p, &q| peak(q).total_cmp(&peak(p)));
            let (j1, j2, side) = (members[0], members[1], &members[2..]);
            let tension = |j: usize| forces.iter().all(|f| f[j] < -idle);
            let pushed = |j: usize| compression && forces.iter().all(|f| f[j] > idle);
            let one_sign = (tension(j1) && tension(j2)) || (pushed(j1) && pushed(j2));
            let side_force: f64 = side.iter().map(|&j| peak(j)).sum();
            if !one_sign || side_force > RUN_SIDE_FRACTION * peak(j2) {
                return None;
            }
            let far = |j: usize| beams[j].ends[0] + beams[j].ends[1] - i;
            let (a, b) = (far(j1), far(j2));
            let p = joints[i].position;
            let (u, v) = (joints[a].position - p, joints[b].position - p);
            let straight = u.cross(&v).norm() <= 1e-9 * u.norm() * v.norm() && u.dot(&v) < 0.0;
            let fits = max_length.is_none_or(|l| (u - v).norm() <= l);
            (a != b && straight && fits).then(|| (members, Beam::new(a, b)))
        });
        let Some((members, merged)) = run else {
            break;
        };
        changed = true;
        let target = *index.entry(merged).or_insert_with(|| {
            beams.push(merged);
            for f in forces.iter_mut() {
                f.push(0.0);
            }
            beams.len() - 1
        });
        for f in forces.iter_mut() {
            f[target] += 0.5 * (f[members[0]] + f[members[1]]);
            for &j in &members {
                f[j] = 0.0;
            }
        }
    }
    let merged = Structure {
        joints: joints.clone(),
        beams,
    };
    changed.then_some((merged, forces))
}

/// Marks the mirror images (under every plane, repeatedly) of the kept joints as kept. Generated
/// beams are closed under the mirrors ([`super::ground::mirror_closure`]), but user-listed extra
/// or forbidden pairs can still make the beams asymmetric (the forces are then not averaged), and
/// a kept free joint could lose the image its symmetry rows pair it with. An image kept without beams is
/// placed by those rows.
fn keep_mirror_images(structure: &Structure, mirrors: &[Mirror], keep: &mut [bool]) {
    let joints = &structure.joints;
    let scale = (joints.iter())
        .map(|j| j.position.norm())
        .fold(1.0, f64::max);
    let mut changed = true;
    while changed {
        changed = false;
        for mirror in mirrors {
            for i in 0..joints.len() {
                if !keep[i] {
                    continue;
                }
                let p = mirror.reflect(&joints[i].position);
                if let Some(k) =
                    (0..joints.len()).find(|&k| (joints[k].position - p).norm() <= 1e-6 * scale)
                    && !keep[k]
                {
                    keep[k] = true;
                    changed = true;
                }
            }
        }
    }
}

/// The mirror image of every beam, if the ground structure is mirror symmetric.
fn mirror_beams(structure: &Structure, mirror: &Mirror) -> Option<Vec<usize>> {
    let joints = &structure.joints;
    let scale = (joints.iter())
        .map(|j| j.position.norm())
        .fold(1.0, f64::max);
    let image_joint = |i: usize| {
        let p = mirror.reflect(&joints[i].position);
        (0..joints.len()).find(|&k| (joints[k].position - p).norm() <= 1e-9 * scale)
    };
    let images: Vec<usize> = (0..joints.len()).map(image_joint).collect::<Option<_>>()?;
    let index: std::collections::HashMap<Beam, usize> = (structure.beams.iter())
        .enumerate()
        .map(|(j, b)| (*b, j))
        .collect();
    (structure.beams.iter())
        .map(|b| {
            index
                .get(&Beam::new(images[b.ends[0]], images[b.ends[1]]))
                .copied()
        })
        .collect()
}

/// Drops idle beams and the free joints they leave without beams (module header), keeping the
/// mirror images of kept joints (the symmetry rows pair them).
fn prune(
    structure: &Structure,
    forces: Vec<Vec<f64>>,
    lp: LpReport,
    mirrors: &[Mirror],
) -> LayoutStart {
    let largest = (forces.iter().flatten())
        .map(|f| f.abs())
        .fold(0.0, f64::max);
    let active: Vec<usize> = (0..structure.beams.len())
        .filter(|&j| forces.iter().any(|f| f[j].abs() > IDLE_FRACTION * largest))
        .collect();
    let mut used = vec![false; structure.joints.len()];
    for &j in &active {
        for e in structure.beams[j].ends {
            used[e] = true;
        }
    }
    let mut keep: Vec<bool> = (structure.joints.iter().zip(&used))
        .map(|(joint, &u)| u || !joint.is_free())
        .collect();
    keep_mirror_images(structure, mirrors, &mut keep);
    let mut renumber = vec![usize::MAX; structure.joints.len()];
    let mut joints = Vec::new();
    for (i, joint) in structure.joints.iter().enumerate() {
        if keep[i] {
            renumber[i] = joints.len();
            joints.push(joint.clone());
        }
    }
    let beams: Vec<Beam> = (active.iter())
        .map(|&j| {
            let [a, b] = structure.beams[j].ends;
            Beam::new(renumber[a], renumber[b])
        })
        .collect();
    let start: Vec<f64> = (forces.iter())
        .flat_map(|f| active.iter().map(|&j| f[j]))
        .collect();
    let parts = signed_parts(&start);
    LayoutStart {
        dropped_beams: structure.beams.len() - beams.len(),
        dropped_joints: structure.joints.len() - joints.len(),
        structure: Structure { joints, beams },
        forces: start,
        parts,
        lp,
    }
}

/// The force parts of a round's variables for `forces` (case-major): the sign's part alone for a
/// force above [`IDLE_FRACTION`] of the largest, both parts for a near-zero one, which may take
/// either sign. The layout start gives round 1 these parts; with `linear` mass the later rounds
/// too (`rounds`). With both parts a loaded member's other part is a degenerate direction of
/// the QP (t and c rising together cost mass only through the objective's slope), and
/// pier_cantilever_linear's later rounds crawled along a self-stress of three such parts
/// (docs/notes/truss.md).
pub(super) fn signed_parts(forces: &[f64]) -> Vec<ForceParts> {
    let largest = forces.iter().map(|f| f.abs()).fold(0.0, f64::max);
    (forces.iter())
        .map(|&f| {
            if f.abs() > IDLE_FRACTION * largest {
                ForceParts::of(f)
            } else {
                ForceParts::Both
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::truss::model::{JointKind, Support};
    use crate::truss::testing::planar_joint as joint;

    /// Anchors 0 and 1 at x = 0 and 4; free joints 2, 3, 4 on the tie at x = 1, 2, 3 and a load
    /// joint 5 above x = 2. Beams: the tie 0–2–3–4–1, a hanger 5–3, and a compression run
    /// 0–6–5 through free joint 6.
    fn tie() -> Structure {
        let free = || JointKind::Free;
        let pinned = || JointKind::Anchor(Support::Pinned);
        Structure {
            joints: vec![
                joint(0.0, 0.0, pinned()),
                joint(4.0, 0.0, pinned()),
                joint(1.0, 0.0, free()),
                joint(2.0, 0.0, free()),
                joint(3.0, 0.0, free()),
                joint(2.0, 2.0, JointKind::Load),
                joint(1.0, 1.0, free()),
            ],
            beams: vec![
                Beam::new(0, 2),
                Beam::new(2, 3),
                Beam::new(3, 4),
                Beam::new(4, 1),
                Beam::new(5, 3),
                Beam::new(0, 6),
                Beam::new(6, 5),
            ],
        }
    }

    #[test]
    fn a_tie_through_free_joints_becomes_one_member_and_compression_runs_stay() {
        let s = tie();
        // Tie forces (tension) differing by the joints' weight; a hanger of 1e-4 of the tie.
        let forces = vec![vec![-1000.0, -1000.2, -1000.2, -1000.0, -0.1, 700.0, 700.0]];
        let (merged, f) = merge_runs(&s, forces, None, false).expect("a run to merge");
        // Joint by joint (0–3, then 0–4, then 0–1): the last member, 0–1, carries the tie;
        // every other member of the run and the hanger is emptied.
        let last = merged.beams.len() - 1;
        assert_eq!(merged.beams[last], Beam::new(0, 1));
        assert!((f[0][last] + 1000.0).abs() < 0.2, "{}", f[0][last]);
        for j in (0..last).filter(|&j| j != 5 && j != 6) {
            assert_eq!(f[0][j], 0.0, "beam {j}");
        }
        // The compression run through joint 6 is kept as it was.
        assert_eq!((f[0][5], f[0][6]), (700.0, 700.0));
        // A hanger carrying more than RUN_SIDE_FRACTION of the tie keeps joint 3; the joints
        // on either side still go, joined to 3.
        let forces = vec![vec![-1000.0, -1000.0, -1000.0, -1000.0, -5.0, 700.0, 700.0]];
        let (merged, f) = merge_runs(&s, forces, None, false).unwrap();
        let carried = |a: usize, b: usize| {
            let j = merged
                .beams
                .iter()
                .position(|&x| x == Beam::new(a, b))
                .unwrap();
            f[0][j]
        };
        assert_eq!(
            (carried(0, 3), carried(1, 3), carried(3, 5)),
            (-1000.0, -1000.0, -5.0)
        );
        // A merged member longer than l_max is not formed: 0–3 is 2 m.
        let forces = vec![vec![-1000.0, -1000.0, -1000.0, -1000.0, -5.0, 700.0, 700.0]];
        assert!(merge_runs(&s, forces, Some(1.5), false).is_none());
        // Nothing to merge in compression.
        let forces = vec![vec![1000.0, 1000.0, 1000.0, 1000.0, 0.0, 700.0, 700.0]];
        assert!(merge_runs(&s, forces.clone(), None, false).is_none());
        // Unless compression mass is linear in length: then the strut 0–6–5 becomes 0–5, and
        // the tie (in compression here) one member too.
        let (merged, f) = merge_runs(&s, forces, None, true).expect("struts to merge");
        let strut = merged.beams.iter().position(|&b| b == Beam::new(0, 5));
        assert_eq!(strut.map(|j| f[0][j]), Some(700.0));
        assert_eq!((f[0][5], f[0][6]), (0.0, 0.0));
    }
}
