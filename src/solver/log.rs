//! The live iteration log: a header and one line per major iteration, in the style of IPOPT.
//! Columns: iteration, objective (in the caller's unit, see [`ObjectiveUnit`]), infeasibility
//! (largest unscaled bound or constraint violation), optimality (scaled dual residual),
//! accepted step length α, merit value (scaled ℓ1 penalty function), QP iterations, elapsed
//! seconds.
//!
//! The solver never writes to stderr itself: [`LogTarget`] says where the text goes (a shared
//! writer, as Clarabel's print target), who is told of each iteration (an [`Observer`], as in
//! argmin), how the objective is shown and which stage of a longer run the solve is ("round
//! 2", "trial 3/8"). The default target writes nothing; the command line passes stderr.
//!
//! [`LiveLog`] decides what reaches the writer. Verbosity 0: nothing. Verbosity ≥ 2, or a
//! writer that is not a terminal (CI, redirection, a buffer): every line. Verbosity 1 on a
//! terminal: every line during the first [`PROGRESS_AFTER`] seconds; a longer solve then
//! switches to one status line rewritten in place (iteration, objective, infeasibility,
//! optimality, elapsed) at most every [`PROGRESS_INTERVAL`] seconds, removed again before any
//! message and replaced by the last iteration's full line at the end. The complete log is kept
//! in the solution either way (and written to iterations.csv by the modules).

use std::fmt;
use std::io::Write;
use std::sync::{Arc, Mutex};

use super::{Dims, IterationRecord};

/// A writer several solves (and threads) can share; each write locks it.
pub type SharedWriter = Arc<Mutex<dyn Write + Send>>;

/// How the objective is shown to people: `shown = scale · f`, in `unit`, under `name`. The
/// solver scales problems internally and undoes that itself; `scale` undoes what the *model*
/// did (a truss NLP's objective is mass / M, a cmc NLP's is area / L²).
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectiveUnit {
    /// What the objective is, e.g. "mass".
    pub name: String,
    /// Its unit, e.g. "kg" (empty for dimensionless).
    pub unit: String,
    /// Factor from the NLP's objective to the shown value.
    pub scale: f64,
}

impl Default for ObjectiveUnit {
    fn default() -> Self {
        ObjectiveUnit {
            name: "objective".into(),
            unit: String::new(),
            scale: 1.0,
        }
    }
}

impl ObjectiveUnit {
    /// A named objective shown as `scale · f` in `unit`.
    pub fn new(name: &str, unit: &str, scale: f64) -> Self {
        ObjectiveUnit {
            name: name.into(),
            unit: unit.into(),
            scale,
        }
    }
}

/// Told of every iteration as the solver records it (after the line is logged).
pub trait Observer: Send + Sync {
    /// One iteration's record (objective already in the shown unit, `stage` filled in).
    fn observe(&self, record: &IterationRecord);
}

/// Where a solve's log goes and who watches it (see the module header). `Default`: nowhere.
#[derive(Clone, Default)]
pub struct LogTarget {
    /// The text log's destination; `None` writes nothing.
    pub out: Option<SharedWriter>,
    /// Whether `out` is a terminal (enables the status line).
    pub terminal: bool,
    /// Told of every iteration.
    pub observer: Option<Arc<dyn Observer>>,
    /// How the objective is shown (log lines, records, iterations.csv).
    pub objective: ObjectiveUnit,
    /// The stage of a longer run this solve is, e.g. "round 2"; stamped on every record.
    pub stage: String,
}

impl fmt::Debug for LogTarget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LogTarget")
            .field("out", &self.out.as_ref().map(|_| "writer"))
            .field("terminal", &self.terminal)
            .field("observer", &self.observer.as_ref().map(|_| "observer"))
            .field("objective", &self.objective)
            .field("stage", &self.stage)
            .finish()
    }
}

impl LogTarget {
    /// A target writing to `out` (`terminal`: whether it is one).
    pub fn to(out: SharedWriter, terminal: bool) -> Self {
        LogTarget {
            out: Some(out),
            terminal,
            ..LogTarget::default()
        }
    }

