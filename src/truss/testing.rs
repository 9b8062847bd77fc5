//! Test support: a dense fourth-order central-difference comparison of an [`Nlp`]'s objective gradient,
//! constraint Jacobian (pattern included) and Lagrangian Hessian.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::solver::Nlp;

use super::mass::MassModel;
use super::model::{Joint, JointKind, Objective, Settings, Vec3};

/// A joint at (x, y, 0) m of the given kind, without name, with one zero load case.
pub fn planar_joint(x: f64, y: f64, kind: JointKind) -> Joint {
    Joint {
        position: Vec3::new(x, y, 0.0),
        kind,
        name: None,
        loads: vec![Vec3::zeros()],
    }
}

/// Test settings: seed mass law (σ = 200), mass objective, no self-weight, 3-D, `cases` load
/// cases named case0, case1, ….
pub fn test_settings(cases: usize) -> Settings {
    Settings {
        // Blend width 1e-3 of the loads, as the problem files default to.
        mass: MassModel::seed(200.0),
        objective: Objective::Mass,
        self_weight: false,
        max_force: 1e7,
        min_length: 0.1,
        max_length: None,
        planar: false,
        held_axis: None,
        move_joints: true,
        symmetry: Vec::new(),
        obstacles: Vec::new(),
        load_cases: (0..cases).map(|c| format!("case{c}")).collect(),
    }
}

/// Largest scaled discrepancies found by [`compare_derivatives`].
#[derive(Debug, Clone, Copy, Default)]
pub struct Discrepancy {
    /// Objective gradient.
    pub gradient: f64,
    /// Constraint Jacobian (entries outside the pattern count with value 0).
    pub jacobian: f64,
    /// Lagrangian Hessian (lower triangle mirrored).
    pub hessian: f64,
    /// Where the worst gradient entry is.
    pub worst_gradient: usize,
    /// Where the worst Jacobian entry is (row, col).
    pub worst_jacobian: (usize, usize),
    /// Analytic and difference values at the worst Hessian entry.
    pub hessian_values: (f64, f64),
    /// Where the worst Hessian entry is (row, col).
    pub worst_hessian: (usize, usize),
}

fn scaled(a: f64, b: f64) -> f64 {
    (a - b).abs() / 1f64.max(a.abs()).max(b.abs())
}

/// [`compare_derivatives_skipping`] with no rows skipped.
pub fn compare_derivatives(nlp: &dyn Nlp, x: &[f64], seed: u64) -> Discrepancy {
    compare_derivatives_skipping(nlp, x, seed, &vec![false; nlp.dims().m])
}

