#[path = "../tests/common/hs.rs"]
mod hs;
use optimize::solver::{HessianMode, Options, solve};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mode = if args[2] == "exact" {
        HessianMode::Exact
    } else {
        HessianMode::Bfgs
    };
    let iters: usize = args.get(3).map(|s| s.parse().unwrap()).unwrap_or(60);
    for p in hs::all() {
        if p.name == args[1] {
            let o = Options {
                hessian: mode,
                verbosity: 2,
                max_iterations: iters,
                ..Options::default()
            };
            let s = solve(&p.nlp(mode == HessianMode::Exact), &o);
            println!(
                "{:?} f={} x={:?} lambda={:?}",
                s.status, s.objective, s.x, s.lambda
            );
        }
    }
}
