//! `convergence.svg`: the iteration records of a run as three stacked panels sharing the
//! x axis — objective (in the run's unit), infeasibility and optimality — against the record's
//! position in the run (iteration numbers restart with every solve, so the x axis counts
//! records). Infeasibility and optimality are drawn on a log₁₀ scale (zeros at the panel's
//! floor, [`FLOOR`]); the objective too when it is positive and spans a decade, else linearly. Each solve is
//! its own polyline; where a new one starts a dashed line marks it, labelled with its stage
//! ("round 2", "trial 3/8"). Numbers are printed with fixed precision, so the same records
//! give the same bytes.

use std::fmt::Write;

use super::result::solve_numbers;
use super::svg::escape;
use crate::outcome::readable;
use crate::solver::IterationRecord;

/// Smallest value a log panel shows; zeros and smaller values are drawn here.
pub const FLOOR: f64 = 1e-16;

const WIDTH: f64 = 760.0;
const LEFT: f64 = 80.0;
const RIGHT: f64 = 20.0;
const TOP: f64 = 48.0;
const PANEL: f64 = 170.0;
const GAP: f64 = 34.0;
const BOTTOM: f64 = 44.0;
const COLOURS: [&str; 3] = ["#1f5fa8", "#c0392b", "#2e7d32"];

/// How values map to a panel's height.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Axis {
    /// log₁₀ between two decades.
    Log { lo: f64, hi: f64 },
    /// Linear between two values.
    Linear { lo: f64, hi: f64 },
}

impl Axis {
    /// The axis for `values` (non-finite ones ignored); `log` asks for a log scale, used
    /// when every value is positive or `floor` allows zeros.
    fn fit(values: &[f64], log: bool, floor: bool) -> Axis {
        let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        let positive = finite.iter().all(|&v| v > 0.0);
        if log && (positive || floor) {
            let logs: Vec<f64> = finite.iter().map(|&v| v.max(FLOOR).log10()).collect();
            let lo = logs.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if lo.is_finite() {
                let (lo, hi) = (lo.floor(), hi.ceil());
                return Axis::Log {
                    lo,
                    hi: if hi > lo { hi } else { lo + 1.0 },
                };
            }
            return Axis::Log { lo: -1.0, hi: 1.0 };
        }
        let lo = finite.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !lo.is_finite() {
            return Axis::Linear { lo: 0.0, hi: 1.0 };
        }
        let pad = if hi > lo {
            0.05 * (hi - lo)
        } else {
            0.5 * lo.abs().max(1.0)
        };
        Axis::Linear {
            lo: lo - pad,
            hi: hi + pad,
        }
    }

    /// Position in [0, 1] (0 at the bottom) of a value.
    fn unit(&self, v: f64) -> f64 {
        match *self {
            Axis::Log { lo, hi } => (v.max(FLOOR).log10() - lo) / (hi - lo),
            Axis::Linear { lo, hi } => (v - lo) / (hi - lo),
        }
    }

    /// Tick values and their labels: every decade (at most 8 shown) or five linear steps.
    fn ticks(&self) -> Vec<(f64, String)> {
        match *self {
            Axis::Log { lo, hi } => {
                let step = ((hi - lo) / 8.0).ceil().max(1.0);
                let mut ticks = Vec::new();
                let mut e = lo;
                while e <= hi + 1e-9 {
                    ticks.push((10f64.powf(e), format!("1e{e:.0}")));
                    e += step;
                }
                ticks
            }
            Axis::Linear { lo, hi } => (0..=4)
                .map(|k| {
                    let v = lo + (hi - lo) * k as f64 / 4.0;
                    (v, readable(v, 5))
                })
                .collect(),
        }
    }
}