/// Compares analytic derivatives at `x` with fourth-order central differences
/// `(8(g(x+h) − g(x−h)) − (g(x+2h) − g(x−2h)))/12h`, step `h = 1e-5·max(1, |x_i|)`,
/// using random multipliers from `seed` for the Hessian. Rows marked in `skip` (where a
/// function is only C¹ and differences straddle its kink) are left out of the Jacobian
/// comparison and get zero multipliers in the Hessian.
pub fn compare_derivatives_skipping(
    nlp: &dyn Nlp,
    x: &[f64],
    seed: u64,
    skip: &[bool],
) -> Discrepancy {
    let d = nlp.dims();
    let (n, m) = (d.n, d.m);
    let mut rows = vec![0; d.jac_nnz];
    let mut cols = vec![0; d.jac_nnz];
    nlp.jacobian_structure(&mut rows, &mut cols);
    let mut grad = vec![0.0; n];
    let mut jac = vec![0.0; d.jac_nnz];
    nlp.eval_derivatives(x, &mut grad, &mut jac)
        .expect("derivatives at the check point");
    let mut dense = vec![0.0; m * n];
    for k in 0..d.jac_nnz {
        dense[rows[k] * n + cols[k]] += jac[k];
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let y: Vec<f64> = (0..m)
        .map(|r| {
            let v = 2.0 * rng.random::<f64>() - 1.0;
            if skip[r] { 0.0 } else { v }
        })
        .collect();
    let sigma = 0.5 + rng.random::<f64>();
    let mut hess = vec![0.0; n * n];
    if d.hess_nnz > 0 {
        let mut hr = vec![0; d.hess_nnz];
        let mut hc = vec![0; d.hess_nnz];
        nlp.hessian_structure(&mut hr, &mut hc);
        let mut hv = vec![0.0; d.hess_nnz];
        nlp.eval_hessian(x, sigma, &y, &mut hv).expect("Hessian");
        for k in 0..d.hess_nnz {
            assert!(hr[k] >= hc[k], "Hessian entry above the diagonal");
            hess[hr[k] * n + hc[k]] += hv[k];
            if hr[k] != hc[k] {
                hess[hc[k] * n + hr[k]] += hv[k];
            }
        }
    }
    // ∇L = σ∇f + Jᵀy at a point.
    let lagrangian_gradient = |x: &[f64]| -> Vec<f64> {
        let mut g = vec![0.0; n];
        let mut j = vec![0.0; d.jac_nnz];
        nlp.eval_derivatives(x, &mut g, &mut j)
            .expect("derivatives");
        let mut out: Vec<f64> = g.iter().map(|v| sigma * v).collect();
        for k in 0..d.jac_nnz {
            out[cols[k]] += y[rows[k]] * j[k];
        }
        out
    };
    let mut out = Discrepancy::default();
    let mut xp = x.to_vec();
    // Objective, constraints and Lagrangian gradient at x + t·h·e_i.
    let mut sample = |i: usize, step: f64| {
        xp[i] = x[i] + step;
        let (mut f, mut c) = (0.0, vec![0.0; m]);
        nlp.eval(&xp, &mut f, &mut c)
            .expect("eval at a shifted point");
        let g = if d.hess_nnz > 0 {
            lagrangian_gradient(&xp)
        } else {
            Vec::new()
        };
        xp[i] = x[i];
        (f, c, g)
    };
    let stencil =
        |p1: f64, m1: f64, p2: f64, m2: f64, h: f64| (8.0 * (p1 - m1) - (p2 - m2)) / (12.0 * h);
    for i in 0..n {
        let h = 1e-5 * 1f64.max(x[i].abs());
        let (f1, c1, g1) = sample(i, h);
        let (f_1, c_1, g_1) = sample(i, -h);
        let (f2, c2, g2) = sample(i, 2.0 * h);
        let (f_2, c_2, g_2) = sample(i, -2.0 * h);
        let e = scaled(grad[i], stencil(f1, f_1, f2, f_2, h));
        if e > out.gradient {
            out.gradient = e;
            out.worst_gradient = i;
        }
        for r in (0..m).filter(|&r| !skip[r]) {
            let fd = stencil(c1[r], c_1[r], c2[r], c_2[r], h);
            let e = scaled(dense[r * n + i], fd);
            if e > out.jacobian {
                out.jacobian = e;
                out.worst_jacobian = (r, i);
            }
        }
        if d.hess_nnz > 0 {
            for r in 0..n {
                let fd = stencil(g1[r], g_1[r], g2[r], g_2[r], h);
                let e = scaled(hess[r * n + i], fd);
                if e > out.hessian {
                    out.hessian = e;
                    out.hessian_values = (hess[r * n + i], fd);
                    out.worst_hessian = (r, i);
                }
            }
        }
    }
    out
}

/// Asserts that all discrepancies are below `tol`.
pub fn assert_derivatives(nlp: &dyn Nlp, x: &[f64], seed: u64, tol: f64, what: &str) {
    let d = compare_derivatives(nlp, x, seed);
    assert!(
        d.gradient <= tol,
        "{what}: gradient off by {} at {}",
        d.gradient,
        d.worst_gradient
    );
    assert!(
        d.jacobian <= tol,
        "{what}: Jacobian off by {} at {:?} ({})",
        d.jacobian,
        d.worst_jacobian,
        nlp.constraint_name(d.worst_jacobian.0)
    );
    assert!(
        d.hessian <= tol,
        "{what}: Hessian off by {} at {:?}: {:?}",
        d.hessian,
        d.worst_hessian,
        d.hessian_values
    );
}
