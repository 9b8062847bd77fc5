//! Multilevel topology rounds (seed §4.3.2): after a solve, clean the structure and rebuild the
//! problem from it.
//!
//! Steps, in order (lengths in m, forces in N):
//! 1. merge: joints joined by a beam of length ≤ l_min·(1 + merge_tolerance) become one joint
//!    (union–find). A group keeps its fixed joint (anchor or load) and that joint's position; a
//!    group of free joints sits at their mean. Two fixed joints are never merged. Beams inside a
//!    group vanish; parallel beams between the same two joints combine into one whose force is the
//!    sum of theirs (the same resultant on both joints, so balance is kept);
//! 2. prune (optional): beams whose largest |λ| over the cases is below `prune` times the largest
//!    in the structure are dropped (the seed keeps them to leave topology options open);
//! 3. crossings (optional): two beams cross when their segments come closer than 1e-9 of the
//!    structure size inside both and they share no joint. With `split_crossings` a new free
//!    joint at the crossing joins them: each beam becomes two carrying its force, so the joint
//!    balances and the mass is unchanged for tension and `linear` mass (for Euler compression
//!    each half buckles at half the length: the design gets lighter, a brace it had for free).
//!    The next round then moves the joint like any other. A crossing whose pieces would be
//!    shorter than l_min·(1 + merge_tolerance) is left (the merge of step 1 would undo it).
//!    With `remove_crossings` the one with the smaller peak |λ| is dropped instead;
//! 4. overlaps (when merging, `compression_runs` only): a beam a–b along which a joint c lies,
//!    joined to both ends by beams a–c and c–b that are collinear within [`RUN_ANGLE`] (the
//!    triangle a–c–b has collapsed), is removed and its force added to those two. With mass
//!    linear in force and length the force may then be split between the direct beam and the
//!    path through c at no cost (the lengths add up; only the lumped self-weights differ): a
//!    flat direction of the forces alone, along which the solve moves in growing Newton steps
//!    and the optimality measure oscillates (pier_cantilever_linear's last 130 iterations
//!    traded force between its three struts 1–19, 1–20 and 20–19 at a mass constant to 1e-8).
//!    The path carries the sum: |f_ac + F| + |f_cb + F| ≤ |f_ac| + |f_cb| + 2|F|, so the mass
//!    grows at most by |F| times the path's excess length (below 1e-3 of L_ab at the angle);
//!    the balance at a and b is off by |F| times the angle between a–b and a–c, which the next
//!    solve removes;
//! 5. dangling: free joints left with at most one beam are removed with that beam (such a beam
//!    carries no force in balance), repeatedly; and straight runs: a free joint without load
//!    left with exactly two beams, collinear within [`RUN_ANGLE`] and of one sign in every case
//!    (tension; or compression when its mass is linear in length, `compression_runs`), is
//!    removed and the two become one beam between their far ends carrying their mean force
//!    (added to a beam already there), unless that beam would exceed l_max. Such a joint is a
//!    flat direction of the next solve: tension mass k_T·t·L (and `linear` compression mass
//!    k_C·c·L) is linear in length, so it can slide along the run at no cost (the layout start
//!    removes the tension runs of its LP, see [`super::start`]; these are the runs a solve
//!    leaves when a joint's other members go idle). The singular reduced Hessian along the
//!    slide makes the exact Hessian's convexification shift every direction
//!    (`solver::hessian::exact`: a direction of zero reduced curvature coupled across the rows
//!    needs δ ≈ 1/`FALLBACK_GAMMA` of the Hessian scale), or the diagonal flip of a negative
//!    length curvature becomes the slide's only curvature: the joint then moves by a constant
//!    step at a constant dual residual and the solve never converges (pier_cantilever_linear
//!    repeated a step of 1.4e-8 at optimality 2.0e-6 on a strut through a free joint; the
//!    Warren deck's last round crawled 847 iterations on two struts through free joints).
//!    Euler compression runs stay: two halves of a strut weigh half the whole (k_C·√c·L²), so
//!    the joint has positive curvature along the run. The joint's own lumped weight kinks the
//!    run by about k·L·g (≤ 1e-3 rad in the examples); only that justifies a kink at a joint
//!    without other members, so the angle allowance is loose;
//! 6. joints are renumbered in their original order.
//!
//! The forces returned are the start of the next round (N, case-major).

use std::collections::BTreeMap;

use serde::Serialize;

use super::geometry::segment_segment_distance;
use super::model::{Beam, Joint, JointKind, Structure, Vec3};

