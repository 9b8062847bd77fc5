//! The files every run writes besides the module's own: `result.json` (the summary) and
//! `iterations.csv` (the solver log), plus a tiny CSV builder modules use for their tables.

use std::fmt::Write;

use crate::outcome::{Artifact, Headline, ResultSummary};
use crate::solver::IterationRecord;

/// `result.json`: the summary, pretty-printed.
pub fn summary_json(summary: &ResultSummary) -> Artifact {
    let mut bytes = serde_json::to_vec_pretty(summary).unwrap_or_else(|e| {
        // Serializing plain data cannot fail except for non-finite floats, which serde_json
        // writes as null; keep the error visible rather than panicking.
        format!("{{\"error\": \"{e}\"}}").into_bytes()
    });
    bytes.push(b'\n');
    Artifact {
        name: "result.json".into(),
        bytes,
    }
}

/// A CSV table: a header and rows of cells; cells containing commas or quotes are quoted.
#[derive(Debug, Clone, Default)]
pub struct Csv {
    text: String,
}

impl Csv {
    /// A table with the given column names.
    pub fn new(header: &[&str]) -> Self {
        let mut csv = Csv::default();
        csv.row(header.iter().map(|s| s.to_string()));
        csv
    }

    /// Appends a row.
    pub fn row<I: IntoIterator<Item = String>>(&mut self, cells: I) {
        let cells: Vec<String> = cells
            .into_iter()
            .map(|c| {
                if c.contains([',', '"', '\n']) {
                    format!("\"{}\"", c.replace('"', "\"\""))
                } else {
                    c
                }
            })
            .collect();
        let _ = writeln!(self.text, "{}", cells.join(","));
    }

    /// The finished file.
    pub fn into_artifact(self, name: &str) -> Artifact {
        Artifact {
            name: name.to_string(),
            bytes: self.text.into_bytes(),
        }
    }
}

/// Formats a number for CSV: shortest round-trip representation.
pub fn num(v: f64) -> String {
    format!("{v:e}")
}

/// `iterations.csv`: one row per solver iteration of every solve of the run, in order.
/// `solve` numbers the solves from 1 (a new one starts where the stage changes or the
/// iteration count does not increase); `stage` is the solve's label ("round 2", "trial 3/8",
/// empty for a lone solve); `objective` is in the run's shown unit (result.json `headline`).
pub fn iterations_csv(file_name: &str, log: &[IterationRecord]) -> Artifact {
    let mut csv = Csv::new(&[
        "solve",
        "stage",
        "iter",
        "objective",
        "infeasibility",
        "optimality",
        "step",
        "merit",
        "qp_iterations",
        "elapsed_s",
    ]);
    for (r, solve) in log.iter().zip(solve_numbers(log)) {
        csv.row([
            solve.to_string(),
            r.stage.clone(),
            r.iter.to_string(),
            num(r.objective),
            num(r.infeasibility),
            num(r.optimality),
            num(r.step),
            num(r.merit),
            r.qp_iterations.to_string(),
            format!("{:.6}", r.elapsed),
        ]);
    }
    csv.into_artifact(file_name)
}

/// The run's iteration files: `iterations.csv` and `convergence.svg` (see [`super::plot`]),
/// the objective panel named after the headline ("mass \[kg\]").
pub fn iteration_files(
    problem: &str,
    headline: &Headline,
    log: &[IterationRecord],
) -> [Artifact; 2] {
    let title = if headline.unit.is_empty() {
        headline.name.clone()
    } else {
        format!("{} [{}]", headline.name, headline.unit)
    };
    [
        iterations_csv("iterations.csv", log),
        Artifact {
            name: "convergence.svg".into(),
            bytes: super::plot::convergence_svg(problem, &title, log).into_bytes(),
        },
    ]
}

/// The 1-based solve each record of a concatenated log belongs to: a new solve starts where
/// the stage label changes or the iteration number does not increase.
pub fn solve_numbers(log: &[IterationRecord]) -> Vec<usize> {
    let mut numbers = Vec::with_capacity(log.len());
    let mut solve = 0;
    let mut previous: Option<&IterationRecord> = None;
    for r in log {
        if previous.is_none_or(|p| p.stage != r.stage || r.iter <= p.iter) {
            solve += 1;
        }
        numbers.push(solve);
        previous = Some(r);
    }
    numbers
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn concatenated_logs_number_their_solves() {
        let rec = |stage: &str, iter| IterationRecord {
            stage: stage.into(),
            iter,
            ..IterationRecord::default()
        };
        let log = [
            rec("", 0),
            rec("", 1),
            rec("", 0),
            rec("round 2", 3),
            rec("round 2", 4),
        ];
        assert_eq!(solve_numbers(&log), [1, 1, 2, 3, 3]);
        let text = String::from_utf8(iterations_csv("i.csv", &log).bytes).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert!(lines[0].starts_with("solve,stage,iter,objective,"));
        assert!(lines[4].starts_with("3,round 2,3,"), "{}", lines[4]);
    }

    #[test]
    fn csv_quotes_awkward_cells_and_numbers_round_trip() {
        let mut csv = Csv::new(&["a", "b"]);
        csv.row(["x,y".to_string(), "say \"hi\"".to_string()]);
        let text = String::from_utf8(csv.into_artifact("t.csv").bytes).unwrap();
        assert_eq!(text, "a,b\n\"x,y\",\"say \"\"hi\"\"\"\n");
        let v = 0.1 + 0.2;
        assert_eq!(num(v).parse::<f64>().unwrap(), v);
    }
}
