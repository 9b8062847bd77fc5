//! Solve + clean-up rounds (seed §4.3: optimize, then merge joints and remove idle members,
//! then optimize the cleaned structure again).
//!
//! By default (no `[rounds] count`, no `--rounds`) the rounds run until the design stops
//! changing, at most [`ROUND_CAP`]. A round may then end early when it only creeps: feasible,
//! its objective falling by less than [`CREEP_TOLERANCE`] (relative) over [`CREEP_WINDOW`]
//! iterations. Such a creep is the signature of a design walking toward a topology change the
//! smooth problem cannot make (two joints merging, a member's force going to zero with its
//! concave Euler mass): the clean-up makes it in one move. A round whose clean-up changes
//! nothing is solved once more from its end point without the creep test, so the last round
//! runs to the solver's own tests and limits.
//!
//! The window waits [`CREEP_WINDOW`] iterations even when the objective has visibly converged.
//! So a round also ends when its decreases shrink geometrically (`Options::progress_stretch`):
//! the decrease Δ₂ over the last [`CREEP_STRETCH`] feasible iterations is at most half the
//! decrease Δ₁ over the stretch before, and Δ₂ ≤ [`CREEP_TOLERANCE`] (relative). With a ratio
//! q ≤ ½ per stretch the rest of the round would gain Δ₂·q/(1 − q) ≤ Δ₂, below the tolerance the
//! window uses. Objective decrease alone does not see a design that still walks toward a
//! topology change at an almost constant objective (crane_derrick's fifth round: a member's
//! force going to zero over 90 iterations at 248.28 → 248.22 kg), so such an end is kept only if
//! the clean-up of that point changes the design. Else the round goes on from that point as a
//! solve of its own without the creep test, to the solver's own tests (the rest of the
//! iteration budget): the design has converged as far as the objective tells, so what is left
//! is either that walk, which ends at its bound (a force at zero, a beam at its minimum length)
//! for the next clean-up to act on, or the last digits. Going on with the window instead crept a
//! full window of 50 iterations before the same point (measured 2026-11-29, all 30 files of
//! docs/notes/truss.md, one thread: the same masses to six digits, iterations crane_derrick 958
//! → 805, crane_derrick_linear 184 → 177, generated pier_2 244 → 204, pier_3 61 → 62, the rest
//! the same; crane seeds 1–20: seed 17 Stalled at 206.32 kg → Optimal at 116.20 kg). Cost:
//! nothing per iteration; one clean-up per such end. Measured on the 18 shipped files
//! (docs/notes/truss.md, 2026-11-28): through_deck_cantilever 744 → 427 iterations; a round
//! that ends after the first drop of a staircase (cantilever_bridge's third round) can end
//! heavier (+0.67 %).
//!
//! With `linear` mass, that solve is cleaned up every [`CLEAN_UP_CHECK`] iterations, as a
//! round is at its start. Nothing else ends its walk before the iteration budget: the shipped
//! pier on a 0.5 m lattice walked one such round to its 1,000-iteration budget (484.858 kg,
//! its steps cut to 0.01–0.15 every fifth iteration), 0.04 % lighter than where it began.
//! Measured (2026-11-29, one thread): that pier 1,233 → 608 iterations in all, 64 → 33 s,
//! 484.6638 → 484.6875 kg (still 1.19 % below its LP); on the 1 m lattice 291 → 281
//! iterations, 489.1525 → 489.1546 kg; the Warren deck at 1 m 135 → 134, generated pier_2
//! 241 → 137, crane_derrick_linear 82 → 64, at the same masses; the other 37 truss files of
//! docs/notes/truss.md the same iterates.
//!
//! With `linear` mass four more defaults apply. The stretch test extrapolates
//! (`Options::progress_extrapolate`): a round also ends when its last two stretches' decreases,
//! continued geometrically over the next window, add up to at most [`CREEP_TOLERANCE`], the
//! window's verdict up to 40 iterations sooner. A settling walk's decreases shrink slowly
//! (generated pier_2's resumed rounds: ×0.92–0.95 per full step, ×0.6–0.8 per stretch,
//! 630.757 → 630.528 kg in 214 iterations, 50 at a time), which the ½ never sees. Measured
//! (2026-11-29, `optimize truss F -q --threads 1`, the 39 truss files of docs/notes/truss.md):
//! pier_2 314 → 241 iterations, vpier_2 85 → 72, warren_deck_linear 64 → 56, deck_6 64 → 55,
//! crane_tripod_linear 42 → 34, crane_derrick_linear 71 → 82, every mass the same to seven digits;
//! the shipped pier on a 1 m lattice 471 → 291 (the same mass). With Euler compression the
//! objective falls in staircases, and a tail cut before the next step cost through_deck_cantilever
//! 427 → 702 iterations and cantilever_bridge 0.75 % mass. A round is cleaned up once after
//! [`CLEAN_UP_CHECK`] iterations and ends there if that changes the design (else it goes on from
//! that point). The rounds after the first keep only the sign's part of each loaded member's force,
//! as the layout start does for the first. And a full step the line search rejects gets up to
//! [`LINEAR_CORRECTIONS`] second-order corrections (IPOPT's `max_soc`) instead of the solver's one:
//! a design that walks (joints sliding, a beam shortening) takes steps the balance rows'
//! linearization cannot follow (their curvature is f/l, the larger the shorter the member), and one
//! correction only halves the violation. Measured (2026-11-29, `optimize truss F -q --threads 1`,
//! the 39 truss files of docs/notes/truss.md): the Warren deck on a 1 m lattice 393 → 130
//! iterations (1.8 → 0.6 s), the same mass; the 27 `linear` files of the set 2,602 → 1,971
//! iterations (vpier_0 309 → 135, vdeck_4 203 → 72, deck_7 138 → 72, footbridge 227 → 142,
//! crane_derrick_linear 177 → 71; vdeck_0 117 → 220, pier_2 204 → 314), all Optimal; deck_3 and
//! deck_5 end 0.13 % heavier in 29 iterations instead of 90 and 97, pier_2 0.03 % heavier, deck_6
//! 0.13 % lighter. For every mass model it sent through_deck_cantilever (Euler mass) to Stalled at
//! 11,244 kg (from Optimal at 10,767.50), so the other models keep one.

