//! The live iteration log: a header and one line per major iteration, in the style of IPOPT.
//! Columns: iteration, objective (unscaled), infeasibility (largest unscaled bound or
//! constraint violation), optimality (scaled dual residual), accepted step length α,
//! merit value (scaled ℓ1 penalty function), QP iterations, elapsed seconds.
//! The writer is a parameter so tests can capture the output.
//!
//! [`LiveLog`] decides what reaches the terminal. Verbosity 0: nothing. Verbosity ≥ 2, or
//! stderr not a terminal (CI, redirection): every line. Verbosity 1 on a terminal: every line
//! during the first [`PROGRESS_AFTER`] seconds; a longer solve then switches to one status
//! line rewritten in place (iteration, objective, infeasibility, optimality, elapsed) at most
//! every [`PROGRESS_INTERVAL`] seconds, removed again before any message and replaced by the
//! last iteration's full line at the end. The complete log is kept in the solution either
//! way (and written to iterations.csv by the CLI).

use std::io::Write;

use super::IterationRecord;

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
    /// The log on stderr, in status-line mode when stderr is a terminal.
    pub fn stderr(verbosity: u8) -> Self {
        use std::io::IsTerminal;
        let terminal = std::io::stderr().is_terminal();
        LiveLog::new(Box::new(std::io::stderr()), verbosity, terminal)
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
    use std::sync::{Arc, Mutex};

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
