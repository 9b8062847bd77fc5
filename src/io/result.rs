//! The files every run writes besides the module's own: `result.json` (the summary) and
//! `iterations.csv` (the solver log), plus a tiny CSV builder modules use for their tables.

use std::fmt::Write;
use std::io;

use serde::Serialize;
use serde_json::ser::{CompactFormatter, Formatter};

use crate::outcome::{Artifact, Headline, ResultSummary};
use crate::solver::IterationRecord;

/// `result.json`: the summary, pretty-printed (`Layout`: two-space indents, each array of
/// plain values on one line, so a mesh's vertices go one `[x, y, z]` per line).
pub fn summary_json(summary: &ResultSummary) -> Artifact {
    let mut bytes = Vec::new();
    let mut serializer = serde_json::Serializer::with_formatter(&mut bytes, Layout::default());
    if let Err(e) = summary.serialize(&mut serializer) {
        // Serializing plain data cannot fail except for non-finite floats, which serde_json
        // writes as null; keep the error visible rather than panicking.
        bytes = format!("{{\"error\": \"{e}\"}}").into_bytes();
    }
    bytes.push(b'\n');
    Artifact {
        name: "result.json".into(),
        bytes,
    }
}

/// serde_json's pretty layout (objects one member per line, two-space indents) except that an
/// array whose first element is a plain value (number, string, boolean, null) is written on
/// one line, `[a, b, c]`; an array of arrays or objects keeps one element per line. An
/// array's separator is written when its next element starts, once its kind is known.
#[derive(Debug, Default)]
struct Layout {
    /// The open containers, innermost last: an array's layout once known (Some(true): one
    /// element per line), None for an object.
    open: Vec<Option<Option<bool>>>,
    /// Whether anything was written in the innermost container.
    has_value: bool,
    /// An array element is due: whether it is the array's first.
    due: Option<bool>,
}

impl Layout {
    /// A line break and the indentation of the innermost container's members.
    fn break_line<W: ?Sized + io::Write>(&self, w: &mut W, depth: usize) -> io::Result<()> {
        w.write_all(b"\n")?;
        (0..depth).try_for_each(|_| w.write_all(b"  "))
    }

    /// Writes the separator of a due array element, `container` telling its kind.
    fn element<W: ?Sized + io::Write>(&mut self, w: &mut W, container: bool) -> io::Result<()> {
        let Some(first) = self.due.take() else {
            return Ok(());
        };
        let depth = self.open.len();
        let lines = match self.open.last_mut() {
            Some(Some(layout)) => *layout.get_or_insert(container),
            _ => container,
        };
        if !first {
            w.write_all(if lines { b"," } else { b", " })?;
        }
        if lines {
            self.break_line(w, depth)?;
        }
        Ok(())
    }

    /// Opens a container with `bracket`; `frame` is its entry in `open`.
    fn begin<W: ?Sized + io::Write>(
        &mut self,
        w: &mut W,
        frame: Option<Option<bool>>,
        bracket: &[u8],
    ) -> io::Result<()> {
        self.element(w, true)?;
        self.open.push(frame);
        self.has_value = false;
        w.write_all(bracket)
    }

    /// Closes the innermost container with `bracket`, on a line of its own after members
    /// written one per line (an object's, or an array's of containers).
    fn end<W: ?Sized + io::Write>(&mut self, w: &mut W, bracket: &[u8]) -> io::Result<()> {
        let lines = !matches!(self.open.pop(), Some(Some(Some(false) | None)));
        if lines && self.has_value {
            self.break_line(w, self.open.len())?;
        }
        w.write_all(bracket)
    }

    /// Writes a due array element's separator before a plain value.
    fn plain<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.element(w, false)
    }
}

/// Forwards plain-value writers to serde_json's compact defaults after [`Layout::plain`].
macro_rules! plain_values {
    ($($name:ident($t:ty)),*) => {$(
        fn $name<W: ?Sized + io::Write>(&mut self, w: &mut W, value: $t) -> io::Result<()> {
            self.plain(w)?;
            CompactFormatter.$name(w, value)
        }
    )*};
}

impl Formatter for Layout {
    plain_values!(
        write_bool(bool),
        write_i8(i8),
        write_i16(i16),
        write_i32(i32),
        write_i64(i64),
        write_i128(i128),
        write_u8(u8),
        write_u16(u16),
        write_u32(u32),
        write_u64(u64),
        write_u128(u128),
        write_f32(f32),
        write_f64(f64),
        write_number_str(&str),
        write_byte_array(&[u8]),
        write_raw_fragment(&str)
    );

    fn write_null<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.plain(w)?;
        w.write_all(b"null")
    }

    fn begin_string<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.plain(w)?;
        w.write_all(b"\"")
    }

    fn begin_array<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.begin(w, Some(None), b"[")
    }

    fn end_array<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.end(w, b"]")
    }

    fn begin_array_value<W: ?Sized + io::Write>(
        &mut self,
        _: &mut W,
        first: bool,
    ) -> io::Result<()> {
        self.due = Some(first);
        Ok(())
    }

    fn end_array_value<W: ?Sized + io::Write>(&mut self, _: &mut W) -> io::Result<()> {
        self.has_value = true;
        Ok(())
    }

    fn begin_object<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.begin(w, None, b"{")
    }

    fn end_object<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.end(w, b"}")
    }

    fn begin_object_key<W: ?Sized + io::Write>(
        &mut self,
        w: &mut W,
        first: bool,
    ) -> io::Result<()> {
        if !first {
            w.write_all(b",")?;
        }
        self.break_line(w, self.open.len())
    }

    fn begin_object_value<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        w.write_all(b": ")
    }

    fn end_object_value<W: ?Sized + io::Write>(&mut self, _: &mut W) -> io::Result<()> {
        self.has_value = true;
        Ok(())
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
    fn plain_arrays_go_on_one_line_and_the_value_is_unchanged() {
        let value = serde_json::json!({
            "mesh": {"vertices": [[1.5, -2.0, 3e-7], [0, 1, 2]], "surface": [0, 1, 1]},
            "text": ["a, \"[b]\"", "c\\"],
            "empty": [],
            "nested": [{"k": [1, 2]}, [true, null]],
        });
        let mut bytes = Vec::new();
        value
            .serialize(&mut serde_json::Serializer::with_formatter(
                &mut bytes,
                Layout::default(),
            ))
            .unwrap();
        let text = String::from_utf8(bytes).unwrap();
        assert_eq!(
            serde_json::from_str::<serde_json::Value>(&text).unwrap(),
            value
        );
        for line in [
            "\"surface\": [0, 1, 1]",
            "    [1.5, -2.0, 3e-7],",
            "\"text\": [\"a, \\\"[b]\\\"\", \"c\\\\\"]",
            "\"empty\": []",
            "\"k\": [1, 2]",
            "    [true, null]",
        ] {
            assert!(text.contains(line), "{line} in {text}");
        }
        assert!(text.contains("\"nested\": [\n    {"), "{text}");
    }

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