/// Settings of a round.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoundSettings {
    /// l_min, m.
    pub min_length: f64,
    /// Relative slack on l_min for merging.
    pub merge_tolerance: f64,
    /// Prune fraction (0 keeps every beam).
    pub prune: f64,
    /// What happens to crossing beams.
    pub crossings: Crossings,
    /// l_max, m (a straight run is not merged into a longer beam).
    pub max_length: Option<f64>,
    /// Whether joints may be merged (step 1) and straight runs joined (step 4).
    pub merge: bool,
    /// Whether compression runs are joined too (step 4): true when compression mass is linear
    /// in length (`linear` mass, or the length objective), so that a free joint on a straight
    /// strut is as flat a direction as one on a tie.
    pub compression_runs: bool,
}

/// What a clean-up does with two beams that cross (module header, step 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Crossings {
    /// Leave them.
    Keep,
    /// Join them by a free joint at the crossing.
    Split,
    /// Drop the one with the smaller peak force.
    Remove,
}

/// Largest angle (rad) between the two members of a straight run that is merged (module header,
/// step 4): well above the kink the joint's own weight explains, well below a real bend.
pub const RUN_ANGLE: f64 = 0.05;

/// What a round changed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct RoundReport {
    /// Joints before.
    pub joints_before: usize,
    /// Beams before.
    pub beams_before: usize,
    /// Joints merged away.
    pub merged_joints: usize,
    /// Beams pruned for small force.
    pub pruned_beams: usize,
    /// Beams removed at crossings.
    pub crossings_removed: usize,
    /// Crossings joined by a new joint.
    pub crossings_split: usize,
    /// Dangling free joints removed.
    pub dangling_joints: usize,
    /// Free joints on straight runs (ties, and `linear` struts) merged away.
    pub straight_runs: usize,
    /// Beams along a two-beam path through a joint, merged into the path.
    pub overlaps: usize,
    /// Joints after.
    pub joints_after: usize,
    /// Beams after.
    pub beams_after: usize,
}

impl RoundReport {
    /// True when the clean-up left the structure as it was: nothing merged, pruned, crossed or
    /// dangling.
    pub fn changes_nothing(&self) -> bool {
        self.merged_joints == 0
            && self.pruned_beams == 0
            && self.crossings_removed == 0
            && self.crossings_split == 0
            && self.dangling_joints == 0
            && self.straight_runs == 0
            && self.overlaps == 0
    }
}

/// Union–find over joint indices.
struct Groups {
    parent: Vec<usize>,
    fixed: Vec<bool>,
}

impl Groups {
    fn find(&mut self, i: usize) -> usize {
        let mut r = i;
        while self.parent[r] != r {
            r = self.parent[r];
        }
        let mut k = i;
        while self.parent[k] != r {
            let next = self.parent[k];
            self.parent[k] = r;
            k = next;
        }
        r
    }

    /// Joins the groups of a and b unless both hold a fixed joint; the fixed root wins.
    fn union(&mut self, a: usize, b: usize) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb || (self.fixed[ra] && self.fixed[rb]) {
            return false;
        }
        let (root, child) = if self.fixed[rb] || (!self.fixed[ra] && rb < ra) {
            (rb, ra)
        } else {
            (ra, rb)
        };
        self.parent[child] = root;
        true
    }
}

/// Beams with their forces per load case (N).
type BeamForces = Vec<(Beam, Vec<f64>)>;

/// One clean-up round on `structure` at solved `positions` with `forces[case][beam]` (N).
/// Returns the new structure (joints at the solved positions), its start forces (case-major) and
/// a report.
pub fn clean(
    structure: &Structure,
    positions: &[Vec3],
    forces: &[Vec<f64>],
    settings: &RoundSettings,
) -> (Structure, Vec<f64>, RoundReport) {
    let mut report = RoundReport {
        joints_before: structure.joints.len(),
        beams_before: structure.beams.len(),
        ..Default::default()
    };
    let mut joints = structure.joints.clone();
    for (j, p) in joints.iter_mut().zip(positions) {
        j.position = *p;
    }
    let (roots, mut beams) =
        merge_short_beams(structure, &mut joints, forces, settings, &mut report);
    if settings.prune > 0.0 {
        let before = beams.len();
        prune(&mut beams, settings.prune);
        report.pruned_beams = before - beams.len();
    }
    match settings.crossings {
        Crossings::Keep => {}
        Crossings::Remove => {
            let before = beams.len();
            beams = remove_crossings(&joints, beams);
            report.crossings_removed = before - beams.len();
        }
        Crossings::Split => {
            report.crossings_split =
                split_crossings(&mut joints, &mut beams, settings, forces.len());
        }
    }
    // Joints added at crossings (after the merged ones) are alive.
    let mut alive: Vec<bool> = (0..joints.len())
        .map(|i| roots.get(i).is_none_or(|&r| r == i))
        .collect();
    if settings.merge && settings.compression_runs {
        while merge_overlap(&joints, &mut beams) {
            report.overlaps += 1;
        }
    }
    remove_dangling(&joints, &mut alive, &mut beams, settings, &mut report);
    let (out, start) = renumber(&joints, &alive, beams, forces.len());
    report.joints_after = out.joints.len();
    report.beams_after = out.beams.len();
    (out, start, report)
}

