//! Command-line definitions (clap derive). `main.rs` turns them into [`RunOptions`].

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use crate::outcome::{Kind, RunOptions};
use crate::spec::overrides::Override;

const EXAMPLES: &str = "\
Examples:
  optimize truss problems/truss/warren_bridge.toml
  optimize cmc problems/cmc/double_bubble.toml -o out/bubble --json
  optimize gait problems/gait/luxo_leap.toml --trial 2 --seed 7
  optimize truss problems/truss/michell.toml --check

Exit codes: 0 converged, 1 runtime failure, 2 usage or problem-file error,
3 stopped without converging (best result written), 130 interrupted (best so far written).";

/// Most worker threads `--threads` accepts.
pub const MAX_THREADS: u64 = 256;
/// Most topology rounds `--rounds` accepts (the file's `[rounds] count` has the same cap).
const MAX_ROUNDS: u64 = crate::truss::spec::MAX_ROUNDS as u64;

/// Design physically valid motion and structures by constrained nonlinear optimization.
#[derive(Debug, Parser)]
#[command(name = "optimize", version, after_help = EXAMPLES)]
pub struct Cli {
    /// What to optimize.
    #[command(subcommand)]
    pub command: Command,
}

/// The problem kinds.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Spacetime motion of an articulated character (torque splines through a simulator).
    #[command(after_help = "Example:\n  optimize gait problems/gait/luxo_leap.toml --trial 2")]
    Gait {
        #[command(flatten)]
        common: Common,
        /// Run only trial K (1-based) of the file's trials.
        #[arg(long, value_name = "K", value_parser = clap::value_parser!(u64).range(1..))]
        trial: Option<u64>,
    },
    /// Minimum-mass truss from anchors and loads (geometry and sizing together).
    #[command(
        after_help = "Example:\n  optimize truss problems/truss/warren_bridge.toml --rounds 3"
    )]
    Truss {
        #[command(flatten)]
        common: Common,
        /// Topology rounds, 1 to 100: merge short beams, drop idle ones, re-solve (overrides the
        /// file).
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=MAX_ROUNDS))]
        rounds: Option<u64>,
    },
    /// Constant-mean-curvature surfaces: soap films, bubbles, tents, pneumatic structures.
    #[command(
        after_help = "Example:\n  optimize cmc problems/cmc/double_bubble.toml -o out/bubble"
    )]
    Cmc {
        #[command(flatten)]
        common: Common,
    },
    /// Print a shell completion script on stdout, e.g. `optimize completions bash >
    /// ~/.local/share/bash-completion/completions/optimize`.
    Completions {
        /// The shell.
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Print the manual page (roff) on stdout, or with DIR write it and one page per command
    /// (optimize-truss.1, …) there, e.g. `optimize man ~/.local/share/man/man1`.
    Man {
        /// Folder for every page.
        #[arg(value_name = "DIR")]
        dir: Option<PathBuf>,
    },
}

/// Flags every kind accepts.
#[derive(Debug, Args)]
pub struct Common {
    /// Problem file (TOML; see docs/problem-files.md).
    pub file: PathBuf,
    /// Parse, validate, build the model and compare its derivatives with finite differences,
    /// without solving.
    #[arg(long)]
    pub check: bool,
    /// Output folder; default `out/<problem name>/`.
    #[arg(
        short = 'o',
        long = "out",
        value_name = "DIR",
        help = "Output folder [default: out/<problem name>/]"
    )]
    pub out: Option<PathBuf>,
    /// Print nothing but errors.
    #[arg(short, long, conflicts_with = "verbose")]
    pub quiet: bool,
    /// Print a detailed iteration log.
    #[arg(short, long)]
    pub verbose: bool,
    /// Print the result summary as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Major-iteration limit (overrides `[solver] max_iterations`).
    #[arg(
        long,
        value_name = "N",
        help = "Major-iteration limit (overrides [solver] max_iterations)"
    )]
    pub max_iter: Option<usize>,
    /// Seed for every random choice [default: 0, or a truss file's `seed`]; the same file and
    /// seed give the same result. Given, it overrides the file's `seed`.
    #[arg(long, value_name = "N")]
    pub seed: Option<u64>,
    /// Worker threads, 1 to 256 [default: all cores]; results do not depend on it.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=MAX_THREADS))]
    pub threads: Option<u64>,
    /// Override a problem-file value, checked like the file (repeatable; the value in TOML
    /// syntax, a bare word taken as a string), e.g. `--set solver.max_iterations=300`.
    #[arg(long = "set", value_name = "KEY.PATH=VALUE")]
    pub set: Vec<Override>,
    /// Start from a previous run's answer: its `result.json` (same problem, same kind).
    #[arg(long, value_name = "RESULT", conflicts_with = "check")]
    pub start: Option<PathBuf>,
}