    /// The same target for another stage of the run.
    pub fn with_stage(&self, stage: impl Into<String>) -> Self {
        LogTarget {
            stage: stage.into(),
            ..self.clone()
        }
    }

    /// The same target showing the objective as `objective`.
    pub fn with_objective(&self, objective: ObjectiveUnit) -> Self {
        LogTarget {
            objective,
            ..self.clone()
        }
    }

    /// Writes `text` and a line end (nothing without a writer; write errors are ignored: a
    /// closed log must not stop a solve).
    pub fn line(&self, text: &str) {
        if let Some(out) = &self.out
            && let Ok(mut w) = out.lock()
        {
            let _ = writeln!(w, "{text}");
            let _ = w.flush();
        }
    }

    /// Writes `text` as it is (status lines carry their own `\r`).
    pub fn raw(&self, text: &str) {
        if let Some(out) = &self.out
            && let Ok(mut w) = out.lock()
        {
            let _ = write!(w, "{text}");
            let _ = w.flush();
        }
    }
}

/// An in-memory log (one per parallel trial, printed in order afterwards): the writer to hand
/// to a [`LogTarget`] and the handle to read it back.
#[derive(Clone, Default)]
pub struct Buffer(Arc<Mutex<Vec<u8>>>);

impl Buffer {
    /// The writer side.
    pub fn writer(&self) -> SharedWriter {
        self.0.clone()
    }

    /// Everything written so far.
    pub fn text(&self) -> String {
        self.0
            .lock()
            .map(|b| String::from_utf8_lossy(&b).into_owned())
            .unwrap_or_default()
    }
}

/// The problem's size, said once before the first iteration: variables, constraints,
/// Jacobian nonzeros, Hessian mode and QP path.
pub fn size_line(dims: &Dims, hessian: &str, qp: &str) -> String {
    format!(
        "{} variables, {} constraints, {} Jacobian nonzeros; Hessian: {hessian}; QP: {qp}",
        dims.n, dims.m, dims.jac_nnz
    )
}

/// Writes the column header.
pub fn write_header(out: &mut dyn Write) -> std::io::Result<()> {
    writeln!(
        out,
        "{:>5} {:>15} {:>10} {:>10} {:>9} {:>15} {:>5} {:>9}",
        "iter", "objective", "infeas", "optimal", "step", "merit", "qp", "time[s]"
    )
}

/// Writes one record as a line.
pub fn write_record(out: &mut dyn Write, r: &IterationRecord) -> std::io::Result<()> {
    writeln!(
        out,
        "{:>5} {:>15.8e} {:>10.3e} {:>10.3e} {:>9.2e} {:>15.8e} {:>5} {:>9.3}",
        r.iter,
        r.objective,
        r.infeasibility,
        r.optimality,
        r.step,
        r.merit,
        r.qp_iterations,
        r.elapsed
    )
}

/// A [`SharedWriter`] as a plain writer (each call locks it).
struct Locked(SharedWriter);

impl Write for Locked {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self.0.lock() {
            Ok(mut w) => w.write(buf),
            Err(_) => Ok(buf.len()),
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        match self.0.lock() {
            Ok(mut w) => w.flush(),
            Err(_) => Ok(()),
        }
    }
}

/// Seconds after which a verbosity-1 solve on a terminal switches to the status line.
pub const PROGRESS_AFTER: f64 = 2.0;
/// Least seconds between two redraws of the status line.
pub const PROGRESS_INTERVAL: f64 = 0.25;

/// The iteration log of one solve as shown live (see the module header).
pub struct LiveLog {
    out: Box<dyn Write>,
    verbosity: u8,
    /// Whether status-line mode is possible (stderr is a terminal).
    terminal: bool,
    /// Elapsed time of the last status-line redraw, when the status line is showing.
    status_drawn: Option<f64>,
    /// The last record, printed in full when the status line is taken down at the end.
    last: Option<IterationRecord>,
}