/// The largest force magnitude of a beam over the load cases (N).
fn peak(f: &[f64]) -> f64 {
    f.iter().map(|v| v.abs()).fold(0.0, f64::max)
}

/// Step 1: merges the ends of beams at most `min_length·(1 + merge_tolerance)` long (m) into
/// one joint (at their mean position unless fixed), summing the forces of beams that become
/// one. Returns each joint's group root (a joint survives only as its own root) and the beams
/// between roots.
fn merge_short_beams(
    structure: &Structure,
    joints: &mut [Joint],
    forces: &[Vec<f64>],
    settings: &RoundSettings,
    report: &mut RoundReport,
) -> (Vec<usize>, BeamForces) {
    let (n, cases) = (joints.len(), forces.len());
    let length = |b: &Beam| (joints[b.ends[1]].position - joints[b.ends[0]].position).norm();
    let mut groups = Groups {
        parent: (0..n).collect(),
        fixed: joints.iter().map(|j| !j.is_free()).collect(),
    };
    let limit = settings.min_length * (1.0 + settings.merge_tolerance);
    for b in &structure.beams {
        if settings.merge && length(b) <= limit && groups.union(b.ends[0], b.ends[1]) {
            report.merged_joints += 1;
        }
    }
    let roots: Vec<usize> = (0..n).map(|i| groups.find(i)).collect();
    let mut sums: BTreeMap<usize, (Vec3, usize)> = BTreeMap::new();
    for i in 0..n {
        let e = sums.entry(roots[i]).or_insert((Vec3::zeros(), 0));
        e.0 += joints[i].position;
        e.1 += 1;
    }
    for (&root, &(sum, count)) in &sums {
        if joints[root].is_free() {
            joints[root].position = sum / count as f64;
        }
    }
    let mut merged: BTreeMap<Beam, Vec<f64>> = BTreeMap::new();
    for (j, b) in structure.beams.iter().enumerate() {
        let (a, c) = (roots[b.ends[0]], roots[b.ends[1]]);
        if a == c {
            continue;
        }
        let beam = Beam::new(a, c);
        // Orientation flips the sign of λe but not of λ: compression stays compression.
        let entry = merged.entry(beam).or_insert_with(|| vec![0.0; cases]);
        for (k, f) in forces.iter().enumerate() {
            entry[k] += f[j];
        }
    }
    (roots, merged.into_iter().collect())
}

/// Step 2: drops the beams whose peak force is below `prune` times the largest.
fn prune(beams: &mut BeamForces, prune: f64) {
    let top = beams.iter().map(|(_, f)| peak(f)).fold(0.0, f64::max);
    beams.retain(|(_, f)| peak(f) >= prune * top);
}

/// Distance below which two segments meet: 1e-9 of the joints' bounding-box diagonal (m).
fn crossing_tolerance(joints: &[Joint]) -> f64 {
    let mut lo = Vec3::repeat(f64::INFINITY);
    let mut hi = Vec3::repeat(f64::NEG_INFINITY);
    for j in joints {
        lo = lo.inf(&j.position);
        hi = hi.sup(&j.position);
    }
    1e-9 * (hi - lo).norm()
}

/// Where the beams with ends `[a, b]` and `[c, d]` cross (module header, step 3): the
/// midpoint of their closest points and the fractions along each, or `None` (also when they
/// share a joint).
fn crossing(
    joints: &[Joint],
    [a, b]: [usize; 2],
    [c, d]: [usize; 2],
    tol: f64,
) -> Option<(Vec3, f64, f64)> {
    if a == c || a == d || b == c || b == d {
        return None;
    }
    let (p, q, r, s) = (
        &joints[a].position,
        &joints[b].position,
        &joints[c].position,
        &joints[d].position,
    );
    let (dist, u, v) = segment_segment_distance(p, q, r, s);
    let inside = u > 0.0 && u < 1.0 && v > 0.0 && v < 1.0;
    (dist <= tol && inside).then(|| ((p + (q - p) * u + r + (s - r) * v) * 0.5, u, v))
}

