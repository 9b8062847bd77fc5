//! The command line as a user meets it: exit codes and one-line, positioned errors for bad
//! problem files, `--check`, `--json`, and the files a run writes.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SHIPPED: &str = "problems/truss/roof_fink.toml";

/// A scratch folder per test, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("optimize-cli-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }

    /// Writes `text` as a problem file and returns its path.
    fn file(&self, name: &str, text: &str) -> PathBuf {
        let path = self.0.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }
}

impl Drop for Scratch {
    /// Every `.glb` a test wrote must read back with the `gltf` crate (which validates indices,
    /// accessors and buffers); then the folder goes.
    fn drop(&mut self) {
        if !std::thread::panicking() {
            for glb in files_under(&self.0, "glb") {
                let bytes = std::fs::read(&glb).unwrap();
                if let Err(e) = optimize::io::gltf_read::read_slice(&bytes, None) {
                    panic!("{}: not valid glTF: {e}", glb.display());
                }
            }
        }
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Files under `dir` (recursively) whose extension is `ext`.
fn files_under(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        if path.is_dir() {
            found.extend(files_under(&path, ext));
        } else if path.extension().is_some_and(|e| e == ext) {
            found.push(path);
        }
    }
    found
}

fn optimize(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_optimize"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the binary runs")
}

fn shipped() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(SHIPPED)).unwrap()
}

/// 1-based line of the first occurrence of `needle` in `text`.
fn line_of(text: &str, needle: &str) -> usize {
    text[..text.find(needle).expect("needle present")]
        .matches('\n')
        .count()
        + 1
}

/// Asserts exit code 2 and a single stderr line `error: <file>:<line>:<col>: ...` containing
/// every `expected` fragment; returns the line.
fn assert_input_error(out: &Output, file: &Path, line: Option<usize>, expected: &[&str]) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "stderr: {stderr}");
    assert_eq!(stderr.lines().count(), 1, "one line expected: {stderr}");
    let prefix = match line {
        Some(l) => format!("error: {}:{l}:", file.display()),
        None => format!("error: {}:", file.display()),
    };
    assert!(
        stderr.starts_with(&prefix),
        "expected prefix `{prefix}` in: {stderr}"
    );
    for e in expected {
        assert!(stderr.contains(e), "expected `{e}` in: {stderr}");
    }
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

#[test]
fn missing_file_exits_2() {
    let scratch = Scratch::new("missing");
    let path = scratch.0.join("nope.toml");
    let out = optimize(&["truss", path.to_str().unwrap()]);
    assert_input_error(&out, &path, None, &["no such file"]);
}

#[test]
fn toml_syntax_error_names_line_and_column() {
    let scratch = Scratch::new("syntax");
    let text = shipped().replacen("max_force = 1e6", "max_force = = 1e6", 1);
    let path = scratch.file("bad.toml", &text);
    let out = optimize(&["truss", path.to_str().unwrap()]);
    assert_input_error(&out, &path, Some(line_of(&text, "max_force = =")), &[]);
}

#[test]
fn unknown_key_suggests_the_closest_valid_key() {
    let scratch = Scratch::new("unknown");
    let text = shipped().replacen("min_length", "min_lenght", 1);
    let path = scratch.file("bad.toml", &text);
    let out = optimize(&["truss", path.to_str().unwrap()]);
    let line = line_of(&text, "min_lenght");
    assert_input_error(
        &out,
        &path,
        Some(line),
        &["`min_lenght`", "did you mean `min_length`"],
    );
}

#[test]
fn unknown_key_in_the_solver_table_suggests_too() {
    let scratch = Scratch::new("solverkey");
    // The shipped file sets no solver key: the table is added.
    let text = format!("{}\n[solver]\ntolerence = 1e-6\n", shipped());
    let path = scratch.file("bad.toml", &text);
    let out = optimize(&["truss", path.to_str().unwrap()]);
    let line = line_of(&text, "tolerence");
    assert_input_error(&out, &path, Some(line), &["did you mean `tolerance`"]);
}

#[test]
fn wrong_type_names_line_and_column() {
    let scratch = Scratch::new("type");
    let text = shipped().replacen("max_force = 1e6", "max_force = \"large\"", 1);
    let path = scratch.file("bad.toml", &text);
    let out = optimize(&["truss", path.to_str().unwrap()]);
    assert_input_error(
        &out,
        &path,
        Some(line_of(&text, "max_force")),
        &["wrong type"],
    );
}