/// The plot of `log` for `problem`, the objective panel titled `objective` (e.g. "mass \[kg\]").
pub fn convergence_svg(problem: &str, objective: &str, log: &[IterationRecord]) -> String {
    let panels: [(String, Vec<f64>, Axis); 3] = {
        let column = |f: fn(&IterationRecord) -> f64| log.iter().map(f).collect::<Vec<f64>>();
        let (obj, inf, opt) = (
            column(|r| r.objective),
            column(|r| r.infeasibility),
            column(|r| r.optimality),
        );
        [
            (
                objective.to_string(),
                obj.clone(),
                Axis::fit(&obj, spans_a_decade(&obj), false),
            ),
            (
                "infeasibility".into(),
                inf.clone(),
                Axis::fit(&inf, true, true),
            ),
            (
                "optimality".into(),
                opt.clone(),
                Axis::fit(&opt, true, true),
            ),
        ]
    };
    let height = TOP + 3.0 * PANEL + 2.0 * GAP + BOTTOM;
    let plot_width = WIDTH - LEFT - RIGHT;
    let count = log.len().max(2);
    let x_of = |i: usize| LEFT + plot_width * i as f64 / (count - 1) as f64;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH:.0}" height="{height:.0}" viewBox="0 0 {WIDTH:.0} {height:.0}" font-family="sans-serif">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let solves = solve_numbers(log);
    let _ = writeln!(
        s,
        r#"<text x="{LEFT:.0}" y="22" font-size="15">{}: convergence ({} records, {} solve{})</text>"#,
        escape(problem),
        log.len(),
        solves.last().copied().unwrap_or(0),
        if solves.last() == Some(&1) { "" } else { "s" }
    );
    for (p, (title, values, axis)) in panels.iter().enumerate() {
        let top = TOP + p as f64 * (PANEL + GAP);
        let y_of = |v: f64| top + PANEL * (1.0 - axis.unit(v).clamp(0.0, 1.0));
        let _ = writeln!(
            s,
            r##"<rect x="{LEFT:.1}" y="{top:.1}" width="{plot_width:.1}" height="{PANEL:.1}" fill="none" stroke="#888"/>"##
        );
        let scale = match axis {
            Axis::Log { .. } => "log scale",
            Axis::Linear { .. } => "linear",
        };
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" font-size="12" fill="{}">{} ({scale})</text>"#,
            LEFT + 4.0,
            top - 5.0,
            COLOURS[p],
            escape(title)
        );
        for (v, label) in axis.ticks() {
            let y = y_of(v);
            let _ = writeln!(
                s,
                r##"<line x1="{LEFT:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" font-size="10" text-anchor="end">{label}</text>"##,
                LEFT + plot_width,
                LEFT - 4.0,
                y + 3.5
            );
        }
        // One polyline per solve.
        let mut start = 0;
        while start < log.len() {
            let end = (start..log.len())
                .find(|&i| solves[i] != solves[start])
                .unwrap_or(log.len());
            let points: Vec<String> = (start..end)
                .filter(|&i| values[i].is_finite())
                .map(|i| format!("{:.1},{:.1}", x_of(i), y_of(values[i])))
                .collect();
            if !points.is_empty() {
                let _ = writeln!(
                    s,
                    r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="1.5"/>"#,
                    points.join(" "),
                    COLOURS[p]
                );
            }
            start = end;
        }
    }
    // Solve boundaries, labelled with the stage, across all panels.
    let bottom = TOP + 3.0 * PANEL + 2.0 * GAP;
    for i in 0..log.len() {
        let first = i == 0 || solves[i] != solves[i - 1];
        if !first || (i == 0 && log[i].stage.is_empty()) {
            continue;
        }
        let x = x_of(i);
        if i > 0 {
            let _ = writeln!(
                s,
                r##"<line x1="{x:.1}" y1="{TOP:.1}" x2="{x:.1}" y2="{bottom:.1}" stroke="#555" stroke-dasharray="4 3"/>"##
            );
        }
        // The label is written where it fits before the next boundary (about 6 px a letter at
        // 10 px); the dashed line still marks a solve too short to name.
        let next = (i + 1..log.len()).find(|&j| solves[j] != solves[j - 1]);
        let room = next.map_or(LEFT + plot_width, x_of) - x;
        let fits = 6.0 * log[i].stage.chars().count() as f64 + 6.0 <= room;
        if !log[i].stage.is_empty() && fits {
            let _ = writeln!(
                s,
                r##"<text x="{:.1}" y="{:.1}" font-size="10" fill="#555">{}</text>"##,
                x + 3.0,
                TOP + 12.0,
                escape(&log[i].stage)
            );
        }
    }
    // Record numbers along the bottom.
    let step = (count as f64 / 8.0).ceil().max(1.0) as usize;
    for i in (0..log.len()).step_by(step) {
        let _ = writeln!(
            s,
            r##"<text x="{:.1}" y="{:.1}" font-size="10" text-anchor="middle">{i}</text>"##,
            x_of(i),
            bottom + 14.0
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" font-size="12" text-anchor="middle">iteration records of the run, in order (iteration numbers restart with each solve)</text>"#,
        LEFT + plot_width / 2.0,
        height - 14.0
    );
    s.push_str("</svg>\n");
    s
}

