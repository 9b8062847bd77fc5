//! The `optimize` command line: parse, run, write, and map the outcome to an exit code
//! (README: 0 converged, 1 runtime failure, 2 usage or problem-file error, 3 not converged,
//! 130 interrupted).

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::{Arc, Mutex};

use clap::{CommandFactory, FromArgMatches};
use optimize::cli::Cli;
use optimize::io::atomic::CHECK_FOLDER;
use optimize::outcome::Outcome;
use optimize::run::execute;
use optimize::solver::log::LogTarget;

/// Asks glibc's allocator to keep freed memory for reuse instead of returning it to the kernel.
///
/// The solvers free and allocate matrices of the same few sizes every iteration (a dense SQP
/// iteration on a 113-variable truss: the Hessian, its trial factors, the row basis, the QP's
/// J and R, about 100 KB each). By default glibc gives the top of the heap back to the kernel
/// once 128 KB are free there, and serves blocks above a threshold that starts at 128 KB by
/// `mmap`, so the next iteration's matrices come back as fresh pages the kernel must fault in
/// and zero. Measured (2026-11-29, `pier_cantilever_linear.toml`, one core, 60 runs of each
/// binary interleaved): 1,447 → 762 page faults per run, median CPU (user + system) 71.9 →
/// 69.1 ms, the same results. The trim threshold of 256 MiB bounds the memory kept; blocks
/// above 32 MiB (glibc's largest `mmap` threshold) are still mapped and unmapped one by one.
/// Other platforms keep their allocator's defaults.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn keep_freed_memory() {
    // glibc's <malloc.h>: M_TRIM_THRESHOLD = -1, M_MMAP_THRESHOLD = -3.
    unsafe extern "C" {
        fn mallopt(param: i32, value: i32) -> i32;
    }
    // SAFETY: mallopt only sets allocator parameters; it is called before any other thread
    // exists, and an unaccepted value leaves the default in place (its return value says so,
    // which changes nothing here).
    unsafe {
        mallopt(-1, 256 << 20);
        mallopt(-3, 32 << 20);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn keep_freed_memory() {}

/// `optimize --version`: the package version and the commit it was built from (build.rs). Kept in
/// the binary so a new commit recompiles only this file, not the library.
const VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (commit ",
    env!("OPTIMIZE_COMMIT"),
    ")"
);

fn main() -> ExitCode {
    keep_freed_memory();
    let matches = Cli::command().version(VERSION).get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(error) => error.exit(),
    };
    let Some((kind, common, mut opts)) = cli.command.resolve() else {
        let described = optimize::cli::describe(
            &cli.command,
            Cli::command().version(VERSION),
            &mut std::io::stdout(),
        );
        return match described {
            Ok(_) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: cannot write the description: {e}");
                ExitCode::from(1)
            }
        };
    };
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
    // The command line owns stderr: the library's log goes where this target says.
    opts.log = LogTarget::to(
        Arc::new(Mutex::new(std::io::stderr())),
        std::io::stderr().is_terminal(),
    );

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
    // result.json's text, printed as is by --json (one serialization for both).
    let summary = optimize::io::result::summary_json(&outcome.summary);
    let written = match optimize::io::write_outcome(&dir, &outcome, &summary) {
        Ok(paths) => paths,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(e.exit_code());
        }
    };
    if !opts.quiet && outcome.check_passed.is_none() {
        opts.log.line(&statistics(&outcome));
    }
    if common.json {
        if let Err(e) = std::io::stdout().lock().write_all(&summary.bytes) {
            eprintln!("error: cannot print the summary: {e}");
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
            "{}   max violation {:.2e}   iterations {}   time {:.2} s",
            s.headline.text(),
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

/// The closing block of the log, in the style of IPOPT's: iterations, evaluations, time per
/// phase, the answer in its unit, the largest violation and the status.
fn statistics(outcome: &Outcome) -> String {
    let s = &outcome.summary;
    let phases: Vec<String> = s
        .timings
        .iter()
        .map(|(phase, t)| format!("{phase} {t:.3}"))
        .collect();
    let rows = [
        ("Iterations", s.iterations.to_string()),
        (
            "Evaluations f, ∇, ∇²",
            format!(
                "{}, {}, {}",
                s.evaluations.functions, s.evaluations.derivatives, s.evaluations.hessians
            ),
        ),
        ("Time [s]", phases.join(", ")),
        (
            &format!("Final {}", s.headline.name),
            format!("{:.9e} {}", s.headline.value, s.headline.unit),
        ),
        ("Largest violation", format!("{:.3e}", s.max_violation)),
        ("Status", s.status.clone()),
    ];
    let mut text = String::new();
    for (name, value) in rows {
        let dots = ".".repeat(26usize.saturating_sub(name.chars().count()));
        text.push_str(&format!("\n{name} {dots}: {}", value.trim_end()));
    }
    text
}