#[test]
fn out_of_range_value_names_line_and_column() {
    let scratch = Scratch::new("range");
    let text = format!("{}\n[solver]\ntolerance = 2.0\n", shipped());
    let path = scratch.file("bad.toml", &text);
    let out = optimize(&["truss", path.to_str().unwrap()]);
    let line = line_of(&text, "tolerance = 2.0");
    assert_input_error(&out, &path, Some(line), &["`tolerance` must be in (0, 1)"]);
}

#[test]
fn check_on_a_valid_file_exits_0() {
    let scratch = Scratch::new("check");
    let out_dir = scratch.0.to_str().unwrap();
    for (kind, file) in [
        ("gait", "problems/gait/pogo_crouch.toml"),
        ("gait", "problems/gait/ball.toml"),
        ("cmc", "problems/cmc/tennis_cushion.toml"),
    ] {
        let out = optimize(&[kind, file, "--check", "-q", "-o", out_dir]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{kind} {file}: {stderr}");
        let summary = std::fs::read_to_string(scratch.0.join("check").join("result.json")).unwrap();
        assert!(summary.contains("\"status\": \"Checked\""), "{summary}");
    }
}

#[test]
fn usage_errors_exit_2_and_help_shows_an_example() {
    assert_eq!(optimize(&["truss"]).status.code(), Some(2));
    assert_eq!(optimize(&["bridge", "x.toml"]).status.code(), Some(2));
    let help = optimize(&["--help"]);
    assert_eq!(help.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&help.stdout).contains("optimize truss problems/truss/"));
    for kind in ["gait", "truss", "cmc"] {
        let help = optimize(&[kind, "--help"]);
        let text = String::from_utf8_lossy(&help.stdout).into_owned();
        assert!(
            text.contains(&format!("optimize {kind} problems/{kind}/")),
            "{text}"
        );
    }
}

#[test]
fn cmc_problem_file_starts_from_a_shipped_glb() {
    // problems/cmc/double_bubble_gltf.toml imports double_bubble_start.glb (the generator's
    // resolution-3 double bubble written by benches/drivers/cmc_start_glb.rs): it must solve to the
    // same area as the generated start, tests/golden/problems/cmc/double_bubble_short.toml.
    // The areas are compared in the area formulation, whose minimum is the discrete problem's
    // own (every coordinate free): the default normal coordinates end their tangential
    // relaxation when a round gains ≤ 1e-5 of the area, so their final area depends on the path
    // at that level (measured: 1.4e-6 apart here), not only on the mesh.
    let scratch = Scratch::new("gltf");
    let run = |file: &str, dir: &str, extra: &[&str]| -> serde_json::Value {
        let out_dir = scratch.0.join(dir);
        let out = run_into("cmc", file, &out_dir, &[&["--json"], extra].concat());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{file}: {stderr}");
        assert!(out_dir.join("model.glb").is_file());
        serde_json::from_slice(&out.stdout).expect("--json prints the summary")
    };
    let imported = run("problems/cmc/double_bubble_gltf.toml", "imported", &[]);
    assert_eq!(imported["status"], "Optimal", "{imported}");
    let area_formulation = ["--set", "formulation=\"area\""];
    let imported_area = run(
        "problems/cmc/double_bubble_gltf.toml",
        "imported_area",
        &area_formulation,
    );
    let generated_area = run(
        "tests/golden/problems/cmc/double_bubble_short.toml",
        "generated_area",
        &area_formulation,
    );
    let area = |v: &serde_json::Value| v["objective"].as_f64().unwrap();
    let (a, b) = (area(&imported_area), area(&generated_area));
    assert!(
        (a / b - 1.0).abs() < 1e-9,
        "imported {a} m², generated {b} m²"
    );
    // The default formulation ends within its relaxation's 1e-5 of that minimum, above it.
    let a = area(&imported);
    assert!(a >= b * (1.0 - 1e-12) && a < b * (1.0 + 1e-5), "{a} vs {b}");
    // Above the exact standard double bubble (11.854293128 cm²) by the coarse mesh's excess.
    assert!(a > 11.854293128e-4 && a < 1.025 * 11.854293128e-4, "{a}");
    let f = &imported["figures"];
    assert_eq!(f["surfaces"].as_array().unwrap().len(), 3, "{f}");
    for v in f["volumes"].as_array().unwrap() {
        let (got, want) = (v["volume"].as_f64().unwrap(), v["target"].as_f64().unwrap());
        assert!((got / want - 1.0).abs() < 1e-6, "{v}");
    }

    // A volume naming a surface the .glb does not have is a positioned input error.
    let glb = Path::new(env!("CARGO_MANIFEST_DIR")).join("problems/cmc/double_bubble_start.glb");
    std::fs::copy(&glb, scratch.0.join("double_bubble_start.glb")).unwrap();
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("problems/cmc/double_bubble_gltf.toml"),
    )
    .unwrap()
    .replace("\"-wall\"", "\"-partition\"");
    let path = scratch.file("bad_surface.toml", &text);
    let out = optimize(&["cmc", path.to_str().unwrap(), "--check", "-q"]);
    assert_input_error(
        &out,
        &path,
        Some(line_of(&text, "\"-partition\"")),
        &["no surface `partition`", "left, wall, right"],
    );
}