/// Step 3 with `split_crossings`: joins crossing beams by a new free joint at each crossing (appended to
/// `joints`, no loads in any of `cases`), each beam replaced by two carrying its forces; the
/// first crossing in beam order is split until none is left (a beam crossing k others is
/// split k times). Returns the number of joints added.
fn split_crossings(
    joints: &mut Vec<Joint>,
    beams: &mut BeamForces,
    settings: &RoundSettings,
    cases: usize,
) -> usize {
    let tol = crossing_tolerance(joints);
    let shortest = settings.min_length * (1.0 + settings.merge_tolerance);
    let long_enough = |u: f64, joints: &[Joint], [a, b]: [usize; 2]| {
        let length = (joints[b].position - joints[a].position).norm();
        u * length > shortest && (1.0 - u) * length > shortest
    };
    let mut added = 0;
    loop {
        let found = (0..beams.len()).find_map(|i| {
            (i + 1..beams.len()).find_map(|k| {
                let (e, f) = (beams[i].0.ends, beams[k].0.ends);
                let (point, u, v) = crossing(joints, e, f, tol)?;
                (long_enough(u, joints, e) && long_enough(v, joints, f)).then_some((i, k, point))
            })
        });
        let Some((i, k, point)) = found else {
            return added;
        };
        let n = joints.len();
        joints.push(Joint {
            position: point,
            kind: JointKind::Free,
            name: None,
            loads: vec![Vec3::zeros(); cases],
        });
        added += 1;
        // Replace k first (the larger index), then i.
        for j in [k, i] {
            let (beam, force) = beams.remove(j);
            let [p, q] = beam.ends;
            beams.push((Beam::new(p, n), force.clone()));
            beams.push((Beam::new(n, q), force));
        }
    }
}

/// Step 3 with `remove_crossings`: drops the weaker beam of each crossing pair, strongest
/// beams first.
fn remove_crossings(joints: &[Joint], beams: BeamForces) -> BeamForces {
    let tol = crossing_tolerance(joints);
    let mut order: Vec<usize> = (0..beams.len()).collect();
    order.sort_by(|&a, &b| {
        peak(&beams[b].1)
            .total_cmp(&peak(&beams[a].1))
            .then(a.cmp(&b))
    });
    let mut kept: Vec<usize> = Vec::new();
    for &k in &order {
        let [a, b] = beams[k].0.ends;
        let crosses = kept
            .iter()
            .any(|&q| crossing(joints, [a, b], beams[q].0.ends, tol).is_some());
        if !crosses {
            kept.push(k);
        }
    }
    kept.sort_unstable();
    kept.into_iter().map(|k| beams[k].clone()).collect()
}

/// Step 5: removes dangling free joints (at most one beam) with their beam until none is
/// left, then, when merging, one tension run at a time ([`merge_straight_run`]) while that
/// leaves none dangling; `alive` marks the joints that remain.
fn remove_dangling(
    joints: &[Joint],
    alive: &mut [bool],
    beams: &mut BeamForces,
    settings: &RoundSettings,
    report: &mut RoundReport,
) {
    let n = joints.len();
    loop {
        let mut degree = vec![0usize; n];
        for (b, _) in beams.iter() {
            degree[b.ends[0]] += 1;
            degree[b.ends[1]] += 1;
        }
        let dangling: Vec<usize> = (0..n)
            .filter(|&i| alive[i] && joints[i].is_free() && degree[i] <= 1)
            .collect();
        if dangling.is_empty() {
            if !settings.merge {
                break;
            }
            if let Some(i) = merge_straight_run(joints, alive, beams, settings) {
                alive[i] = false;
                report.straight_runs += 1;
                continue;
            }
            break;
        }
        for &i in &dangling {
            alive[i] = false;
        }
        report.dangling_joints += dangling.len();
        beams.retain(|(b, _)| alive[b.ends[0]] && alive[b.ends[1]]);
    }
}