use crate::error::Error;
use crate::solver::{Evaluations, IterationRecord, Options, Solution, Status};

use super::model::Structure;
use super::nlp::{ForceParts, SetupError, TrussNlp};
use super::start::signed_parts;
use super::topology::{self, RoundReport, RoundSettings};

/// Most solve + clean-up rounds by default (without `[rounds] count` or `--rounds`): rounds
/// run until the design stops changing, this cap only guards against a clean-up that never
/// settles.
pub const ROUND_CAP: usize = 20;

/// By default, a round that did not converge and whose clean-up changed nothing is solved
/// again from its end point this many times (the solver's Hessian state starts afresh), then
/// the rounds stop.
pub const DEFAULT_RESTARTS: usize = 1;

/// Feasible iterations over which a default round must lower its objective by
/// [`CREEP_TOLERANCE`] (see the module header; `Options::progress_window`).
pub const CREEP_WINDOW: usize = 50;

/// Relative objective decrease a default round must make every [`CREEP_WINDOW`] feasible
/// iterations.
pub const CREEP_TOLERANCE: f64 = 1e-3;

/// Second-order corrections per rejected full step in the default rounds with `linear` mass
/// (module header; IPOPT's `max_soc`), unless the file sets `[solver]
/// second_order_corrections`.
pub const LINEAR_CORRECTIONS: usize = 4;

/// Feasible iterations per stretch of a default round's geometric creep end (see the module
/// header; `Options::progress_stretch`): a tenth of [`CREEP_WINDOW`], so the test judges the
/// last 2·5 + 1 iterates. The iteration count of through_deck_cantilever moves with it by route
/// changes, not monotonically (3–10: 368, 468, 427, 523, 415, 442, 867; docs/notes/truss.md).
pub const CREEP_STRETCH: usize = CREEP_WINDOW / 10;

