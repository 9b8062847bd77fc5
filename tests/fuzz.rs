//! Seeded mutation fuzzing of problem files: every shipped problem (`problems/`) and golden input
//! (`tests/golden/problems/`) is mutated (numbers to NaN, ±∞, huge, negative or zero; keys
//! deleted or duplicated; arrays extended; values of another type; unknown keys) and driven
//! through the library's load and model build, then one evaluation of the model and its
//! derivatives at the start, the part of `--check` that every input reaches (the finite-difference
//! comparison that follows only re-evaluates the same model).
//!
//! The contract: no panic, no abort, an error or a success, in bounded time. Outcomes are counted
//! by class. `cargo test --release --test fuzz` runs a small bounded sample; the full run is
//! `cargo test --release --test fuzz -- --ignored --nocapture` (5,000 files per kind; seed from
//! `FUZZ_SEED`, count per kind from `FUZZ_COUNT`).

use std::collections::BTreeMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use optimize::error::Error;
use optimize::gait::collocation::{self, Collocation};
use optimize::gait::reduced::Reduced;
use optimize::solver::Nlp;
use optimize::spec::Source;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The longest one mutant may take (load, build, one evaluation).
const TIME_LIMIT: Duration = Duration::from_secs(20);

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Outcome {
    RejectedWithPosition,
    /// Positioned at 1:1 on a comment or blank line: no key was found for the error.
    RejectedAtFileStart,
    /// Positioned at a table header although the error is about something inside the table.
    RejectedAtTableHeader,
    RejectedWithoutPosition,
    RuntimeError,
    AcceptedEvaluated,
    AcceptedEvaluationFailed,
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The seed files of one kind.
fn seeds(kind: &str) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for dir in [
        root().join("problems").join(kind),
        root().join("tests/golden/problems").join(kind),
    ] {
        if let Ok(entries) = std::fs::read_dir(&dir) {
            for e in entries.flatten() {
                let p = e.path();
                if p.extension().is_some_and(|x| x == "toml") {
                    files.push(p);
                }
            }
        }
    }
    files.sort();
    files
}

/// Evaluates `nlp` and its derivatives at its start; false when an evaluation fails.
fn evaluate(nlp: &dyn Nlp) -> bool {
    let d = nlp.dims();
    let mut x = vec![0.0; d.n];
    nlp.start(&mut x);
    let (mut f, mut c) = (0.0, vec![0.0; d.m]);
    let (mut g, mut j) = (vec![0.0; d.n], vec![0.0; d.jac_nnz]);
    nlp.eval(&x, &mut f, &mut c).is_ok() && nlp.eval_derivatives(&x, &mut g, &mut j).is_ok()
}

/// The outcome of an error on `text`. Misplaced: at 1:1 on a comment or blank line (no key
/// found for the error, unless a top-level key is missing), or at a table header for an error
/// about a key or value inside the table (a serde error other than a missing key, or a message
/// quoting a key the table holds).
fn classify_error(e: &Error, text: &str) -> Outcome {
    let Error::Input(i) = e else {
        return Outcome::RuntimeError;
    };
    let Some((line, _)) = i.position else {
        return Outcome::RejectedWithoutPosition;
    };
    let lines: Vec<&str> = text.lines().collect();
    let at = lines.get(line - 1).map_or("", |l| l.trim_start());
    let missing = i.message.starts_with("missing key");
    if i.position == Some((1, 1)) && (at.is_empty() || at.starts_with('#')) && !missing {
        return Outcome::RejectedAtFileStart;
    }
    if at.starts_with('[') && !missing {
        let body = lines[line..]
            .iter()
            .take_while(|l| !l.trim_start().starts_with('['));
        let keys: Vec<&str> = body
            .filter_map(|l| l.split_once('=').map(|(k, _)| k.trim()))
            .collect();
        let quoted = i.message.split('`').skip(1).step_by(2);
        let about_inside = ["unknown key", "expected ", "invalid", "unknown variant"]
            .iter()
            .any(|p| i.message.starts_with(p))
            || quoted.into_iter().any(|q| keys.contains(&q));
        if about_inside {
            return Outcome::RejectedAtTableHeader;
        }
    }
    Outcome::RejectedWithPosition
}