#[test]
fn cmc_stability_table_sets_the_eigenvalues_reported_or_switches_the_analysis_off() {
    let scratch = Scratch::new("stability");
    let short = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/golden/problems/cmc/double_bubble_short.toml"),
    )
    .unwrap();
    let solve = |tag: &str, table: &str| -> serde_json::Value {
        let path = scratch.file(&format!("{tag}.toml"), &format!("{short}\n{table}"));
        solved("cmc", path.to_str().unwrap(), &scratch.0.join(tag), &[])
    };
    // Default: six eigenvalues, each with its error bound within the stated precision.
    let default = solve("default", "");
    let s = &default["figures"]["stability"];
    let values: Vec<f64> = serde_json::from_value(s["smallest_eigenvalues"].clone()).unwrap();
    let errors: Vec<f64> = serde_json::from_value(s["eigenvalue_errors"].clone()).unwrap();
    assert_eq!((values.len(), errors.len()), (6, 6), "{s}");
    assert_eq!(s["relative_precision"], 1e-6, "{s}");
    let largest = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for e in &errors {
        assert!(*e >= 0.0 && *e <= 1e-6 * largest, "{s}");
    }
    // Two eigenvalues: the same two smallest, within their bounds.
    let two = solve("two", "[stability]\neigenvalues = 2\n");
    let s2 = &two["figures"]["stability"];
    let fewer: Vec<f64> = serde_json::from_value(s2["smallest_eigenvalues"].clone()).unwrap();
    assert_eq!(fewer.len(), 2, "{s2}");
    for (a, b) in fewer.iter().zip(&values) {
        assert!((a - b).abs() <= 2e-6 * largest, "{s2} {s}");
    }
    assert_eq!(s2["verdict"], "stable", "{s2}");
    // 0: no analysis, the same solution.
    let off = solve("off", "[stability]\neigenvalues = 0\n");
    assert!(off["figures"].get("stability").is_none(), "{off}");
    assert_eq!(off["objective"], default["objective"]);
    // A misspelt key and an out-of-range count are positioned input errors.
    for (text, needle, expected) in [
        (
            "[stability]\neigenvalue = 3\n",
            "eigenvalue =",
            "did you mean `eigenvalues`",
        ),
        (
            "[stability]\neigenvalues = 51\n",
            "eigenvalues = 51",
            "`eigenvalues` must be between 0 and 50, got 51",
        ),
    ] {
        let text = format!("{short}\n{text}");
        let path = scratch.file("bad.toml", &text);
        let out = optimize(&["cmc", path.to_str().unwrap(), "--check", "-q"]);
        assert_input_error(&out, &path, Some(line_of(&text, needle)), &[expected]);
    }
}

/// Every file under `dir` (recursively) by its path relative to `dir`, with its bytes.
fn snapshot(dir: &Path) -> std::collections::BTreeMap<PathBuf, Vec<u8>> {
    let mut files = std::collections::BTreeMap::new();
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        if path.is_dir() {
            for (inner, bytes) in snapshot(&path) {
                files.insert(Path::new(&entry.file_name()).join(inner), bytes);
            }
        } else {
            files.insert(entry.file_name().into(), std::fs::read(&path).unwrap());
        }
    }
    files
}

