//! Key-time continuation for unmet lower bounds (`[trials] continuation_stages`): a sequence of
//! easier problems that leads a start which barely leaves the ground to one that meets an
//! "at least this high at time t" task, so the feasibility phase does not start where the task
//! is insensitive to the forces.
//!
//! A lower-bound-only row `c(t_c) ≥ ℓ` that the start violates is often insensitive at `t_c`:
//! a foot that is back on the ground at `t_c` stays there under small force changes (seed §6.1:
//! starts that never leave the ground fail). The start's rollout is scanned for each key time
//! `t_c` whose lower-bound rows `i` are lower_rows: `t* ≤ t_c` is the step where the smallest
//! margin `minᵢ (cᵢ(t) − ℓᵢ)` is largest (the start's best attempt, e.g. the top of a small
//! hop), with values `cᵢ* = cᵢ(t*)`. Stage `s = 1…S` keeps only these rows, at time
//! `t_s = t* + (s/S)(t_c − t*)` (rounded to an RK4 step) with bounds
//! `ℓᵢ(s) = cᵢ* + (s/S)(ℓᵢ − cᵢ*)`; each stage is solved by the feasibility phase from the
//! previous stage's end, so the rows are sampled while they are still sensitive, and stage `S`
//! is the original rows. Other rows are not part of the stages.

use super::sim::Simulator;
use super::spec::Problem;
use super::spline::SplineControls;
use super::task::PoseConstraint;

/// The stage problems for spline parameters `params` (physical units): `stages` problems with
/// the staged rows only (module header), or none when no lower-bound row is lower_rows at its
/// key time, or its best margin is at the key time itself, or the rollout fails.
pub fn stage_problems(problem: &Problem, params: &[f64], stages: usize) -> Vec<Problem> {
    let lower_rows: Vec<&PoseConstraint> = problem
        .constraints
        .iter()
        .filter(|c| c.lower.is_finite() && c.upper == f64::INFINITY)
        .collect();
    if stages == 0 || lower_rows.is_empty() {
        return Vec::new();
    }
    let last = lower_rows.iter().map(|c| c.step).max().unwrap_or(0);
    let Some(history) = rollout_values(problem, params, &lower_rows, last) else {
        return Vec::new();
    };
    // Key steps with a row violated at the start.
    let mut keys: Vec<usize> = lower_rows
        .iter()
        .enumerate()
        .filter(|(i, c)| history[c.step][*i] < c.lower)
        .map(|(_, c)| c.step)
        .collect();
    keys.sort_unstable();
    keys.dedup();
    let mut groups = Vec::new();
    for key in keys {
        let rows: Vec<usize> = (0..lower_rows.len())
            .filter(|&i| lower_rows[i].step == key)
            .collect();
        let margin = |n: usize| {
            rows.iter()
                .map(|&i| history[n][i] - lower_rows[i].lower)
                .fold(f64::INFINITY, f64::min)
        };
        let best = (1..=key)
            .max_by(|&a, &b| margin(a).total_cmp(&margin(b)).then(a.cmp(&b)))
            .unwrap_or(key);
        if best < key {
            groups.push((key, best, rows));
        }
    }
    if groups.is_empty() {
        return Vec::new();
    }
    let (lower_rows, history) = (&lower_rows, &history);
    (1..=stages)
        .map(|s| {
            let w = s as f64 / stages as f64;
            let mut p = problem.clone();
            p.constraints = groups
                .iter()
                .flat_map(|(key, best, rows)| {
                    let step = (*best as f64 + w * (*key - *best) as f64).round() as usize;
                    rows.iter().map(move |&i| {
                        let c = lower_rows[i];
                        let start = history[*best][i];
                        let lower = start + w * (c.lower - start);
                        PoseConstraint {
                            name: format!(
                                "{} (stage {s}: t={:.3}, ≥ {lower:.3})",
                                c.name,
                                step as f64 * problem.dt
                            ),
                            time: step as f64 * problem.dt,
                            step,
                            lower,
                            ..c.clone()
                        }
                    })
                })
                .collect();
            p.constraints.sort_by_key(|c| c.step);
            p
        })
        .collect()
}

/// The values of `rows` after every RK4 step `0..=last` of the rollout of `params`.
fn rollout_values(
    problem: &Problem,
    params: &[f64],
    rows: &[&PoseConstraint],
    last: usize,
) -> Option<Vec<Vec<f64>>> {
    let grid = problem.knot_grid();
    let controls = SplineControls {
        grid,
        params: params.to_vec(),
    };
    let mut sim = Simulator::<f64>::new(&problem.model);
    let mut state = problem.initial_of(params);
    let steps: Vec<usize> = (0..=last).collect();
    let mut out = Vec::with_capacity(last + 1);
    sim.rollout(&mut state, problem.dt, &steps, &controls, |_, x, sim| {
        out.push(
            rows.iter()
                .map(|c| c.quantity.value(&problem.model, x, &sim.dynamics))
                .collect(),
        );
    })
    .ok()?;
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gait::formulation::Formulation;
    use std::path::PathBuf;

    /// On a small hop of the Luxo lamp (the shipped start at half force: top of the hop,
    /// about 0.1 m, near t = 0.3 s) with the in-air rows moved to t = 0.45 s, when the hop is
    /// coming down, the stages move those rows from the top of the hop to t = 0.45 s and from
    /// its height to 0.3 m.
    #[test]
    fn luxo_stages_run_from_the_hop_to_the_task() {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/gait/luxo_leap.toml");
        let mut p = crate::gait::load(&path).unwrap();
        let key = (0.45 / p.dt).round() as usize;
        for c in p.constraints.iter_mut().filter(|c| c.time == 0.3) {
            (c.time, c.step) = (0.45, key);
        }
        p.constraints.sort_by_key(|c| c.step);
        let f = Formulation::new(&p);
        let x: Vec<f64> = f.hand_made_start()[..f.reduced().parameters()]
            .iter()
            .map(|v| 0.5 * v)
            .collect();
        let stages = stage_problems(&p, &x, 4);
        assert_eq!(stages.len(), 4);
        let first = &stages[0].constraints;
        assert_eq!(first.len(), 2);
        assert!(
            first[0].time > 0.05 && first[0].time < 0.45,
            "{}",
            first[0].time
        );
        for c in first {
            assert!(c.lower > 0.01 && c.lower < 0.3, "{}", c.lower);
        }
        let last = &stages[3].constraints;
        for c in last {
            assert_eq!(c.step, key);
            assert_eq!(c.lower, 0.3);
        }
    }
}