/// Iterations after which a default round of a `linear`-mass run is cleaned up once: should the
/// clean-up change the design (a member's force gone to zero, two joints met, a straight run
/// formed), the round ends there and the next one starts on the cleaned design; else the round
/// goes on from that point. A round on a design that needs a topology change otherwise crawls
/// toward it until the creep test ends it ([`CREEP_WINDOW`] iterations at the least). A round
/// that goes on without the creep test after a creep end (module header) is checked again
/// every this many iterations: nothing else ends its walk before the iteration budget. Not with
/// Euler compression or the length objective: there a clean-up in mid-route (a member whose
/// force passes through zero, joints that only pass near each other) cost crane_tripod 37 % mass
/// and left crane_derrick and through_deck_cantilever Stalled, roof_warren Infeasible
/// (docs/notes/truss.md).
pub const CLEAN_UP_CHECK: usize = 25;

/// Largest violation (the solver's scaled measure) of a round's end point after which its
/// clean-up may merge joints and tension runs. Merging moves joints and adds forces; at a point
/// that does not balance, inside a self-stressed knot of short beams, it turned crane seed 4's
/// violation of 2.3e-3 into 4.6 (docs/notes/truss.md). Pruning and dangling joints are unaffected.
const MERGE_VIOLATION: f64 = 1e-3;

/// What the rounds produced: the reported round's model and solution, and totals over all
/// rounds.
pub struct Rounds {
    /// The model of the reported round.
    pub nlp: TrussNlp,
    /// Its solution.
    pub solution: Solution,
    /// One clean-up report per round that was followed by another.
    pub reports: Vec<RoundReport>,
    /// Rounds solved.
    pub rounds_run: usize,
    /// The round whose design is reported: the last round of the best standing (`Standing`)
    /// any round reached (the last one, unless an earlier one ended better).
    pub result_round: usize,
    /// SQP iterations over all rounds.
    pub iterations: usize,
    /// Evaluations over all rounds.
    pub evaluations: Evaluations,
    /// Each round's iteration records, in order.
    pub logs: Vec<Vec<IterationRecord>>,
}