impl Command {
    /// The kind, the problem file, the flags shared by all kinds, and the run options; `None`
    /// for the commands that describe the tool (`completions`, `man`).
    pub fn resolve(&self) -> Option<(Kind, &Common, RunOptions)> {
        let (kind, common) = match self {
            Command::Gait { common, .. } => (Kind::Gait, common),
            Command::Truss { common, .. } => (Kind::Truss, common),
            Command::Cmc { common } => (Kind::Cmc, common),
            Command::Completions { .. } | Command::Man { .. } => return None,
        };
        let mut opts = RunOptions {
            out_dir: common.out.clone(),
            quiet: common.quiet,
            verbose: common.verbose,
            check: common.check,
            max_iter: common.max_iter,
            seed: common.seed.unwrap_or(0),
            seed_given: common.seed.is_some(),
            threads: common.threads.map(|t| t as usize),
            overrides: common.set.clone(),
            start_file: common.start.clone(),
            ..RunOptions::default()
        };
        match self {
            Command::Gait { trial, .. } => opts.trial = trial.map(|t| t as usize),
            Command::Truss { rounds, .. } => opts.rounds = rounds.map(|r| r as usize),
            _ => {}
        }
        Some((kind, common, opts))
    }
}

/// Writes what `optimize completions` or `optimize man` prints for the command line `cli`
/// (the definition with its version) to `out` (or, for `man DIR`, the pages into DIR); `false`
/// for the problem kinds' commands.
pub fn describe(
    command: &Command,
    mut cli: clap::Command,
    out: &mut dyn std::io::Write,
) -> std::io::Result<bool> {
    match command {
        Command::Completions { shell } => {
            clap_complete::generate(*shell, &mut cli, "optimize", out);
            Ok(true)
        }
        Command::Man { dir: None } => {
            clap_mangen::Man::new(cli).render(out)?;
            Ok(true)
        }
        Command::Man { dir: Some(dir) } => {
            std::fs::create_dir_all(dir)?;
            clap_mangen::generate_to(cli, dir)?;
            Ok(true)
        }
        _ => Ok(false),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn cli_definition_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn flags_reach_the_run_options() {
        let cli = Cli::try_parse_from([
            "optimize",
            "truss",
            "p.toml",
            "--rounds",
            "3",
            "--seed",
            "9",
            "-q",
            "--max-iter",
            "5",
        ])
        .unwrap();
        let (kind, common, opts) = cli.command.resolve().unwrap();
        assert_eq!(kind, Kind::Truss);
        assert_eq!(common.file, PathBuf::from("p.toml"));
        assert_eq!(
            (
                opts.rounds,
                opts.seed,
                opts.seed_given,
                opts.quiet,
                opts.max_iter
            ),
            (Some(3), 9, true, true, Some(5))
        );
        let (_, _, opts) = Cli::try_parse_from(["optimize", "truss", "p.toml"])
            .unwrap()
            .command
            .resolve()
            .unwrap();
        assert_eq!((opts.seed, opts.seed_given), (0, false));
        assert!(Cli::try_parse_from(["optimize", "gait", "p.toml", "--trial", "0"]).is_err());
        assert!(Cli::try_parse_from(["optimize", "cmc", "p.toml", "-q", "-v"]).is_err());
    }
}