#[test]
fn a_write_failing_at_any_step_over_an_older_run_leaves_that_run_whole() {
    let scratch = Scratch::new("write-failure");
    let out_dir = scratch.0.join("run");
    solved("truss", SHIPPED, &out_dir, &[]);
    let old = snapshot(&out_dir);
    // A different run (stopped after 2 iterations) fails at each of its file writes in turn,
    // then at the move of its complete folder into place.
    let args = run_args("truss", SHIPPED, &out_dir, &["--max-iter", "2"]);
    for step in 0..=old.len() {
        let failed = Command::new(env!("CARGO_BIN_EXE_optimize"))
            .args(&args)
            .env("OPTIMIZE_FAIL_WRITE_AFTER", step.to_string())
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&failed.stderr);
        assert_eq!(failed.status.code(), Some(1), "step {step}: {stderr}");
        assert!(stderr.contains("injected"), "step {step}: {stderr}");
        assert!(
            snapshot(&out_dir) == old,
            "step {step}: the older run changed"
        );
        let leftovers: Vec<_> = std::fs::read_dir(&scratch.0).unwrap().flatten().collect();
        assert_eq!(leftovers.len(), 1, "step {step}: temporaries left");
    }
    // Without the failure the new run replaces the old one as a whole.
    let new = optimize(&args);
    assert_eq!(new.status.code(), Some(3));
    let written = snapshot(&out_dir);
    assert_eq!(
        written.keys().collect::<Vec<_>>(),
        old.keys().collect::<Vec<_>>()
    );
    assert_eq!(read_result(&out_dir)["status"], "IterationLimit");
    let summary = Path::new("result.json");
    assert_ne!(written[summary], old[summary]);
}

#[test]
fn check_after_a_solve_leaves_the_solved_run_intact() {
    let scratch = Scratch::new("check-after-solve");
    let out_dir = scratch.0.join("run");
    let out = out_dir.to_str().unwrap();
    let solve = run_into("truss", SHIPPED, &out_dir, &[]);
    assert_eq!(solve.status.code(), Some(0));
    let solved = std::fs::read(out_dir.join("result.json")).unwrap();
    let model = std::fs::read(out_dir.join("model.glb")).unwrap();
    let check = optimize(&["truss", SHIPPED, "--check", "-q", "-o", out]);
    assert_eq!(check.status.code(), Some(0));
    assert_eq!(std::fs::read(out_dir.join("result.json")).unwrap(), solved);
    assert_eq!(std::fs::read(out_dir.join("model.glb")).unwrap(), model);
    let checked = std::fs::read_to_string(out_dir.join("check").join("result.json")).unwrap();
    assert!(checked.contains("\"status\": \"Checked\""), "{checked}");
}

#[test]
fn an_iteration_limit_on_a_coarse_level_writes_the_best_result_and_exits_3() {
    let scratch = Scratch::new("coarse-limit");
    let out = scratch.0.join("run");
    let file = "problems/cmc/octahedron_hexagon.toml";
    // Each normal-coordinate round of the first level converges within 3 iterations.
    let run = run_into("cmc", file, &out, &["--max-iter", "2"]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(3), "{stderr}");
    let summary = read_result(&out);
    assert_eq!(summary["status"], "IterationLimit", "{summary}");
    assert!(out.join("model.glb").is_file());
}

#[test]
fn a_run_reports_its_answer_in_the_users_unit() {
    // warren_bridge's NLP minimizes mass / M; the user sees the mass in kg everywhere.
    let scratch = Scratch::new("headline");
    let out = optimize(&[
        "truss",
        "problems/truss/warren_bridge.toml",
        "--threads",
        "1",
        "-o",
        scratch.0.to_str().unwrap(),
    ]);
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    let summary = read_result(&scratch.0);
    let headline = &summary["headline"];
    let mass = summary["figures"]["mass_kg"].as_f64().unwrap();
    assert_eq!(
        (&headline["name"], &headline["unit"]),
        (&"mass".into(), &"kg".into())
    );
    let value = headline["value"].as_f64().unwrap();
    assert!((value / mass - 1.0).abs() < 1e-9, "{value} vs {mass}");
    // Seven significant digits in plain notation (the shipped bridge weighs thousands of kg).
    assert!((1e3..1e4).contains(&value), "{value}");
    assert!(stdout.contains(&format!("mass {value:.3} kg")), "{stdout}");
    // The log opens with the problem's size and closes with the statistics block.
    let first = stderr.lines().next().unwrap();
    assert!(
        first.contains(" variables, ") && first.contains("Jacobian nonzeros"),
        "{first}"
    );
    assert!(
        stderr.contains(&format!("Final mass ................: {value:.9e} kg")),
        "{stderr}"
    );
    // iterations.csv: the solve and stage columns, the objective in kg.
    let csv = std::fs::read_to_string(scratch.0.join("iterations.csv")).unwrap();
    assert!(csv.starts_with("solve,stage,iter,objective,"), "{csv}");
    let last: Vec<&str> = csv.lines().last().unwrap().split(',').collect();
    let logged: f64 = last[3].parse().unwrap();
    assert!((logged / value - 1.0).abs() < 1e-9, "{logged} vs {value}");
    let plot = std::fs::read_to_string(scratch.0.join("convergence.svg")).unwrap();
    assert!(
        plot.contains("mass [kg]") && plot.contains("<polyline"),
        "{plot}"
    );
}