impl LiveLog {
    /// The log of a solve on `target`'s writer (silent without one).
    pub fn on(target: &LogTarget, verbosity: u8) -> Self {
        match &target.out {
            Some(out) => LiveLog::new(Box::new(Locked(out.clone())), verbosity, target.terminal),
            None => LiveLog::new(Box::new(std::io::sink()), 0, false),
        }
    }

    /// The log on any writer; `terminal` enables the status line.
    pub fn new(out: Box<dyn Write>, verbosity: u8, terminal: bool) -> Self {
        LiveLog {
            out,
            verbosity,
            terminal,
            status_drawn: None,
            last: None,
        }
    }

    /// The column header.
    pub fn header(&mut self) {
        if self.verbosity >= 1 {
            let _ = write_header(&mut self.out);
        }
    }

    /// One iteration: a full line, or the status line once the solve runs long.
    pub fn record(&mut self, r: &IterationRecord) {
        if self.verbosity == 0 {
            return;
        }
        let status_mode = self.terminal && self.verbosity == 1 && r.elapsed >= PROGRESS_AFTER;
        if !status_mode {
            let _ = write_record(&mut self.out, r);
            return;
        }
        self.last = Some(r.clone());
        if self
            .status_drawn
            .is_some_and(|t| r.elapsed - t < PROGRESS_INTERVAL)
        {
            return;
        }
        let _ = write!(
            self.out,
            "\r\x1b[2K  iteration {}  objective {:.8e}  infeasibility {:.2e}  optimality {:.2e}  {:.1} s",
            r.iter, r.objective, r.infeasibility, r.optimality, r.elapsed
        );
        let _ = self.out.flush();
        self.status_drawn = Some(r.elapsed);
    }

    /// A message on a line of its own (the status line is taken down first).
    pub fn message(&mut self, text: &str) {
        if self.verbosity == 0 {
            return;
        }
        self.take_down_status();
        let _ = writeln!(self.out, "{text}");
    }