/// Whether the finite values are positive and their largest is at least ten times their
/// smallest (the objective is drawn on a log scale then, else linearly).
fn spans_a_decade(values: &[f64]) -> bool {
    let finite = values.iter().copied().filter(|v| v.is_finite());
    let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    lo > 0.0 && hi >= 10.0 * lo
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(stage: &str, iter: usize, objective: f64, infeasibility: f64) -> IterationRecord {
        IterationRecord {
            stage: stage.into(),
            iter,
            objective,
            infeasibility,
            optimality: 10f64.powi(-(iter as i32)),
            ..IterationRecord::default()
        }
    }

    #[test]
    fn each_solve_is_a_line_and_stages_are_marked() {
        let log = [
            rec("round 1", 0, 100.0, 1e-1),
            rec("round 1", 1, 50.0, 1e-3),
            rec("round 1", 2, 40.0, 0.0),
            rec("round 2", 0, 41.0, 1e-2),
            rec("round 2", 1, 39.0, 1e-9),
        ];
        let svg = convergence_svg("bridge", "mass [kg]", &log);
        // Two solves × three panels.
        assert_eq!(svg.matches("<polyline").count(), 6);
        assert_eq!(svg.matches("stroke-dasharray").count(), 1);
        assert!(svg.contains(">round 1<") && svg.contains(">round 2<"));
        // A last solve of one record among many has no room for its name.
        let mut long: Vec<IterationRecord> = (0..60).map(|k| rec("round 1", k, 1.0, 0.0)).collect();
        long.push(rec("round 2", 0, 1.0, 0.0));
        let svg_long = convergence_svg("bridge", "mass [kg]", &long);
        assert!(svg_long.contains(">round 1<") && !svg_long.contains(">round 2<"));
        assert_eq!(svg_long.matches("stroke-dasharray").count(), 1);
        assert!(svg.contains("mass [kg] (linear)"));
        assert!(svg.contains("5 records, 2 solves"));
        assert_eq!(svg, convergence_svg("bridge", "mass [kg]", &log));
    }

    #[test]
    fn axes_cover_their_values() {
        let a = Axis::fit(&[3e-7, 0.0, 2.0], true, true);
        assert_eq!(a, Axis::Log { lo: -16.0, hi: 1.0 });
        assert!(a.unit(2.0) <= 1.0 && a.unit(0.0) == 0.0);
        // A negative objective is drawn linearly.
        let b = Axis::fit(&[-5.0, 1.0, f64::NAN], true, false);
        assert!(matches!(b, Axis::Linear { lo, hi } if lo < -5.0 && hi > 1.0));
        assert!(b.ticks().len() == 5);
    }
}
