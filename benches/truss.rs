//! Truss solve times: whole runs (`optimize::truss::run`: staged layout-LP start, then the
//! geometry and sizing SQP, then export) of the shipped examples, warren_bridge also with its
//! former solver settings (L-BFGS, sparse QP), the largest example (cooling_tower, 2592
//! variables) with ten flat samples, and the layout LP alone.
//! Figures go to BENCHMARKS.md (truss section).

use std::path::Path;

use criterion::{Criterion, SamplingMode, criterion_group, criterion_main};
use optimize::outcome::RunOptions;
use optimize::truss::{load, start};

/// Examples timed as whole runs: warren_bridge (the sub-second target), michell (a
/// sphere obstacle) and the two cranes (random ground structures, seven pruning rounds). The
/// largest example has its own flat-sampled case ([`cooling_tower`]); the other large ones are
/// tabulated from single CLI runs (BENCHMARKS.md, truss).
const RUNS: [&str; 4] = ["warren_bridge", "michell", "crane_tripod", "crane_derrick"];

fn path(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("problems/truss")
        .join(format!("{name}.toml"))
}

/// warren_bridge as it was solved before the exact Hessian's reduced-space convexification:
/// limited-memory BFGS with the sparse QP (the file's `[solver]` table rewritten into a copy
/// in the temporary directory), for a before/after ratio within one bench run.
fn warren_lbfgs(c: &mut Criterion) {
    let text = std::fs::read_to_string(path("warren_bridge")).expect("reads");
    let text = text
        .replace("hessian = \"exact\"", "hessian = \"lbfgs\"")
        .replace("qp = \"auto\"", "qp = \"sparse\"");
    let copy = std::env::temp_dir().join("warren_bridge_lbfgs.toml");
    std::fs::write(&copy, text).expect("writes");
    let problem = load(&copy).expect("loads");
    let opts = RunOptions {
        quiet: true,
        ..Default::default()
    };
    c.bench_function("truss run warren_bridge lbfgs", |b| {
        b.iter(|| optimize::truss::run(&problem, &opts).expect("runs"))
    });
}

fn runs(c: &mut Criterion) {
    for name in RUNS {
        let problem = load(&path(name)).expect("loads");
        let opts = RunOptions {
            quiet: true,
            ..Default::default()
        };
        c.bench_function(&format!("truss run {name}"), |b| {
            b.iter(|| optimize::truss::run(&problem, &opts).expect("runs"))
        });
    }
}

/// cooling_tower, the largest example (2592 variables on its ground structure; the issue's
/// "< 30 s" target): a run takes seconds, so each of the ten samples is one run.
fn cooling_tower(c: &mut Criterion) {
    let problem = load(&path("cooling_tower")).expect("loads");
    let opts = RunOptions {
        quiet: true,
        ..Default::default()
    };
    let mut group = c.benchmark_group("truss large");
    group.sampling_mode(SamplingMode::Flat).sample_size(10);
    group.bench_function("truss run cooling_tower", |b| {
        b.iter(|| optimize::truss::run(&problem, &opts).expect("runs"))
    });
    group.finish();
}

fn layout(c: &mut Criterion) {
    for name in ["warren_bridge", "michell"] {
        let problem = load(&path(name)).expect("loads");
        let model = problem.model();
        c.bench_function(&format!("truss layout LP {name}"), |b| {
            b.iter(|| {
                start::layout_start(
                    &model.structure,
                    &model.settings,
                    model.full.as_ref(),
                    &optimize::solver::Interrupt::new(),
                )
                .expect("solves")
            })
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = layout, runs, warren_lbfgs, cooling_tower
}
criterion_main!(benches);