/// Load, build and evaluate one file of `kind`: the outcome and the error's text, if any.
fn probe(kind: &str, path: &Path) -> (Outcome, String) {
    let result: Result<bool, Error> = (|| match kind {
        "truss" => {
            let p = optimize::truss::load(path)?;
            let model = p.model_for(0)?;
            let nlp = p.nlp(&model, 0)?;
            Ok(evaluate(&nlp))
        }
        "cmc" => {
            let p = optimize::cmc::load(path)?;
            let nlp = p.build()?;
            Ok(evaluate(&nlp))
        }
        _ => {
            let source = Source::read(path)?;
            if collocation::spec::selects_collocation(&source) {
                let p = collocation::load_source(&source)?;
                Ok(evaluate(&Collocation::new(&p)))
            } else {
                let p = optimize::gait::spec::load_source(&source)?;
                Ok(evaluate(&Reduced::new(&p)))
            }
        }
    })();
    match result {
        Ok(true) => (Outcome::AcceptedEvaluated, String::new()),
        Ok(false) => (Outcome::AcceptedEvaluationFailed, String::new()),
        Err(e) => {
            let text = std::fs::read_to_string(path).unwrap_or_default();
            (classify_error(&e, &text), e.to_string())
        }
    }
}

/// Replacement values for a number.
const NUMBERS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "1e300",
    "-1e300",
    "1e12",
    "1000000000000",
    "-1",
    "0",
    "0.0",
    "1e-300",
    "-0.5",
    "4294967296",
    "99999999999999999999",
];

/// Replacement values of other types.
const OTHERS: &[&str] = &["\"x\"", "true", "[]", "{}", "[1, 2, 3, 4]", "[[0.0]]"];

/// Byte ranges of the numeric literals in a line's value part (after `=`).
fn numbers_in(line: &str) -> Vec<(usize, usize)> {
    let Some(eq) = line.find('=') else {
        return Vec::new();
    };
    if line.trim_start().starts_with('#') {
        return Vec::new();
    }
    let b = line.as_bytes();
    let mut out = Vec::new();
    let mut i = eq + 1;
    let mut in_string = false;
    while i < b.len() {
        let ch = b[i];
        if ch == b'"' {
            in_string = !in_string;
        }
        if ch == b'#' && !in_string {
            break;
        }
        let starts = (ch.is_ascii_digit() || ch == b'-' || ch == b'+')
            && !in_string
            && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_'));
        if starts {
            let s = i;
            i += 1;
            while i < b.len()
                && (b[i].is_ascii_alphanumeric() || matches!(b[i], b'.' | b'_' | b'-' | b'+'))
            {
                i += 1;
            }
            if line[s..i].bytes().any(|c| c.is_ascii_digit()) {
                out.push((s, i));
            }
            continue;
        }
        i += 1;
    }
    out
}

/// `table.key` of the value on line `i`: the nearest header above and the line's key.
fn key_of(lines: &[String], i: usize) -> String {
    let table = lines[..i]
        .iter()
        .rev()
        .map(|l| l.trim())
        .find(|l| l.starts_with('['))
        .map_or(String::new(), |h| {
            let header = h.split('#').next().unwrap_or("").trim();
            header.trim_matches(['[', ']']).to_string() + "."
        });
    let key = lines[i].split('=').next().unwrap_or("").trim();
    format!("{table}{key}")
}

/// One random mutation of `text`, and its class (what was done to which key).
fn mutate_once(text: &str, rng: &mut ChaCha8Rng) -> (String, String) {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.is_empty() {
        return (text.to_string(), "none".into());
    }
    let with_numbers: Vec<usize> = (0..lines.len())
        .filter(|&i| !numbers_in(&lines[i]).is_empty())
        .collect();
    let with_values: Vec<usize> = (0..lines.len())
        .filter(|&i| {
            let l = lines[i].trim_start();
            !l.starts_with('#') && !l.starts_with('[') && l.contains('=')
        })
        .collect();
    let op = rng.random_range(0..10);
    let class = match op {
        0..=4 if !with_numbers.is_empty() => {
            let i = with_numbers[rng.random_range(0..with_numbers.len())];
            let spans = numbers_in(&lines[i]);
            let (s, e) = spans[rng.random_range(0..spans.len())];
            let old = lines[i][s..e].to_string();
            let (new, what) = match rng.random_range(0..3) {
                0 => {
                    let n = NUMBERS[rng.random_range(0..NUMBERS.len())];
                    (n.to_string(), format!("set {n}"))
                }
                1 if old.starts_with('-') => (old[1..].to_string(), "negate".into()),
                1 => (format!("-{old}"), "negate".into()),
                _ => (
                    format!("{old}e{}", rng.random_range(3..40)),
                    "scale up".into(),
                ),
            };
            lines[i].replace_range(s..e, &new);
            format!("{what} {}", key_of(&lines, i))
        }
        5 if !with_values.is_empty() => {
            let i = with_values[rng.random_range(0..with_values.len())];
            let class = format!("delete {}", key_of(&lines, i));
            lines.remove(i);
            class
        }
        6 if !with_values.is_empty() => {
            let i = with_values[rng.random_range(0..with_values.len())];
            let copy = lines[i].clone();
            lines.insert(i + 1, copy);
            format!("duplicate {}", key_of(&lines, i))
        }
        7 => {
            let arrays: Vec<usize> = (0..lines.len())
                .filter(|&i| lines[i].contains("= [") && lines[i].contains(']'))
                .collect();
            if let Some(&i) = arrays.get(rng.random_range(0..arrays.len().max(1))) {
                let close = lines[i].rfind(']').unwrap_or(0);
                lines[i].insert_str(close, ", 5.0");
                format!("extend {}", key_of(&lines, i))
            } else {
                "none".into()
            }
        }
        8 if !with_values.is_empty() => {
            let i = with_values[rng.random_range(0..with_values.len())];
            if let Some(eq) = lines[i].find('=') {
                let value = OTHERS[rng.random_range(0..OTHERS.len())];
                lines[i] = format!("{}= {value}", &lines[i][..eq]);
                format!("retype {} to {value}", key_of(&lines, i))
            } else {
                "none".into()
            }
        }
        _ => {
            let headers: Vec<usize> = (0..lines.len())
                .filter(|&i| lines[i].trim_start().starts_with('['))
                .collect();
            let at = headers
                .get(rng.random_range(0..headers.len().max(1)))
                .map_or(0, |&i| i + 1);
            lines.insert(at, "unknown_key = 1.0".to_string());
            format!("unknown key after line {at}")
        }
    };
    let mut out = lines.join("\n");
    out.push('\n');
    (out, class)
}

