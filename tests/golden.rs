//! Golden regression: every case of tests/golden/manifest.toml runs a problem file through
//! `optimize::run::execute` (the function the CLI calls) and compares chosen fields of the
//! result summary with tests/golden/<case>.json, each within its stated tolerance.
//!
//! `UPDATE_GOLDEN=1 cargo test --release --test golden` rewrites the golden files from the
//! current results; review the diff before committing. A missing golden file fails.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use approx::relative_eq;
use optimize::outcome::{Kind, RunOptions};
use optimize::run::execute;
use rayon::prelude::*;
use serde::Deserialize;
use serde_json::Value;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    case: Vec<Case>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Case {
    /// Golden file stem.
    name: String,
    /// "gait", "truss" or "cmc".
    kind: String,
    /// Problem file, relative to the crate root.
    file: PathBuf,
    #[serde(default)]
    seed: u64,
    max_iter: Option<usize>,
    rounds: Option<usize>,
    trial: Option<usize>,
    /// Dotted path into result.json → how to compare.
    fields: BTreeMap<String, Compare>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
enum Compare {
    /// "exact": strings, integers and booleans must match.
    Exact(String),
    /// Numbers: |a − b| ≤ abs or ≤ rel·max(|a|, |b|).
    Near {
        #[serde(default)]
        rel: f64,
        #[serde(default)]
        abs: f64,
    },
}

fn kind(name: &str) -> Kind {
    match name {
        "gait" => Kind::Gait,
        "truss" => Kind::Truss,
        "cmc" => Kind::Cmc,
        other => panic!("manifest names unknown kind `{other}`"),
    }
}

fn lookup<'a>(summary: &'a Value, path: &str) -> Option<&'a Value> {
    path.split('.')
        .try_fold(summary, |v, key| match key.parse::<usize>() {
            Ok(i) => v.get(i),
            Err(_) => v.get(key),
        })
}

fn compare(field: &str, how: &Compare, got: &Value, want: &Value) -> Result<(), String> {
    match how {
        Compare::Exact(mode) if mode == "exact" => (got == want)
            .then_some(())
            .ok_or(format!("{field}: got {got}, golden {want}")),
        Compare::Exact(mode) => Err(format!("{field}: unknown comparison `{mode}`")),
        Compare::Near { rel, abs } => {
            let (Some(a), Some(b)) = (got.as_f64(), want.as_f64()) else {
                return Err(format!("{field}: not numbers: got {got}, golden {want}"));
            };
            let ok = relative_eq!(a, b, epsilon = *abs, max_relative = *rel);
            ok.then_some(()).ok_or(format!(
                "{field}: got {a:.12e}, golden {b:.12e} (rel {rel:e}, abs {abs:e})"
            ))
        }
    }
}

fn run_case(root: &Path, case: &Case, update: bool) -> Result<(), String> {
    let opts = RunOptions {
        quiet: true,
        seed: case.seed,
        max_iter: case.max_iter,
        rounds: case.rounds,
        trial: case.trial,
        ..RunOptions::default()
    };
    let (_, outcome) = execute(kind(&case.kind), &root.join(&case.file), &opts)
        .map_err(|e| format!("{}: {e}", case.name))?;
    let summary = serde_json::to_value(&outcome.summary).map_err(|e| e.to_string())?;
    let golden_path = root
        .join("tests/golden")
        .join(format!("{}.json", case.name));
    let mut got = serde_json::Map::new();
    for field in case.fields.keys() {
        let value = lookup(&summary, field)
            .ok_or(format!("{}: result has no field `{field}`", case.name))?;
        got.insert(field.clone(), value.clone());
    }
    if update {
        let text = serde_json::to_string_pretty(&Value::Object(got)).unwrap() + "\n";
        std::fs::write(&golden_path, text).map_err(|e| e.to_string())?;
        return Ok(());
    }
    let text = std::fs::read_to_string(&golden_path).map_err(|_| {
        format!(
            "{}: missing golden file {} (run with UPDATE_GOLDEN=1)",
            case.name,
            golden_path.display()
        )
    })?;
    let want: Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", case.name))?;
    let errors: Vec<String> = case
        .fields
        .iter()
        .filter_map(|(field, how)| {
            let want = want.get(field).unwrap_or(&Value::Null);
            compare(field, how, &got[field], want).err()
        })
        .collect();
    if errors.is_empty() {
        Ok(())
    } else {
        Err(format!("{}: {}", case.name, errors.join("; ")))
    }
}

#[test]
fn golden_results_hold() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("tests/golden/manifest.toml")).unwrap();
    let manifest: Manifest = toml::from_str(&text).expect("valid manifest");
    assert!(!manifest.case.is_empty(), "the manifest lists no case");
    let update = std::env::var_os("UPDATE_GOLDEN").is_some_and(|v| v == "1");
    let failures: Vec<String> = manifest
        .case
        .par_iter()
        .filter_map(|case| run_case(root, case, update).err())
        .collect();
    assert!(
        failures.is_empty(),
        "golden mismatches:\n{}",
        failures.join("\n")
    );
}

#[test]
fn comparisons_detect_differences() {
    let near = Compare::Near {
        rel: 1e-6,
        abs: 0.0,
    };
    assert!(compare("x", &near, &Value::from(1.0), &Value::from(1.0 + 1e-9)).is_ok());
    assert!(compare("x", &near, &Value::from(1.0), &Value::from(1.001)).is_err());
    let exact = Compare::Exact("exact".into());
    assert!(
        compare(
            "s",
            &exact,
            &Value::from("Optimal"),
            &Value::from("Stalled")
        )
        .is_err()
    );
    let summary = serde_json::json!({"figures": {"areas": [1.0, 2.0]}});
    assert_eq!(lookup(&summary, "figures.areas.1"), Some(&Value::from(2.0)));
}
