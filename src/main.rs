//! The `optimize` command line: parse, run, write, and map the outcome to an exit code
//! (README: 0 converged, 1 runtime failure, 2 usage or problem-file error, 3 not converged,
//! 130 interrupted).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::Parser;
use optimize::cli::Cli;
use optimize::run::{Outcome, execute};

fn main() -> ExitCode {
    let cli = Cli::parse();
    let (kind, common, mut opts) = cli.command.resolve();
    if let Some(n) = opts.threads
        && let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
    {
        eprintln!("error: cannot start {n} worker threads: {e}");
        return ExitCode::from(1);
    }
    // First Ctrl-C: stop after the current iteration and write the best point so far.
    // Second Ctrl-C: leave at once.
    let interrupt = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&interrupt);
    let _ = ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    });
    opts.interrupt = Some(interrupt);

    let (name, outcome) = match execute(kind, &common.file, &opts) {
        Ok(done) => done,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(e.exit_code());
        }
    };
    let dir = opts
        .out_dir
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&name));
    let written = match optimize::io::write_outcome(&dir, &outcome) {
        Ok(paths) => paths,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(e.exit_code());
        }
    };
    if common.json {
        match serde_json::to_string_pretty(&outcome.summary) {
            Ok(text) => println!("{text}"),
            Err(e) => eprintln!("error: cannot print the summary: {e}"),
        }
    } else if !opts.quiet {
        report(&outcome, &written);
    }
    ExitCode::from(outcome.exit_code())
}

/// A short human summary on stdout.
fn report(outcome: &Outcome, written: &[PathBuf]) {
    let s = &outcome.summary;
    println!("{} ({}): {}", s.problem, s.kind, s.status_message);
    if outcome.check_passed.is_none() {
        println!(
            "objective {:.9e}   max violation {:.2e}   iterations {}   time {:.2} s",
            s.objective,
            s.max_violation,
            s.iterations,
            s.timings.values().sum::<f64>()
        );
    }
    if let Some(dir) = written.first().and_then(|p| p.parent()) {
        let names: Vec<String> = written
            .iter()
            .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
            .collect();
        println!("wrote {}: {}", dir.display(), names.join(", "));
    }
}