/// A mutant of `text`: one or two mutations, and their classes joined by " + ".
fn mutant(text: &str, rng: &mut ChaCha8Rng) -> (String, String) {
    let mut t = text.to_string();
    let mut classes = Vec::new();
    for _ in 0..rng.random_range(1..=2) {
        let (next, class) = mutate_once(&t, rng);
        t = next;
        classes.push(class);
    }
    (t, classes.join(" + "))
}

/// A scratch folder holding the mutants of one kind and the seed folders' other files (the
/// meshes that cmc imports name relative to the problem file).
struct Scratch(PathBuf);

impl Scratch {
    fn new(kind: &str, tag: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("optimize-fuzz-{kind}-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for seed_dir in [root().join("problems").join(kind)] {
            for e in std::fs::read_dir(seed_dir).unwrap().flatten() {
                let p = e.path();
                if p.extension().is_some_and(|x| x != "toml") {
                    std::fs::copy(&p, dir.join(p.file_name().unwrap())).unwrap();
                }
            }
        }
        Scratch(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// What a fuzz run saw: counts by outcome, a few errors per misplaced outcome, and the accepted
/// mutation classes (what was done to which key) with their counts and the changed lines of
/// the first accepted mutant of the class.
#[derive(Default)]
struct Tally {
    counts: BTreeMap<Outcome, usize>,
    misplaced: BTreeMap<Outcome, Vec<String>>,
    accepted: BTreeMap<String, (usize, String)>,
}

/// The lines of `mutant` that `original` does not hold, joined by " | ": what a mutation wrote.
fn changed_lines(original: &str, mutant: &str) -> String {
    let before: std::collections::BTreeSet<&str> = original.lines().collect();
    let changed: Vec<&str> = (mutant.lines())
        .filter(|l| !before.contains(l))
        .map(str::trim)
        .collect();
    if changed.is_empty() {
        "(lines removed or repeated only)".into()
    } else {
        changed.join(" | ")
    }
}

impl Tally {
    fn add(
        &mut self,
        outcome: Outcome,
        seed_file: &Path,
        class: &str,
        error: String,
        sample: &str,
    ) {
        *self.counts.entry(outcome).or_insert(0) += 1;
        let name = seed_file.file_name().unwrap().to_string_lossy();
        match outcome {
            Outcome::RejectedAtFileStart
            | Outcome::RejectedAtTableHeader
            | Outcome::RejectedWithoutPosition => {
                let samples = self.misplaced.entry(outcome).or_default();
                if samples.len() < 8 {
                    samples.push(format!("{name} [{class}]: {error}"));
                }
            }
            Outcome::AcceptedEvaluated | Outcome::AcceptedEvaluationFailed => {
                for one in class.split(" + ") {
                    let entry = (self.accepted.entry(format!("{name}: {one}")))
                        .or_insert_with(|| (0, sample.to_string()));
                    entry.0 += 1;
                }
            }
            _ => {}
        }
    }

    fn count(&self, outcome: Outcome) -> usize {
        self.counts.get(&outcome).copied().unwrap_or(0)
    }

    /// Mutants rejected without a position or at a misplaced one.
    fn misplaced_total(&self) -> usize {
        [
            Outcome::RejectedAtFileStart,
            Outcome::RejectedAtTableHeader,
            Outcome::RejectedWithoutPosition,
        ]
        .into_iter()
        .map(|o| self.count(o))
        .sum()
    }
}

/// Mutates the seed files of `kind` into `count` files (round robin over the seeds, whose
/// names are kept: imports resolve against the scratch folder), probes each, and tallies the
/// outcomes. Panics (with the mutant's text) on a panic or an overrun of the time limit.
fn fuzz(kind: &str, seed: u64, count: usize, only: &[&str]) -> Tally {
    let files: Vec<PathBuf> = seeds(kind)
        .into_iter()
        .filter(|p| only.is_empty() || only.iter().any(|o| p.ends_with(o)))
        .collect();
    assert!(!files.is_empty(), "no seed files for {kind}");
    let texts: Vec<String> = files
        .iter()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect();
    let scratch = Scratch::new(kind, &seed.to_string());
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut tally = Tally::default();
    for k in 0..count {
        let which = k % files.len();
        let (text, class) = mutant(&texts[which], &mut rng);
        let path = scratch.0.join(files[which].file_name().unwrap());
        std::fs::write(&path, &text).unwrap();
        if std::env::var_os("FUZZ_TRACE").is_some() {
            eprintln!("{kind} mutant {k}: {} [{class}]", path.display());
        }
        let started = Instant::now();
        let outcome = catch_unwind(AssertUnwindSafe(|| probe(kind, &path)));
        let took = started.elapsed();
        let Ok((outcome, error)) = outcome else {
            panic!(
                "{kind} mutant {k} of {} panicked:\n{text}",
                files[which].display()
            );
        };
        assert!(
            took <= TIME_LIMIT,
            "{kind} mutant {k} of {} took {took:?}:\n{text}",
            files[which].display()
        );
        let sample = changed_lines(&texts[which], &text);
        tally.add(outcome, &files[which], &class, error, &sample);
    }
    tally
}

/// Prints the counts by outcome, the misplaced errors' samples and, with `accepted`, every
/// accepted mutation class with its count and a sample of the lines it wrote.
fn report(kind: &str, tally: &Tally, accepted: bool) {
    let total: usize = tally.counts.values().sum();
    let parts: Vec<String> = (tally.counts.iter())
        .map(|(o, n)| format!("{o:?} {n}"))
        .collect();
    println!("{kind}: {total} mutants: {}", parts.join(", "));
    for (outcome, samples) in &tally.misplaced {
        for sample in samples {
            println!("  {outcome:?}: {sample}");
        }
    }
    if accepted {
        for (class, (n, sample)) in &tally.accepted {
            println!("  accepted {n:>4}  {class}  e.g. {sample}");
        }
    }
}

/// The bounded sample in the normal test run: the fast seed files of each kind.
#[test]
fn mutated_problem_files_never_panic_or_hang() {
    for (kind, only) in [
        ("truss", &["roof_fink.toml", "warren_bridge.toml"][..]),
        ("cmc", &["tennis_cushion.toml", "double_bubble.toml"][..]),
        ("gait", &["pogo_crouch.toml", "ball.toml"][..]),
    ] {
        let tally = fuzz(kind, 1, 60, only);
        report(kind, &tally, false);
        assert!(
            tally.count(Outcome::RejectedWithPosition) > 0,
            "{kind}: some mutants must be rejected"
        );
        assert_eq!(
            tally.misplaced_total(),
            0,
            "{kind}: errors without a position or at a misplaced one"
        );
    }
}

/// The full run: `FUZZ_COUNT` (default 5,000) mutants per kind from every seed file.
#[test]
#[ignore = "minutes; run with --ignored --nocapture"]
fn mutated_problem_files_full_run() {
    let seed = std::env::var("FUZZ_SEED").map_or(0, |s| s.parse().unwrap());
    let count = std::env::var("FUZZ_COUNT").map_or(5000, |s| s.parse().unwrap());
    let kinds = std::env::var("FUZZ_KINDS").unwrap_or_else(|_| "truss,cmc,gait".into());
    for kind in kinds.split(',') {
        let started = Instant::now();
        let tally = fuzz(kind, seed, count, &[]);
        report(kind, &tally, true);
        println!("{kind}: {:.0} s", started.elapsed().as_secs_f64());
    }
}

#[test]
fn number_spans_skip_keys_strings_and_comments() {
    let line = "at = [1.0, -2e3, 0] # 5";
    let spans: Vec<&str> = numbers_in(line).iter().map(|&(s, e)| &line[s..e]).collect();
    assert_eq!(spans, ["1.0", "-2e3", "0"]);
    assert!(numbers_in("name = \"b2\"").is_empty());
}
