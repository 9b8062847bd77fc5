//! The `optimize` command line: parse, run, write, and map the outcome to an exit code
//! (README: 0 converged, 1 runtime failure, 2 usage or problem-file error, 3 not converged,
//! 130 interrupted).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use optimize::cli::Cli;
use optimize::io::atomic::CHECK_FOLDER;
use optimize::outcome::Outcome;
use optimize::run::execute;

fn main() -> ExitCode {
    let cli = Cli::parse();
    let (kind, common, opts) = cli.command.resolve();
    if let Some(n) = opts.threads
        && let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
    {
        eprintln!("error: cannot start {n} worker threads: {e}");
        return ExitCode::from(1);
    }
    // First Ctrl-C: raise the run's interrupt flag; whatever is running stops at its next
    // poll and the best point so far is written. Second Ctrl-C: leave at once.
    let interrupt = opts.interrupt.clone();
    let _ = ctrlc::set_handler(move || {
        if interrupt.raise() {
            std::process::exit(130);
        }
    });

    let (name, outcome) = match execute(kind, &common.file, &opts) {
        Ok(done) => done,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(e.exit_code());
        }
    };
    let mut dir = opts
        .out_dir
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&name));
    if opts.check {
        // A check never touches the solved run beside it.
        dir.push(CHECK_FOLDER);
    }
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