/// Runs the rounds from `nlp`: `count` rounds if given, else by default (module header).
/// `clean_up` is the clean-up's settings (its `merge` is decided per round here).
pub fn solve_rounds(
    mut nlp: TrussNlp,
    options: &Options,
    count: Option<usize>,
    clean_up: &RoundSettings,
) -> Result<Rounds, Error> {
    let rounds = count.unwrap_or(ROUND_CAP).max(1);
    let creep_test = count.is_none() && options.progress_window == 0;
    // Non-converged rounds in a row whose clean-up changed nothing.
    let mut restarts = 0;
    let mut reports = Vec::new();
    let mut iterations = 0;
    let mut evaluations = Evaluations::default();
    let mut logs: Vec<Vec<IterationRecord>> = Vec::new();
    let mut solution: Solution;
    let mut round = 0;
    // Each round's standing, and the model and solution of the round reported so far.
    let mut standings: Vec<Standing> = Vec::new();
    let mut best: Option<(TrussNlp, Solution)> = None;
    // Iterations the current round spent before its clean-up check or creep end that changed
    // nothing (0: none yet).
    let mut checked = 0;
    // The current round ended once by a creep test without a clean-up change: it goes on
    // without the creep test (module header).
    let mut settle = false;
    loop {
        let mut options = options.clone();
        options.log = options.log.with_objective(nlp.objective_unit());
        if rounds > 1 {
            options.log.stage = format!("round {}", round + 1);
        }
        if creep_test && nlp.settings().mass_linear_in_force() {
            options.second_order_corrections = options
                .second_order_corrections
                .or(Some(LINEAR_CORRECTIONS));
        }
        if creep_test && restarts == 0 && !settle {
            options.progress_window = CREEP_WINDOW;
            options.progress_tolerance = CREEP_TOLERANCE;
            options.progress_stretch = CREEP_STRETCH;
            options.progress_extrapolate |= nlp.settings().mass_linear_in_force();
        }
        let check = creep_test
            && nlp.settings().mass_linear_in_force()
            && restarts == 0
            && (checked == 0 || settle)
            && options.max_iterations > checked + CLEAN_UP_CHECK;
        if check {
            options.max_iterations = CLEAN_UP_CHECK;
        } else {
            options.max_iterations = options.max_iterations.saturating_sub(checked);
        }
        solution = crate::solver::solve(&nlp, &options);
        iterations += solution.iterations;
        evaluations.functions += solution.evaluations.functions;
        evaluations.derivatives += solution.evaluations.derivatives;
        evaluations.hessians += solution.evaluations.hessians;
        if checked > 0 {
            let log = logs.last_mut().expect("the checked part's log");
            log.extend(solution.log.iter().skip(1).map(|r| IterationRecord {
                iter: r.iter + checked,
                ..r.clone()
            }));
        } else {
            logs.push(solution.log.clone());
        }
        // The clean-up check's end, or a creep end (by the stretches or the window: the status
        // does not tell): kept only if the clean-up changes the design, else the round goes on
        // from here (after a creep end without the creep test).
        let creep_end =
            creep_test && options.progress_stretch > 0 && solution.status == Status::SlowProgress;
        if creep_end || (check && solution.status == Status::IterationLimit) {
            let (_, _, report) = clean_up_at(&nlp, &solution, clean_up);
            if report.changes_nothing() {
                settle |= creep_end;
                checked += solution.iterations;
                nlp = resumed_at(&nlp, &solution.x)
                    .map_err(|e| Error::Runtime(format!("round {}: {e}", round + 1)))?;
                continue;
            }
        }
        settle = false;
        checked = 0;
        round += 1;
        let optimal = solution.status == Status::Optimal;
        standings.push(Standing::of(solution.status));
        if reported_round(&standings) == round {
            best = Some((nlp.clone(), solution.clone()));
        }
        if round == rounds || solution.status == Status::Interrupted {
            break;
        }
        let (structure, forces, report) = clean_up_at(&nlp, &solution, clean_up);
        if report.changes_nothing() {
            // Another solve would start at this optimum of the same model; by default a
            // non-converged round on an unchanged model is restarted once (fresh Hessian,
            // no creep test).
            restarts += 1;
            if optimal || (count.is_none() && restarts > DEFAULT_RESTARTS) {
                break;
            }
        } else {
            restarts = 0;
        }
        reports.push(report);
        let parts = if nlp.settings().mass_linear_in_force() {
            signed_parts(&forces)
        } else {
            // With Euler compression both parts stay: a member whose force crosses zero
            // between rounds is a real route there (fixed signs cost cantilever_bridge 6 % mass).
            vec![ForceParts::Both; forces.len()]
        };
        nlp = TrussNlp::with_parts(structure, nlp.settings().clone(), forces, parts)
            .map_err(|e| Error::Runtime(format!("round {round}: {e}")))?;
    }
    let result_round = reported_round(&standings);
    if let Some((best_nlp, best_solution)) = best {
        nlp = best_nlp;
        solution = best_solution;
    }
    Ok(Rounds {
        nlp,
        solution,
        reports,
        rounds_run: round,
        result_round,
        iterations,
        evaluations,
        logs,
    })
}

/// The clean-up of `solution`'s end point (its `merge` decided by the point's violation).
/// The same model started again at `x`: its own structure (joints moved to `x`), beam order
/// and force parts. (The clean-up's copy of an unchanged design lists the beams sorted, which
/// a first round's layout start need not: its forces would meet another beam's parts.)
fn resumed_at(nlp: &TrussNlp, x: &[f64]) -> Result<TrussNlp, SetupError> {
    let mut structure = nlp.structure().clone();
    for (joint, p) in structure.joints.iter_mut().zip(nlp.positions(x)) {
        joint.position = p;
    }
    let forces = nlp.forces(x).concat();
    TrussNlp::with_parts(structure, nlp.settings().clone(), forces, nlp.parts())
}

fn clean_up_at(
    nlp: &TrussNlp,
    solution: &Solution,
    clean_up: &RoundSettings,
) -> (Structure, Vec<f64>, RoundReport) {
    let settings = RoundSettings {
        merge: solution.max_violation <= MERGE_VIOLATION,
        ..*clean_up
    };
    topology::clean(
        nlp.structure(),
        &nlp.positions(&solution.x),
        &nlp.forces(&solution.x),
        &settings,
    )
}

/// How a round ended, ordered from worst to best for choosing the reported design.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Standing {
    /// No usable design: Infeasible (the least-infeasible point), Unbounded, EvaluationError.
    Failed,
    /// A design the solver stopped at before its tests held (a limit, slow progress, a stall,
    /// Acceptable, an interruption).
    Unfinished,
    /// Optimal.
    Converged,
}

