//! Solves the hanging chain of `tests/common/chain.rs` once per Hessian mode and prints status,
//! iterations and time: the medium-size figures of BENCHMARKS.md.
//!
//! `cargo run --release --example chain_solve -- [links] [auto|dense|sparse] [bfgs|lbfgs|exact]`
//! (default 100 links: n = 198, m = 100; the QP method `auto`; all three Hessian modes).
//! `VERBOSITY=N` shows the iteration log, `LBFGS_MEMORY=p` sets the L-BFGS memory.

#[path = "../../tests/common/chain.rs"]
#[allow(dead_code)]
mod chain;

use chain::Chain;
use optimize::solver::qp::QpMethod;
use optimize::solver::{HessianMode, Options, solve};

fn main() {
    let links = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(100);
    let qp_method = match std::env::args().nth(2).as_deref() {
        Some("dense") => QpMethod::Dense,
        Some("sparse") => QpMethod::Sparse,
        _ => QpMethod::Auto,
    };
    for (mode, exact) in [
        (HessianMode::Bfgs, false),
        (HessianMode::Lbfgs, false),
        (HessianMode::Exact, true),
    ] {
        let only = std::env::args().nth(3);
        if only.is_some_and(|m| !format!("{mode:?}").eq_ignore_ascii_case(&m)) {
            continue;
        }
        let chain = Chain { links, exact };
        let options = Options {
            hessian: mode,
            verbosity: std::env::var("VERBOSITY")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(0),
            qp_method,
            lbfgs_memory: std::env::var("LBFGS_MEMORY")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(Options::default().lbfgs_memory),
            ..Options::default()
        };
        let s = solve(&chain, &options);
        println!(
            "chain links = {links} {mode:?} ({qp_method:?} QP): {:?}, f = {:.10}, {} iterations, {} evaluations, {:.3} s",
            s.status, s.objective, s.iterations, s.evaluations.functions, s.seconds
        );
    }
}