#[test]
fn version_names_the_package_version_and_the_commit() {
    let out = optimize(&["--version"]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let prefix = concat!("optimize ", env!("CARGO_PKG_VERSION"), " (commit ");
    assert!(text.starts_with(prefix), "{text}");
    let commit = text
        .trim_end()
        .strip_prefix(prefix)
        .and_then(|t| t.strip_suffix(')'));
    // A hexadecimal hash (possibly marked -dirty), or `unknown` outside a git checkout.
    let commit = commit.unwrap_or_else(|| panic!("{text}"));
    let hash = commit.strip_suffix("-dirty").unwrap_or(commit);
    assert!(
        hash == "unknown" || (hash.len() >= 7 && hash.chars().all(|c| c.is_ascii_hexdigit())),
        "{text}"
    );
}

/// Runs `optimize --check` on the cmc cushion with `sets` as `--set` arguments and returns the
/// check's summary.
fn checked_cushion_with(scratch: &Scratch, sets: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "cmc",
        "problems/cmc/tennis_cushion.toml",
        "--check",
        "-q",
        "-o",
        scratch.0.to_str().unwrap(),
    ];
    for s in sets {
        args.extend(["--set", s]);
    }
    let out = optimize(&args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{sets:?}: {stderr}");
    let text = std::fs::read_to_string(scratch.0.join("check").join("result.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn set_overrides_a_file_value_and_is_recorded() {
    let scratch = Scratch::new("set");
    let plain = checked_cushion_with(&scratch, &[]);
    assert!(plain.get("overrides").is_none(), "{plain}");
    // The file says resolution = 8; halving it quarters the mesh.
    let coarse = checked_cushion_with(&scratch, &["resolution=4", "solver.max_iterations=7"]);
    let variables = |v: &serde_json::Value| v["figures"]["variables"].as_u64().unwrap();
    assert!(
        variables(&coarse) * 3 < variables(&plain),
        "{} vs {}",
        variables(&coarse),
        variables(&plain)
    );
    assert_eq!(
        coarse["overrides"],
        serde_json::json!(["resolution=4", "solver.max_iterations=7"])
    );
    // A [solver] key the file does not have: the table is created, the value validated.
    let extra = ["--set", "solver.max_iterations=1", "--rounds", "1"];
    let truss = run_into("truss", SHIPPED, &scratch.0.join("truss"), &extra);
    assert_eq!(
        truss.status.code(),
        Some(3),
        "one iteration does not converge"
    );
    let summary = read_result(&scratch.0.join("truss"));
    assert_eq!(summary["iterations"], 1, "{summary}");
}

#[test]
fn set_errors_name_the_argument() {
    for (set, expected) in [
        (
            "resoluton=8",
            "error: --set resoluton=8: unknown key `resoluton`; did you mean `resolution`?",
        ),
        (
            "resolution=0",
            "error: --set resolution=0: `resolution` must be between 1 and 64, got 0",
        ),
        (
            "solver.max_iterations=abc",
            "error: --set solver.max_iterations=abc: wrong type: found string \"abc\"",
        ),
        (
            "solver.tolerance=2.0",
            "error: --set solver.tolerance=2.0: `tolerance` must be in (0, 1), got 2",
        ),
        ("shape=1", "error: --set shape=1: `shape` is a table"),
        (
            "solver.tolerance=inf",
            "error: --set solver.tolerance=inf: `tolerance` must be finite",
        ),
    ] {
        let out = optimize(&[
            "cmc",
            "problems/cmc/tennis_cushion.toml",
            "--check",
            "-q",
            "--set",
            set,
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{set}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.starts_with(expected), "{set}: {stderr}");
    }
    // Malformed arguments are usage errors.
    let out = optimize(&[
        "cmc",
        "problems/cmc/tennis_cushion.toml",
        "--set",
        "resolution",
    ]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn a_file_error_keeps_its_position_under_set() {
    // `--set seed=3` goes in as a new first line; the file's own error stays at its line.
    let scratch = Scratch::new("set-position");
    let text = shipped().replacen("min_length", "min_lenght", 1);
    let path = scratch.file("bad.toml", &text);
    let out = optimize(&["truss", path.to_str().unwrap(), "--set", "seed=3"]);
    assert_input_error(
        &out,
        &path,
        Some(line_of(&text, "min_lenght")),
        &["did you mean `min_length`"],
    );
}

/// The `result.json` written into `dir`.
fn read_result(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("result.json")).unwrap()).unwrap()
}

/// The arguments of a quiet one-thread run of `file` of `kind` into `dir`, `extra` flags after.
fn run_args<'a>(kind: &'a str, file: &'a str, dir: &'a Path, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        kind,
        file,
        "-q",
        "--threads",
        "1",
        "-o",
        dir.to_str().unwrap(),
    ];
    args.extend(extra);
    args
}

/// Runs `file` of `kind` quietly on one thread into `dir`, `extra` flags after.
fn run_into(kind: &str, file: &str, dir: &Path, extra: &[&str]) -> Output {
    optimize(&run_args(kind, file, dir, extra))
}

/// Solves `file` of `kind` into `dir` (extra flags after), expecting exit 0; returns result.json.
fn solved(kind: &str, file: &str, dir: &Path, extra: &[&str]) -> serde_json::Value {
    let out = run_into(kind, file, dir, extra);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{kind} {file} {extra:?}: {stderr}"
    );
    read_result(dir)
}

#[test]
fn every_kind_restarts_from_its_result_at_once() {
    let scratch = Scratch::new("start");
    for (kind, file, extra) in [
        ("truss", SHIPPED, &[][..]),
        (
            "gait",
            "tests/golden/problems/gait/pogo_crouch_short.toml",
            &["--trial", "1"][..],
        ),
        ("cmc", "problems/cmc/tennis_cushion.toml", &[][..]),
    ] {
        let first_dir = scratch.0.join(kind).join("first");
        let first = solved(kind, file, &first_dir, extra);
        let result = first_dir.join("result.json");
        let again = solved(
            kind,
            file,
            &scratch.0.join(kind).join("again"),
            &["--start", result.to_str().unwrap()],
        );
        let (a, b) = (
            first["headline"]["value"].as_f64().unwrap(),
            again["headline"]["value"].as_f64().unwrap(),
        );
        let iterations = again["iterations"].as_u64().unwrap();
        assert!(
            iterations <= 3 && iterations < first["iterations"].as_u64().unwrap(),
            "{kind}: {iterations} iterations from the result, {} from the file",
            first["iterations"]
        );
        assert_eq!(again["status"], "Optimal", "{kind}: {again}");
        // cmc minimizes area plus the tangential regularization, whose projectors are frozen
        // at the solve's start: from another start the area may move by up to that term.
        let tolerance = match kind {
            "cmc" => {
                let f = &first["figures"];
                let l = f["length_scale"].as_f64().unwrap();
                f["regularization"].as_f64().unwrap() * l * l / a
            }
            _ => 1e-9,
        };
        assert!(
            (b / a - 1.0).abs() <= tolerance,
            "{kind}: {b} from the result, {a} from the file (tolerance {tolerance:e})"
        );
    }
}

#[test]
fn a_result_of_another_problem_kind_or_size_is_refused() {
    let scratch = Scratch::new("start-mismatch");
    let truss_dir = scratch.0.join("truss");
    solved("truss", SHIPPED, &truss_dir, &["--rounds", "1"]);
    let cmc_dir = scratch.0.join("cmc");
    solved("cmc", "problems/cmc/tennis_cushion.toml", &cmc_dir, &[]);
    let truss_result = truss_dir.join("result.json");
    let cmc_result = cmc_dir.join("result.json");
    let out_dir = scratch.0.join("x");
    for (args, result, expected) in [
        (
            vec!["truss", "problems/truss/roof_warren.toml"],
            &truss_result,
            "a result of truss problem `roof_fink`, not of truss problem `roof_warren`",
        ),
        (
            vec!["cmc", "problems/cmc/tennis_cushion.toml"],
            &truss_result,
            "a result of truss problem `roof_fink`, not of cmc problem `tennis_cushion`",
        ),
        (
            vec![
                "cmc",
                "problems/cmc/tennis_cushion.toml",
                "--set",
                "resolution=4",
            ],
            &cmc_result,
            "does not fit this problem's start mesh (45 vertices, 64 triangles)",
        ),
    ] {
        let mut args = args.clone();
        args.extend(["-q", "-o", out_dir.to_str().unwrap()]);
        args.extend(["--start", result.to_str().unwrap()]);
        let out = optimize(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(
            stderr.starts_with(&format!("error: {}: ", result.display()))
                && stderr.contains(expected),
            "{args:?}: {stderr}"
        );
    }
}

#[test]
fn an_output_folder_that_cannot_be_written_exits_1() {
    // `-o` under a regular file: the run's folder cannot be created.
    let scratch = Scratch::new("unwritable");
    let file = scratch.file("plain.txt", "not a folder");
    let out_dir = file.join("run");
    let out = run_into("truss", SHIPPED, &out_dir, &["--rounds", "1"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with("error: "), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// Runs the binary with `args` from the crate root, sends it SIGINT (what Ctrl-C sends) after
/// `delay`, and returns its output and how long it took to exit after the signal.
#[cfg(unix)]
fn interrupted_after(args: &[&str], delay: std::time::Duration) -> (Output, std::time::Duration) {
    let child = Command::new(env!("CARGO_BIN_EXE_optimize"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("the binary runs");
    std::thread::sleep(delay);
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(kill.success());
    let started = std::time::Instant::now();
    let out = child.wait_with_output().unwrap();
    (out, started.elapsed())
}

#[cfg(unix)]
#[test]
fn ctrl_c_writes_the_best_point_so_far_and_exits_130() {
    // Eight pogo trials take a minute and more; SIGINT stops them at their next poll.
    let scratch = Scratch::new("interrupt");
    let out_dir = scratch.0.join("run");
    let args = run_args("gait", "problems/gait/pogo_crouch.toml", &out_dir, &[]);
    let (out, took) = interrupted_after(&args, std::time::Duration::from_millis(1500));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(took.as_secs_f64() < 10.0, "stopped after {took:?}");
    let summary = read_result(&out_dir);
    assert_eq!(summary["status"], "Interrupted", "{summary}");
    assert!(out_dir.join("model.glb").is_file());
}

#[cfg(unix)]
#[test]
fn ctrl_c_inside_a_long_rollout_of_a_check_exits_130_at_once() {
    // Tasks at 25 s with dt = 5e-4 s: 50,000 RK4 steps per rollout, and `--check` takes half a
    // minute; SIGINT after 1.5 s lands inside a rollout, which polls every few steps.
    let scratch = Scratch::new("interrupt-rollout");
    let out_dir = scratch.0.join("run");
    let mut args = vec!["gait", "problems/gait/pogo_crouch.toml", "--check", "-q"];
    args.extend(["--threads", "1", "--set", "controls.horizon=25"]);
    let tasks = [
        "task.0.time=25",
        "task.1.time=25",
        "task.2.time=25",
        "task.3.time=25",
    ];
    for task in &tasks {
        args.extend(["--set", task]);
    }
    args.extend(["-o", out_dir.to_str().unwrap()]);
    let (out, took) = interrupted_after(&args, std::time::Duration::from_millis(1500));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(took.as_secs_f64() < 3.0, "stopped after {took:?}");
    let summary = read_result(&out_dir.join("check"));
    assert_eq!(summary["status"], "Interrupted", "{summary}");
}

#[test]
fn truss_glb_shows_every_working_beam_with_its_figures() {
    let scratch = Scratch::new("truss-glb");
    let summary = solved("truss", SHIPPED, &scratch.0, &[]);
    let bytes = std::fs::read(scratch.0.join("model.glb")).unwrap();
    let doc = optimize::io::gltf_read::read_slice(&bytes, None)
        .unwrap()
        .document;
    // Extras are read from the GLB's JSON chunk (length at bytes 12..16, text from byte 20).
    let length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + length]).unwrap();
    let beams: Vec<&serde_json::Value> = json["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|n| n["name"].as_str().unwrap().starts_with("beam "))
        .collect();
    let active = summary["figures"]["active_beams"].as_u64().unwrap() as usize;
    assert_eq!(beams.len(), active, "{}", json["nodes"]);
    let mass: f64 = beams
        .iter()
        .map(|n| n["extras"]["mass_kg"].as_f64().unwrap())
        .sum();
    let total = summary["headline"]["value"].as_f64().unwrap();
    // Idle beams (below 1e-3 of the largest force) are left out: they weigh next to nothing.
    assert!((mass / total - 1.0).abs() < 1e-3, "{mass} kg of {total} kg");
    // Every beam drawn at least 0.4 % of the joints' bounding-box diagonal thick (a 12-sided
    // prism: its narrowest width is cos 15° of the diameter).
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for joint in summary["figures"]["design"]["joints"].as_array().unwrap() {
        for k in 0..3 {
            let x = joint["position"][k].as_f64().unwrap();
            (lo[k], hi[k]) = (lo[k].min(x), hi[k].max(x));
        }
    }
    let diagonal = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    let cases = summary["figures"]["load_cases"].as_array().unwrap().len();
    for (node, beam) in doc.nodes().zip(&beams) {
        let bbox = node
            .mesh()
            .unwrap()
            .primitives()
            .next()
            .unwrap()
            .bounding_box();
        let thickness = (0..3)
            .map(|k| f64::from(bbox.max[k] - bbox.min[k]))
            .fold(f64::INFINITY, f64::min);
        let least = 2.0 * 0.004 * diagonal * (std::f64::consts::PI / 12.0).cos();
        assert!(
            thickness >= least * (1.0 - 1e-6),
            "{beam}: {thickness} m thick"
        );
        assert_eq!(beam["extras"]["force_n"].as_array().unwrap().len(), cases);
        assert!(beam["extras"]["radius_m"].as_f64().unwrap() > 0.0);
    }
}

#[test]
fn every_kind_writes_a_model_and_a_picture() {
    // README's output list: model.glb and a picture for every kind, collocation included.
    let scratch = Scratch::new("pictures");
    for (kind, file, picture, extra) in [
        ("truss", SHIPPED, "preview.svg", &["--rounds", "1"][..]),
        (
            "cmc",
            "problems/cmc/tennis_cushion.toml",
            "preview.svg",
            &[][..],
        ),
        (
            "gait",
            "tests/golden/problems/gait/pogo_crouch_short.toml",
            "filmstrip.svg",
            &["--trial", "1"][..],
        ),
        ("gait", "problems/gait/ball.toml", "filmstrip.svg", &[][..]),
    ] {
        let dir = scratch.0.join(Path::new(file).file_stem().unwrap());
        let summary = solved(kind, file, &dir, extra);
        let svg = std::fs::read_to_string(dir.join(picture)).unwrap();
        let problem = summary["problem"].as_str().unwrap();
        assert!(
            svg.starts_with("<svg") && svg.contains(&format!("{problem}: ")),
            "{file}"
        );
        let doc = optimize::io::gltf_read::read_file(&dir.join("model.glb"))
            .unwrap()
            .document;
        assert!(doc.meshes().count() >= 1, "{file}");
        if kind == "gait" {
            assert_eq!(doc.animations().count(), 1, "{file}: animated");
        }
    }
}

#[test]
fn completions_and_man_pages_describe_every_command() {
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let out = optimize(&["completions", shell]);
        assert_eq!(out.status.code(), Some(0), "{shell}");
        let script = String::from_utf8_lossy(&out.stdout);
        for word in ["truss", "gait", "cmc", "set", "start", "rounds", "max-iter"] {
            assert!(script.contains(word), "{shell}: no {word}");
        }
    }
    assert_eq!(optimize(&["completions", "tcsh"]).status.code(), Some(2));
    let page = optimize(&["man"]);
    assert_eq!(page.status.code(), Some(0));
    let page = String::from_utf8_lossy(&page.stdout);
    assert!(
        page.starts_with(".ie") && page.contains(".TH optimize 1"),
        "{page}"
    );
    assert!(page.contains("Exit codes: 0 converged"), "{page}");
    let scratch = Scratch::new("man");
    let dir = scratch.0.join("man1");
    assert_eq!(
        optimize(&["man", dir.to_str().unwrap()]).status.code(),
        Some(0)
    );
    for kind in ["gait", "truss", "cmc"] {
        let page = std::fs::read_to_string(dir.join(format!("optimize-{kind}.1"))).unwrap();
        assert!(
            page.contains("\\-\\-set") && page.contains("\\-\\-start"),
            "{kind}: {page}"
        );
    }
}