impl Standing {
    /// The standing of a round that ended with `status`.
    pub(super) fn of(status: Status) -> Self {
        match status {
            Status::Optimal => Standing::Converged,
            Status::Infeasible | Status::Unbounded | Status::EvaluationError => Standing::Failed,
            _ => Standing::Unfinished,
        }
    }
}

/// The round (1-based) whose design a run reports, from each round's standing in order: the
/// last round of the best standing reached. A clean-up that the next solve cannot settle does
/// not discard a converged design, nor a feasible one for the least-infeasible point of a
/// round that found none (roof_warren's 30-iteration golden run: its fourth round, on a design
/// cleaned up from a point one iteration short of convergence, ended Infeasible).
pub(super) fn reported_round(standings: &[Standing]) -> usize {
    let best = standings.iter().copied().max().unwrap_or(Standing::Failed);
    standings
        .iter()
        .rposition(|&s| s == best)
        .map_or(standings.len(), |i| i + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn later_rounds_keep_the_sign_part_of_loaded_members_and_both_of_idle_ones() {
        // Largest force 2e5 N: 1e-2 N is below IDLE_FRACTION of it, 5 N above.
        let parts = signed_parts(&[-2e5, 3e4, 1e-2, -5.0, 0.0]);
        assert_eq!(
            parts,
            [
                ForceParts::Tension,
                ForceParts::Compression,
                ForceParts::Both,
                ForceParts::Tension,
                ForceParts::Both,
            ]
        );
    }

    #[test]
    fn a_round_resumed_on_an_unchanged_design_starts_where_it_stopped() {
        use super::super::model::{Beam, Joint, JointKind, Settings, Support, Vec3};
        use super::super::testing::test_settings;
        use crate::solver::Nlp;
        // A bracket: anchors at (0, 0) and (0, 3), load P down at (4, 0). The diagonal pulls
        // (−5P/3, tension), the horizontal pushes (4P/3). Its beams are listed unsorted, as a
        // first round's layout start may list them, and each has one signed part.
        let p = 1e5;
        let joint = |at: [f64; 3], kind, load: f64| Joint {
            position: Vec3::from(at),
            kind,
            name: None,
            loads: vec![Vec3::new(0.0, -load, 0.0)],
        };
        let anchor = JointKind::Anchor(Support::Pinned);
        let structure = Structure {
            joints: vec![
                joint([0.0, 0.0, 0.0], anchor.clone(), 0.0),
                joint([0.0, 3.0, 0.0], anchor, 0.0),
                joint([4.0, 0.0, 0.0], JointKind::Free, p),
            ],
            beams: vec![Beam::new(1, 2), Beam::new(0, 2)],
        };
        let settings = Settings {
            planar: true,
            ..test_settings(1)
        };
        let forces = vec![-5.0 * p / 3.0, 4.0 * p / 3.0];
        let parts = signed_parts(&forces);
        assert_eq!(parts, [ForceParts::Tension, ForceParts::Compression]);
        let nlp = TrussNlp::with_parts(structure, settings, forces, parts).unwrap();
        let dims = nlp.dims();
        let mut x = vec![0.0; dims.n];
        nlp.start(&mut x);
        // Moved a little, as a round's end point would be.
        x[dims.n - 1] += 0.01;
        let resumed = resumed_at(&nlp, &x).unwrap();
        let mut start = vec![0.0; dims.n];
        resumed.start(&mut start);
        let evaluate = |nlp: &TrussNlp, x: &[f64]| {
            let (mut f, mut c) = (0.0, vec![0.0; dims.m]);
            nlp.eval(x, &mut f, &mut c).unwrap();
            (f, c)
        };
        let (f, c) = evaluate(&nlp, &x);
        let (f_resumed, c_resumed) = evaluate(&resumed, &start);
        assert!(
            (f - f_resumed).abs() <= 1e-12 * f.abs(),
            "{f} vs {f_resumed}"
        );
        for (a, b) in c.iter().zip(&c_resumed) {
            assert!((a - b).abs() <= 1e-9 * (1.0 + a.abs()), "{a} vs {b}");
        }
    }
}