/// Step 6: the structure of the `alive` joints, renumbered in order, and its beams sorted,
/// with their forces as start values (case-major, `cases` load cases).
fn renumber(
    joints: &[Joint],
    alive: &[bool],
    beams: BeamForces,
    cases: usize,
) -> (Structure, Vec<f64>) {
    let mut index = vec![usize::MAX; joints.len()];
    let mut new_joints = Vec::new();
    for i in 0..joints.len() {
        if alive[i] {
            index[i] = new_joints.len();
            new_joints.push(joints[i].clone());
        }
    }
    let mut renumbered: BeamForces = beams
        .into_iter()
        .map(|(b, f)| (Beam::new(index[b.ends[0]], index[b.ends[1]]), f))
        .collect();
    renumbered.sort_by_key(|(b, _)| *b);
    let mut start = vec![0.0; cases * renumbered.len()];
    for (j, (_, f)) in renumbered.iter().enumerate() {
        for c in 0..cases {
            start[c * renumbered.len() + j] = f[c];
        }
    }
    let out = Structure {
        joints: new_joints,
        beams: renumbered.into_iter().map(|(b, _)| b).collect(),
    };
    (out, start)
}

/// Merges the first straight run (module header, step 4) among the `alive` joints: removes
/// its joint's two beams from `beams` and adds (or adds to) the beam between their far ends.
/// Returns the joint merged away.
fn merge_straight_run(
    joints: &[Joint],
    alive: &[bool],
    beams: &mut Vec<(Beam, Vec<f64>)>,
    settings: &RoundSettings,
) -> Option<usize> {
    // One sign in every case, for both members: tension, or compression when allowed.
    let sign = |f: &[f64]| {
        if f.iter().all(|&v| v < 0.0) {
            -1
        } else if settings.compression_runs && f.iter().all(|&v| v > 0.0) {
            1
        } else {
            0
        }
    };
    let max_length = settings.max_length;
    let run = (0..joints.len()).find_map(|i| {
        let joint = &joints[i];
        if !alive[i] || !joint.is_free() || joint.loads.iter().any(|f| f.norm() != 0.0) {
            return None;
        }
        let members: Vec<usize> = (0..beams.len())
            .filter(|&k| beams[k].0.ends.contains(&i))
            .collect();
        let &[k1, k2] = members.as_slice() else {
            return None;
        };
        let far = |k: usize| beams[k].0.ends[0] + beams[k].0.ends[1] - i;
        let (a, b) = (far(k1), far(k2));
        let too_long =
            max_length.is_some_and(|l| (joints[a].position - joints[b].position).norm() > l);
        let same_sign = sign(&beams[k1].1) != 0 && sign(&beams[k1].1) == sign(&beams[k2].1);
        (a != b && same_sign && straight_through(joints, a, i, b) && !too_long).then_some((
            i,
            k1,
            k2,
            Beam::new(a, b),
        ))
    });
    let (joint, k1, k2, merged) = run?;
    let force: Vec<f64> = (beams[k1].1.iter().zip(&beams[k2].1))
        .map(|(p, q)| 0.5 * (p + q))
        .collect();
    let (first, second) = (k1.min(k2), k1.max(k2));
    beams.remove(second);
    beams.remove(first);
    match beams.iter_mut().find(|(b, _)| *b == merged) {
        Some((_, f)) => f.iter_mut().zip(&force).for_each(|(f, g)| *f += g),
        None => beams.push((merged, force)),
    }
    Some(joint)
}

/// Whether the path a–c–b runs straight through joint c: the directions from c to a and to b
/// opposite within [`RUN_ANGLE`].
fn straight_through(joints: &[Joint], a: usize, c: usize, b: usize) -> bool {
    let (u, v) = (
        joints[a].position - joints[c].position,
        joints[b].position - joints[c].position,
    );
    u.cross(&v).norm() <= RUN_ANGLE.sin() * u.norm() * v.norm() && u.dot(&v) < 0.0
}

