//! Regressions for bad input found by mutation fuzzing: each is refused before any work, with a
//! one-line positioned error and exit code 2, instead of a panic, an abort or an unbounded run.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn optimize(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_optimize"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the binary runs")
}

/// `problem` (a shipped file) with `from` replaced by `to`, written to a scratch file.
fn mutant(problem: &str, from: &str, to: &str, tag: &str) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join(problem)).unwrap();
    assert!(text.contains(from), "{problem} has `{from}`");
    let dir = std::env::temp_dir().join(format!("optimize-bounds-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{tag}.toml"));
    std::fs::write(&path, text.replacen(from, to, 1)).unwrap();
    path
}

/// Exit 2, one stderr line `error: file:line:col: ...` containing every fragment.
fn assert_positioned(out: &Output, expected: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    let position = stderr.split(".toml:").nth(1).unwrap_or("");
    let mut parts = position.split(':');
    assert!(
        parts.next().is_some_and(|l| l.parse::<usize>().is_ok())
            && parts.next().is_some_and(|c| c.parse::<usize>().is_ok()),
        "no line:col in {stderr}"
    );
    for e in expected {
        assert!(stderr.contains(e), "`{e}` not in {stderr}");
    }
}

fn check(kind: &str, path: &Path) -> Output {
    optimize(&[
        kind,
        path.to_str().unwrap(),
        "--check",
        "--threads",
        "1",
        "-q",
    ])
}

#[test]
fn a_huge_lattice_margin_is_refused_before_allocating() {
    let p = mutant(
        "problems/truss/roof_fink.toml",
        "spacing = 1.0 ",
        "margin = 1e6\nspacing = 1.0 ",
        "margin",
    );
    assert_positioned(
        &check("truss", &p),
        &["`margin` would generate", "limit 5e3"],
    );
}

#[test]
fn a_huge_random_count_is_refused() {
    let p = mutant(
        "problems/truss/roof_fink.toml",
        "kind = \"lattice\"\nspacing = 1.0 ",
        "kind = \"random\"\ncount = 1000000000000\n#",
        "random",
    );
    assert_positioned(&check("truss", &p), &["`count` would generate 1e12 joints"]);
}

#[test]
fn extra_array_elements_and_nan_are_positioned_errors() {
    let p = mutant(
        "problems/gait/pogo_crouch.toml",
        "gravity = [0.0, -9.81, 0.0]",
        "gravity = [0.0, -9.81, 0.0, 5.0]",
        "gravity",
    );
    assert_positioned(&check("gait", &p), &["expected 3 elements, found 4"]);
    let p = mutant(
        "problems/gait/pogo_crouch.toml",
        "gravity = [0.0, -9.81, 0.0]",
        "gravity = [0.0, nan, 0.0]",
        "nan",
    );
    assert_positioned(&check("gait", &p), &["`gravity` must be finite, got nan"]);
}

#[test]
fn a_long_gait_task_is_refused_in_rk4_steps() {
    let p = mutant(
        "problems/gait/pogo_crouch.toml",
        "time = ",
        "time = 1e6 #",
        "long",
    );
    assert_positioned(&check("gait", &p), &["RK4 steps", "limit 5e4"]);
}

#[test]
fn a_contact_point_below_the_ground_is_an_input_error() {
    let p = mutant(
        "problems/gait/pogo_crouch.toml",
        "contacts = [[-0.03, 0.0, 0.0]",
        "contacts = [[-0.03, -0.5, 0.0]",
        "below",
    );
    assert_positioned(&check("gait", &p), &["below the ground"]);
}

#[test]
fn out_of_range_trial_and_threads_are_usage_errors() {
    let out = optimize(&[
        "gait",
        "problems/gait/pogo_crouch.toml",
        "--trial",
        "99",
        "-q",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--trial 99"), "{stderr}");
    let out = optimize(&[
        "truss",
        "problems/truss/roof_fink.toml",
        "--check",
        "--threads",
        "100000",
    ]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn an_obj_bubble_with_one_reversed_face_is_refused() {
    let dir = std::env::temp_dir().join(format!("optimize-obj-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // An octahedron with its last face reversed.
    let obj = "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\ng bubble\n\
               f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 6 4\n";
    std::fs::write(dir.join("b.obj"), obj).unwrap();
    let toml = "[shape]\ntype = \"obj\"\nfile = \"b.obj\"\n\
                [[shape.volume]]\nname = \"v\"\nsurfaces = [\"bubble\"]\nvolume = 1.0\n";
    std::fs::write(dir.join("b.toml"), toml).unwrap();
    let out = check("cmc", &dir.join("b.toml"));
    assert_positioned(&out, &["face 8 of surface `bubble` is wound against"]);
    // Every face reversed: consistent, but the volume is negative.
    let reversed: String = obj
        .lines()
        .map(|l| match l.strip_prefix("f ") {
            Some(f) => format!("f {}\n", f.split(' ').rev().collect::<Vec<_>>().join(" ")),
            None => format!("{l}\n"),
        })
        .collect();
    let reversed = reversed.replace("f 4 6 1", "f 1 6 4");
    std::fs::write(dir.join("b.obj"), reversed).unwrap();
    let out = check("cmc", &dir.join("b.toml"));
    assert_positioned(&out, &["enclose -"]);
}

/// Exit 2 with the error at the 1-based line and column where `needle` first occurs in `path`,
/// and its message containing `fragment`.
fn assert_at(out: &Output, path: &Path, needle: &str, fragment: &str) {
    let text = std::fs::read_to_string(path).unwrap();
    let offset = text.find(needle).expect("the needle is in the file");
    let line = text[..offset].matches('\n').count() + 1;
    let col = offset - text[..offset].rfind('\n').map_or(0, |i| i + 1) + 1;
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(&format!(".toml:{line}:{col}: ")) && stderr.contains(fragment),
        "expected `{fragment}` at {line}:{col}: {stderr}"
    );
}

#[test]
fn errors_inside_shape_tables_point_at_the_key_or_value() {
    // (kind, problem, text, its mutation, where the error must point, what it must say)
    let cases = [
        (
            "cmc",
            "problems/cmc/catenoid.toml",
            "radius = 1.0 ",
            "radius = 1.0\nbogus = 1 ",
            "bogus",
            "unknown key `bogus`",
        ),
        (
            "cmc",
            "problems/cmc/catenoid.toml",
            "separation = 1.0",
            "separation = \"far\"",
            "\"far\"",
            "wrong type",
        ),
        (
            "gait",
            "problems/gait/pogo_crouch.toml",
            "size = [0.06, 0.20, 0.03]",
            "size = [0.06, 0.20, 0.03, 1.0]",
            "[0.06, 0.20, 0.03, 1.0]",
            "expected 3 elements, found 4",
        ),
        (
            "gait",
            "problems/gait/ball.toml",
            "height = 2.0",
            "height = -2.0",
            "height = -2.0",
            "`height` must be positive m",
        ),
    ];
    for (i, (kind, problem, from, to, needle, fragment)) in cases.into_iter().enumerate() {
        let p = mutant(problem, from, to, &format!("shape-{i}"));
        assert_at(&check(kind, &p), &p, needle, fragment);
    }
}
