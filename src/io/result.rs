//! The files every run writes besides the module's own: `result.json` (the summary) and
//! `iterations.csv` (the solver log), plus a tiny CSV builder modules use for their tables.

use std::fmt::Write;

use crate::outcome::{Artifact, ResultSummary};
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

/// `iterations.csv`: one row per solver iteration (or `file_name` for several solves).
pub fn iterations_csv(file_name: &str, log: &[IterationRecord]) -> Artifact {
    let mut csv = Csv::new(&[
        "iter",
        "objective",
        "infeasibility",
        "optimality",
        "step",
        "merit",
        "qp_iterations",
        "elapsed_s",
    ]);
    for r in log {
        csv.row([
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

#[cfg(test)]
mod tests {
    use super::*;

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
