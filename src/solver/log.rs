//! The live iteration log: a header and one line per major iteration, in the style of IPOPT.
//! Columns: iteration, objective (unscaled), infeasibility (largest unscaled bound or
//! constraint violation), optimality (scaled dual residual), accepted step length α,
//! merit value (scaled ℓ1 penalty function), QP iterations, elapsed seconds.
//! The writer is a parameter so tests can capture the output.

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

#[cfg(test)]
mod tests {
    use super::*;

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
