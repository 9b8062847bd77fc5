//! Writes the layout LP that `optimize truss` starts from, over the whole ground structure its
//! member adding prices, as JSON, so another LP solver can solve the same LP
//! (benches/peers/highs_layout.py, benches/peers/layout_lp_compare.sh).
//!
//! `cargo run --release --example layout_lp_export -- FILE.toml OUT.json`: the file must ask
//! for full connectivity (`[connect] full = true`). One LP per load case, each in standard form
//! `min costᵀx s.t. A x = b, x ≥ 0` with A in compressed sparse columns (`col_ptr`, `row_idx`,
//! `values`; column j is beam j's compression, column beams + j its tension), and
//! `objective_to_unit`, the factor that turns an objective into `unit` (kg, or m for the length
//! objective).

use std::process::ExitCode;

use nalgebra_sparse::CscMatrix;
use optimize::truss::model::Objective;
use optimize::truss::start::full_layout_lp;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() != 2 {
        eprintln!("usage: layout_lp_export FILE.toml OUT.json");
        return ExitCode::from(2);
    }
    let problem = match optimize::truss::load(std::path::Path::new(&args[0])) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let model = problem.model();
    let Some(full) = model.full.as_ref() else {
        eprintln!(
            "{}: no `[connect] full = true`: no whole ground structure",
            args[0]
        );
        return ExitCode::from(2);
    };
    let structure = &model.structure;
    let case_count = structure.joints.first().map_or(0, |j| j.loads.len());
    let unit = match model.settings.objective {
        Objective::Length => "m",
        _ => "kg",
    };
    let cases: Vec<serde_json::Value> = (0..case_count)
        .map(|case| {
            let (lp, to_unit) = full_layout_lp(structure, &model.settings, full, case);
            let a = CscMatrix::from(&lp.a);
            serde_json::json!({
                "rows": a.nrows(),
                "cols": a.ncols(),
                "col_ptr": a.col_offsets(),
                "row_idx": a.row_indices(),
                "values": a.values(),
                "b": lp.b,
                "cost": lp.cost,
                "objective_to_unit": to_unit,
            })
        })
        .collect();
    let text = serde_json::json!({ "problem": problem.name(), "unit": unit, "cases": cases });
    if let Err(e) = std::fs::write(&args[1], text.to_string()) {
        eprintln!("{}: {e}", args[1]);
        return ExitCode::from(1);
    }
    let columns: usize = (cases.iter())
        .map(|c| c["cols"].as_u64().unwrap_or(0) as usize)
        .sum();
    eprintln!(
        "{}: {case_count} load case(s), {columns} LP columns",
        args[1]
    );
    ExitCode::SUCCESS
}
