//! Stamps the build with the commit it was built from (`optimize --version`): the short hash of
//! `git rev-parse HEAD`, with `-dirty` when the work tree has changes, or `unknown` outside a
//! git checkout (e.g. a source package). The dirty flag is refreshed when `src/` changes.

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    let commit = match git(&["rev-parse", "--short=10", "HEAD"]) {
        Some(hash) if !hash.is_empty() => {
            let dirty = git(&["status", "--porcelain", "--untracked-files=no"])
                .is_some_and(|s| !s.is_empty());
            if dirty { format!("{hash}-dirty") } else { hash }
        }
        _ => "unknown".to_string(),
    };
    println!("cargo:rustc-env=OPTIMIZE_COMMIT={commit}");
    // Rerun when HEAD moves (a commit, a checkout) or the sources change; not on every index
    // refresh, which would rebuild the whole crate after `git status`. Paths come from git, so
    // a linked worktree (where `.git` is a file) works too; a path that does not exist would
    // make cargo rerun this script on every build, so only existing ones are printed.
    let head_ref = git(&["symbolic-ref", "-q", "HEAD"]);
    let watched = ["HEAD", "packed-refs"]
        .into_iter()
        .map(str::to_string)
        .chain(head_ref)
        .filter_map(|name| git(&["rev-parse", "--git-path", &name]));
    for path in watched {
        if std::path::Path::new(&path).exists() {
            println!("cargo:rerun-if-changed={path}");
        }
    }
    println!("cargo:rerun-if-changed=src");
    println!("cargo:rerun-if-changed=build.rs");
}