    /// Ends status-line mode: clears the line and prints the last record in full.
    pub fn take_down_status(&mut self) {
        if self.status_drawn.take().is_some() {
            let _ = write!(self.out, "\r\x1b[2K");
            if let Some(r) = self.last.take() {
                let _ = write_record(&mut self.out, &r);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A writer whose contents the test can read afterwards.
    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);

    impl Write for Shared {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    fn record(iter: usize, elapsed: f64) -> IterationRecord {
        IterationRecord {
            iter,
            objective: 1.0,
            infeasibility: 0.0,
            optimality: 1e-3,
            step: 1.0,
            merit: 1.0,
            qp_iterations: 1,
            elapsed,
            stage: String::new(),
        }
    }

    /// Runs 40 iterations 0.1 s apart (4 s in all), then a message.
    fn run(verbosity: u8, terminal: bool) -> String {
        let buf = Shared::default();
        let mut log = LiveLog::new(Box::new(buf.clone()), verbosity, terminal);
        log.header();
        for k in 0..40 {
            log.record(&record(k, 0.1 * k as f64));
        }
        log.message("done");
        String::from_utf8(buf.0.lock().unwrap().clone()).unwrap()
    }

    #[test]
    fn long_solves_on_a_terminal_switch_to_one_status_line() {
        let text = run(1, true);
        // Full lines for iterations 0..=19 (before 2 s), then status redraws every ≥ 0.25 s.
        let full_lines = text
            .lines()
            .filter(|l| l.ends_with(|c: char| c.is_ascii_digit()) && !l.contains('\r'))
            .count();
        let redraws = text.matches("\r\x1b[2K  iteration").count();
        assert_eq!(redraws, 7, "{text:?}");
        assert!(full_lines >= 20);
        // The status line is taken down and the last iteration printed in full before "done".
        let tail: Vec<&str> = text.rsplit('\n').take(3).collect();
        assert_eq!(tail[1], "done");
        let last = tail[2].rsplit("\x1b[2K").next().unwrap();
        assert!(last.trim_start().starts_with("39 "), "{tail:?}");
    }

    #[test]
    fn pipes_and_verbose_runs_get_every_line_and_quiet_runs_nothing() {
        for (verbosity, terminal) in [(1, false), (2, true)] {
            let text = run(verbosity, terminal);
            assert!(!text.contains('\r'));
            assert_eq!(text.lines().count(), 1 + 40 + 1);
        }
        assert!(run(0, true).is_empty());
    }

    /// min (x − 3)² s.t. x ≤ 2, shown ×10 in "g".
    struct Clamped;

    impl crate::solver::Nlp for Clamped {
        fn dims(&self) -> Dims {
            Dims {
                n: 1,
                m: 1,
                jac_nnz: 1,
                hess_nnz: 0,
            }
        }
        fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
            (xl[0], xu[0], cl[0], cu[0]) = (-10.0, 10.0, f64::NEG_INFINITY, 2.0);
        }
        fn start(&self, x: &mut [f64]) {
            x[0] = 0.0;
        }
        fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
            (rows[0], cols[0]) = (0, 0);
        }
        fn eval(
            &self,
            x: &[f64],
            f: &mut f64,
            c: &mut [f64],
        ) -> Result<(), crate::solver::EvalError> {
            *f = (x[0] - 3.0).powi(2);
            c[0] = x[0];
            Ok(())
        }
        fn eval_derivatives(
            &self,
            x: &[f64],
            g: &mut [f64],
            jac: &mut [f64],
        ) -> Result<(), crate::solver::EvalError> {
            g[0] = 2.0 * (x[0] - 3.0);
            jac[0] = 1.0;
            Ok(())
        }
    }

    /// Counts the records it is told of.
    #[derive(Default)]
    struct Count(Mutex<Vec<IterationRecord>>);

    impl Observer for Count {
        fn observe(&self, record: &IterationRecord) {
            self.0.lock().unwrap().push(record.clone());
        }
    }

    #[test]
    fn a_solve_logs_to_its_target_in_the_shown_unit_and_tells_the_observer() {
        let buffer = Buffer::default();
        let count = Arc::new(Count::default());
        let log = LogTarget {
            observer: Some(count.clone()),
            ..LogTarget::to(buffer.writer(), false)
        };
        let mut options = crate::solver::Options {
            log: log
                .with_objective(ObjectiveUnit::new("mass", "g", 10.0))
                .with_stage("round 2"),
            ..crate::solver::Options::default()
        };
        let solution = crate::solver::solve(&Clamped, &options);
        assert!(solution.status.is_success());
        assert!((solution.objective - 1.0).abs() < 1e-6);
        let last = solution.log.last().unwrap();
        assert!((last.objective - 10.0).abs() < 1e-5, "{last:?}");
        assert!(solution.log.iter().all(|r| r.stage == "round 2"));
        assert_eq!(*count.0.lock().unwrap(), solution.log);
        let text = buffer.text();
        let first = text.lines().next().unwrap();
        assert_eq!(
            first,
            "round 2: 1 variables, 1 constraints, 1 Jacobian nonzeros; Hessian: dense BFGS; \
             QP: dense active set"
        );
        assert!(text.contains("Optimal"), "{text}");
        // No writer: nothing is written anywhere, the records are still kept.
        options.log.out = None;
        assert_eq!(
            crate::solver::solve(&Clamped, &options).log.len(),
            solution.log.len()
        );
    }

    #[test]
    fn header_and_record_line_up() {
        let mut buf = Vec::new();
        write_header(&mut buf).unwrap();
        let r = IterationRecord {
            iter: 3,
            objective: -1.5,
            infeasibility: 2e-7,
            optimality: 1e-3,
            step: 1.0,
            merit: -1.4,
            qp_iterations: 4,
            elapsed: 0.25,
            stage: String::new(),
        };
        write_record(&mut buf, &r).unwrap();
        let text = String::from_utf8(buf).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 2);
        assert_eq!(lines[0].len(), lines[1].len());
        assert!(lines[1].trim_start().starts_with('3'));
        assert!(lines[0].contains("merit"));
    }
}