/// Step 4 (module header): removes the first beam a–b of `beams` along which a joint c lies,
/// joined to a and b by beams collinear within [`RUN_ANGLE`], and adds its force to those two.
/// Returns whether one was found.
fn merge_overlap(joints: &[Joint], beams: &mut BeamForces) -> bool {
    let index: BTreeMap<Beam, usize> = (beams.iter().enumerate())
        .map(|(k, (b, _))| (*b, k))
        .collect();
    let mut neighbours = vec![Vec::new(); joints.len()];
    for (b, _) in beams.iter() {
        neighbours[b.ends[0]].push(b.ends[1]);
        neighbours[b.ends[1]].push(b.ends[0]);
    }
    let found = beams.iter().enumerate().find_map(|(k, (beam, _))| {
        let [a, b] = beam.ends;
        neighbours[a].iter().find_map(|&c| {
            let path = (index.get(&Beam::new(a, c)), index.get(&Beam::new(c, b)));
            let (Some(&ac), Some(&cb)) = path else {
                return None;
            };
            straight_through(joints, a, c, b).then_some((k, ac, cb))
        })
    });
    let Some((k, ac, cb)) = found else {
        return false;
    };
    let force = beams[k].1.clone();
    for path in [ac, cb] {
        for (f, g) in beams[path].1.iter_mut().zip(&force) {
            *f += g;
        }
    }
    beams.remove(k);
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::truss::model::{JointKind, Support};
    use crate::truss::testing::planar_joint as joint;

    fn settings() -> RoundSettings {
        RoundSettings {
            min_length: 0.1,
            merge_tolerance: 1e-3,
            prune: 0.0,
            crossings: Crossings::Keep,
            max_length: None,
            merge: true,
            compression_runs: false,
        }
    }

    fn positions(s: &Structure) -> Vec<Vec3> {
        s.joints.iter().map(|j| j.position).collect()
    }

    #[test]
    fn joints_at_minimum_length_merge_and_parallel_beams_combine() {
        // Free joints 2 and 3 are 0.1 apart; both connect to anchor 0 and load 1.
        let s = Structure {
            joints: vec![
                joint(0.0, 0.0, JointKind::Anchor(Support::Pinned)),
                joint(4.0, 0.0, JointKind::Load),
                joint(2.0, 2.0, JointKind::Free),
                joint(2.1, 2.0, JointKind::Free),
            ],
            beams: vec![
                Beam::new(0, 2),
                Beam::new(0, 3),
                Beam::new(1, 2),
                Beam::new(1, 3),
                Beam::new(2, 3),
                Beam::new(0, 1),
            ],
        };
        let forces = vec![vec![1.0, 2.0, 3.0, 4.0, 9.0, -5.0]];
        let (out, start, report) = clean(&s, &positions(&s), &forces, &settings());
        assert_eq!(report.merged_joints, 1);
        assert_eq!(out.joints.len(), 3);
        assert!((out.joints[2].position - Vec3::new(2.05, 2.0, 0.0)).norm() < 1e-12);
        assert_eq!(
            out.beams,
            vec![Beam::new(0, 1), Beam::new(0, 2), Beam::new(1, 2)]
        );
        assert_eq!(start, vec![-5.0, 3.0, 7.0]);
    }

    #[test]
    fn fixed_joints_keep_their_place_and_never_merge_together() {
        let s = Structure {
            joints: vec![
                joint(0.0, 0.0, JointKind::Anchor(Support::Pinned)),
                joint(0.1, 0.0, JointKind::Load),
                joint(0.05, 0.05, JointKind::Free),
                joint(1.0, 1.0, JointKind::Free),
            ],
            beams: vec![
                Beam::new(0, 1),
                Beam::new(1, 2),
                Beam::new(0, 3),
                Beam::new(1, 3),
                Beam::new(2, 3),
            ],
        };
        let forces = vec![vec![1.0; 5]];
        let (out, _, report) = clean(&s, &positions(&s), &forces, &settings());
        // Joint 2 (0.0707 from both fixed joints) joins one of them; the fixed pair stays apart.
        assert_eq!(report.merged_joints, 1);
        assert_eq!(out.joints.len(), 3);
        assert!(!out.joints[0].is_free() && !out.joints[1].is_free());
        assert_eq!(out.joints[0].position, Vec3::zeros());
        assert_eq!(out.joints[1].position, Vec3::new(0.1, 0.0, 0.0));
    }

    /// A 2 m square: anchors 0 (0, 0) and 1 (2, 0), load 2 (2, 2), free joint 3 (0, 2); beams
    /// 0–2 and 1–3 (the diagonals), then 1–2, 2–3, 0–3.
    fn square_with_diagonals() -> Structure {
        Structure {
            joints: vec![
                joint(0.0, 0.0, JointKind::Anchor(Support::Pinned)),
                joint(2.0, 0.0, JointKind::Anchor(Support::Pinned)),
                joint(2.0, 2.0, JointKind::Load),
                joint(0.0, 2.0, JointKind::Free),
            ],
            beams: vec![
                Beam::new(0, 2),
                Beam::new(1, 3),
                Beam::new(1, 2),
                Beam::new(2, 3),
                Beam::new(0, 3),
            ],
        }
    }

    #[test]
    fn pruning_crossings_and_dangling_joints() {
        // A square with both diagonals, plus a free joint hanging on one beam.
        let mut s = square_with_diagonals();
        s.joints.push(joint(5.0, 5.0, JointKind::Free));
        s.beams.push(Beam::new(2, 4));
        let forces = vec![vec![10.0, -2.0, 8.0, 1e-9, 3.0, 1e-6]];
        let mut set = settings();
        set.crossings = Crossings::Remove;
        let (out, _, report) = clean(&s, &positions(&s), &forces, &set);
        assert_eq!(report.crossings_removed, 1);
        assert_eq!(report.dangling_joints, 1);
        assert_eq!(out.joints.len(), 4);
        assert!(
            !out.beams.contains(&Beam::new(1, 3)),
            "weaker diagonal dropped"
        );
        set.crossings = Crossings::Keep;
        set.prune = 1e-3;
        let (out, start, report) = clean(&s, &positions(&s), &forces, &set);
        assert_eq!(report.pruned_beams, 2);
        assert_eq!(report.dangling_joints, 1);
        assert_eq!(out.beams.len(), 4);
        assert!(start.iter().all(|f| f.abs() >= 1e-2));
    }

    #[test]
    fn crossing_beams_are_joined_by_a_joint_carrying_both_forces() {
        // The diagonals (forces 10 and −2 N) meet at (1, 1).
        let s = square_with_diagonals();
        let forces = vec![vec![10.0, -2.0, 8.0, 1.0, 3.0]];
        let length = |s: &Structure| -> f64 {
            let p = positions(s);
            s.beams
                .iter()
                .map(|b| (p[b.ends[1]] - p[b.ends[0]]).norm())
                .sum()
        };
        let mut set = settings();
        set.crossings = Crossings::Split;
        let (out, start, report) = clean(&s, &positions(&s), &forces, &set);
        assert_eq!(report.crossings_split, 1);
        assert!(!report.changes_nothing());
        assert_eq!(out.joints.len(), 5);
        assert_eq!(out.beams.len(), 7);
        let centre = out.joints[4].position;
        assert!(out.joints[4].is_free() && (centre - Vec3::new(1.0, 1.0, 0.0)).norm() < 1e-12);
        // Each half carries its diagonal's force: the new joint balances, the length is kept.
        let at = |a: usize, b: usize| {
            start[out
                .beams
                .iter()
                .position(|x| *x == Beam::new(a, b))
                .unwrap()]
        };
        assert_eq!((at(0, 4), at(2, 4)), (10.0, 10.0));
        assert_eq!((at(1, 4), at(3, 4)), (-2.0, -2.0));
        assert!((length(&out) - length(&s)).abs() < 1e-12);
        // Pieces shorter than l_min stay crossed.
        set.min_length = 1.5;
        let (_, _, report) = clean(&s, &positions(&s), &forces, &set);
        assert_eq!(report.crossings_split, 0);
    }

    /// Pinned anchors 0 at (0, 0) and 1 at (4, 0), then free joints at `free` (x, y).
    fn tie_with_free_joints(free: &[(f64, f64)]) -> Vec<Joint> {
        let pinned = || JointKind::Anchor(Support::Pinned);
        let mut joints = vec![joint(0.0, 0.0, pinned()), joint(4.0, 0.0, pinned())];
        joints.extend(free.iter().map(|&(x, y)| joint(x, y, JointKind::Free)));
        joints
    }

    #[test]
    fn without_merging_short_beams_and_straight_ties_stay() {
        // Free joints 2 and 3 at l_min on a straight tie between anchors 0 and 1: merging
        // would join 2 and 3 and then the tie; with `merge` off nothing changes.
        let s = Structure {
            joints: tie_with_free_joints(&[(2.0, 0.0), (2.1, 0.0)]),
            beams: vec![Beam::new(0, 2), Beam::new(1, 3), Beam::new(2, 3)],
        };
        let forces = vec![vec![-3.0, -3.0, -3.0]];
        let merging = clean(&s, &positions(&s), &forces, &settings()).2;
        assert_eq!((merging.merged_joints, merging.straight_runs), (1, 1));
        let kept = RoundSettings {
            merge: false,
            ..settings()
        };
        let (out, start, report) = clean(&s, &positions(&s), &forces, &kept);
        assert!(report.changes_nothing());
        assert_eq!(out, s);
        assert_eq!(start, vec![-3.0, -3.0, -3.0]);
    }

    #[test]
    fn a_joint_left_on_a_straight_tie_becomes_one_member() {
        // Anchors 0 and 1; free joint 2 on the tie between them (kinked by 1e-4 rad, its own
        // weight), free joint 3 on a bent tension path 0–3–1, free joint 4 on a compression run
        // 0–4–1 (kept for Euler struts: two halves weigh half the whole), and the pair 0–1 in
        // tension.
        let s = Structure {
            joints: tie_with_free_joints(&[(2.0, 2e-4), (2.0, 1.0), (2.0, -2e-4)]),
            beams: vec![
                Beam::new(0, 1),
                Beam::new(0, 2),
                Beam::new(1, 2),
                Beam::new(0, 3),
                Beam::new(1, 3),
                Beam::new(0, 4),
                Beam::new(1, 4),
            ],
        };
        let forces = vec![vec![-1.0, -10.0, -12.0, -5.0, -5.0, 7.0, 7.0]];
        let (out, start, report) = clean(&s, &positions(&s), &forces, &settings());
        assert_eq!(report.straight_runs, 1);
        assert_eq!(out.joints.len(), 4);
        // Joint 2's mean force (−11) joins the beam already between the anchors.
        assert_eq!(
            out.beams,
            vec![
                Beam::new(0, 1),
                Beam::new(0, 2),
                Beam::new(0, 3),
                Beam::new(1, 2),
                Beam::new(1, 3)
            ]
        );
        assert_eq!(start, vec![-12.0, -5.0, 7.0, -5.0, 7.0]);
        // Not into a beam longer than l_max.
        let mut set = settings();
        set.max_length = Some(3.0);
        let (_, _, report) = clean(&s, &positions(&s), &forces, &set);
        assert_eq!(report.straight_runs, 0);
        // With compression mass linear in length the strut through joint 4 is a flat
        // direction too: it joins the pair 0–1 as well (−12 + 7).
        let linear = RoundSettings {
            compression_runs: true,
            ..settings()
        };
        let (out, start, report) = clean(&s, &positions(&s), &forces, &linear);
        assert_eq!(report.straight_runs, 2);
        assert_eq!(
            out.beams,
            vec![Beam::new(0, 1), Beam::new(0, 2), Beam::new(1, 2)]
        );
        assert_eq!(start, vec![-5.0, -5.0, -5.0]);
        // A run with one member in tension and one in compression is no run.
        let mixed = vec![vec![-1.0, -10.0, 12.0, -5.0, -5.0, 7.0, -7.0]];
        let (_, _, report) = clean(&s, &positions(&s), &mixed, &linear);
        assert_eq!(report.straight_runs, 0);
    }

    #[test]
    fn a_beam_along_a_two_beam_path_joins_the_path_with_linear_mass() {
        // Anchors 0 and 1; free joint 2 on the strut 0–1 (kinked by 1e-3 rad) joined to both
        // ends and braced to free joint 3 above.
        let s = Structure {
            joints: vec![
                joint(0.0, 0.0, JointKind::Anchor(Support::Pinned)),
                joint(4.0, 0.0, JointKind::Anchor(Support::Pinned)),
                joint(2.0, 1e-3, JointKind::Free),
                joint(2.0, 2.0, JointKind::Free),
            ],
            beams: vec![
                Beam::new(0, 1),
                Beam::new(0, 2),
                Beam::new(0, 3),
                Beam::new(1, 2),
                Beam::new(1, 3),
                Beam::new(2, 3),
            ],
        };
        let forces = vec![vec![5.0, 3.0, 2.0, -1.0, 2.0, 4.0]];
        let linear = RoundSettings {
            compression_runs: true,
            ..settings()
        };
        let (out, start, report) = clean(&s, &positions(&s), &forces, &linear);
        assert_eq!((report.overlaps, report.straight_runs), (1, 0));
        assert!(!report.changes_nothing());
        assert_eq!(out.joints.len(), 4);
        assert_eq!(
            out.beams,
            vec![
                Beam::new(0, 2),
                Beam::new(0, 3),
                Beam::new(1, 2),
                Beam::new(1, 3),
                Beam::new(2, 3)
            ]
        );
        // The path carries its own forces plus the direct beam's.
        assert_eq!(start, vec![8.0, 2.0, 4.0, 2.0, 4.0]);
        // Euler compression (no linear runs), no merging, or a real triangle: nothing changes.
        for (set, lift) in [
            (settings(), 1e-3),
            (
                RoundSettings {
                    merge: false,
                    ..linear
                },
                1e-3,
            ),
            (linear, 0.5),
        ] {
            let mut bent = s.clone();
            bent.joints[2].position.y = lift;
            let (out, _, report) = clean(&bent, &positions(&bent), &forces, &set);
            assert!(report.changes_nothing());
            assert_eq!(out.beams, s.beams);
        }
    }
}
