//! KKT solver against dense nalgebra solves and known inertias.

use nalgebra::{DMatrix, DVector};
use rand::RngExt;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::{Equilibration, KktSolver, Regularization};

/// A random sparse quasi-definite matrix [H, Aᵀ; A, −D] with H ≻ 0 (diagonally dominant), D ≻ 0,
/// as lower-triangle triplets plus its dense form.
fn random_quasi_definite(
    rng: &mut ChaCha8Rng,
    n: usize,
    m: usize,
    density: f64,
) -> (Vec<usize>, Vec<usize>, Vec<f64>, DMatrix<f64>) {
    let dim = n + m;
    let mut dense = DMatrix::<f64>::zeros(dim, dim);
    for c in 0..n {
        for r in c + 1..n {
            if rng.random::<f64>() < density {
                let v = rng.random_range(-1.0..1.0);
                dense[(r, c)] = v;
                dense[(c, r)] = v;
            }
        }
    }
    for r in n..dim {
        for c in 0..n {
            if rng.random::<f64>() < density {
                let v = rng.random_range(-3.0..3.0);
                dense[(r, c)] = v;
                dense[(c, r)] = v;
            }
        }
    }
    for k in 0..n {
        let off: f64 = (0..n)
            .filter(|&j| j != k)
            .map(|j| dense[(k, j)].abs())
            .sum();
        dense[(k, k)] = off + rng.random_range(0.1..2.0);
    }
    for k in n..dim {
        dense[(k, k)] = -rng.random_range(1e-3..1.0);
    }
    let (mut rows, mut cols, mut vals) = (vec![], vec![], vec![]);
    for c in 0..dim {
        for r in c..dim {
            if dense[(r, c)] != 0.0 {
                rows.push(r);
                cols.push(c);
                vals.push(dense[(r, c)]);
            }
        }
    }
    (rows, cols, vals, dense)
}

fn build(n: usize, m: usize, rows: &[usize], cols: &[usize], vals: &[f64]) -> KktSolver {
    let (mut kkt, pos) = KktSolver::from_lower_triplets(n, m, rows, cols).unwrap();
    let values = kkt.values_mut();
    for (&p, &v) in pos.iter().zip(vals) {
        values[p] += v;
    }
    kkt
}

#[test]
fn random_quasi_definite_systems_match_dense_solves() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut saw_supernodal = false;
    let mut saw_simplicial = false;
    for &(n, m, density) in &[
        (5, 2, 0.5),
        (40, 15, 0.1),
        (120, 60, 0.03),
        (150, 100, 0.3),
        (300, 10, 0.01),
        (20, 0, 0.2),
    ] {
        let (rows, cols, vals, dense) = random_quasi_definite(&mut rng, n, m, density);
        let mut kkt = build(n, m, &rows, &cols, &vals);
        saw_supernodal |= kkt.is_supernodal();
        saw_simplicial |= !kkt.is_supernodal();
        let inertia = kkt.factor(Regularization::default()).unwrap();
        assert_eq!((inertia.positive, inertia.negative), (n, m));
        let b = DVector::from_fn(n + m, |_, _| rng.random_range(-1.0..1.0));
        let expected = dense.clone().lu().solve(&b).unwrap();
        let mut x = b.as_slice().to_vec();
        let report = kkt.solve_refined(&mut x, 5, 1e-14).unwrap();
        let err = x
            .iter()
            .zip(expected.iter())
            .map(|(a, e)| (a - e).abs())
            .fold(0.0f64, f64::max);
        let scale = expected.amax().max(1.0);
        assert!(
            err <= 1e-10 * scale,
            "n={n} m={m}: error {err:e}, {report:?}"
        );
    }
    assert!(
        saw_supernodal && saw_simplicial,
        "both factorization paths must be exercised"
    );
}

#[test]
fn refactoring_the_same_values_keeps_the_factors() {
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let (rows, cols, vals, dense) = random_quasi_definite(&mut rng, 25, 10, 0.2);
    let mut kkt = build(25, 10, &rows, &cols, &vals);
    let strong = Regularization {
        dual: 1e-5,
        ..Regularization::default()
    };
    kkt.factor(strong).unwrap();
    assert_eq!(kkt.numeric_factorizations(), 1);
    // Same values (rewritten in place) and regularization: the factors are kept.
    let copy = kkt.values().to_vec();
    kkt.values_mut().copy_from_slice(&copy);
    kkt.factor(strong).unwrap();
    assert_eq!(kkt.numeric_factorizations(), 1);
    // Another regularization, then other values: each is a new factorization.
    kkt.factor(Regularization::default()).unwrap();
    assert_eq!(kkt.numeric_factorizations(), 2);
    let p = kkt.diagonal_position(0);
    kkt.values_mut()[p] += 1.0;
    kkt.factor(Regularization::default()).unwrap();
    assert_eq!(kkt.numeric_factorizations(), 3);
    let mut shifted = dense;
    shifted[(0, 0)] += 1.0;
    let b = DVector::from_fn(35, |i, _| (i as f64).cos());
    let expected = shifted.lu().solve(&b).unwrap();
    let mut x = b.as_slice().to_vec();
    kkt.solve_refined(&mut x, 5, 1e-14).unwrap();
    for (a, e) in x.iter().zip(expected.iter()) {
        assert!((a - e).abs() <= 1e-10 * (1.0 + e.abs()));
    }
}

#[test]
fn values_can_be_updated_in_place_and_refactored() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (rows, cols, vals, dense) = random_quasi_definite(&mut rng, 30, 12, 0.15);
    let mut kkt = build(30, 12, &rows, &cols, &vals);
    kkt.factor(Regularization::default()).unwrap();
    // Scale the whole matrix by 3 in place: the solution of K x = b shrinks by 3.
    for v in kkt.values_mut() {
        *v *= 3.0;
    }
    kkt.factor(Regularization::default()).unwrap();
    let b = DVector::from_fn(42, |i, _| (i as f64).sin());
    let expected = (dense * 3.0).lu().solve(&b).unwrap();
    let mut x = b.as_slice().to_vec();
    kkt.solve_refined(&mut x, 5, 1e-14).unwrap();
    for (a, e) in x.iter().zip(expected.iter()) {
        assert!((a - e).abs() <= 1e-10 * (1.0 + e.abs()));
    }
}

#[test]
fn inertia_of_indefinite_matrices_with_known_eigenvalue_signs() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for &(dim, negatives) in &[(8, 3), (60, 25), (200, 1), (200, 199)] {
        // K = Qᵀ Λ Q with Q a product of sparse Givens-like rotations keeps a known inertia.
        let mut dense = DMatrix::<f64>::zeros(dim, dim);
        for k in 0..dim {
            let magnitude = rng.random_range(0.5..2.0);
            dense[(k, k)] = if k < negatives { -magnitude } else { magnitude };
        }
        for _ in 0..dim {
            let i = rng.random_range(0..dim);
            let j = rng.random_range(0..dim);
            if i == j {
                continue;
            }
            let theta: f64 = rng.random_range(0.0..1.0);
            let (c, s) = (theta.cos(), theta.sin());
            // dense ← G dense Gᵀ with G rotating coordinates i and j.
            for col in 0..dim {
                let (a, b) = (dense[(i, col)], dense[(j, col)]);
                dense[(i, col)] = c * a - s * b;
                dense[(j, col)] = s * a + c * b;
            }
            for row in 0..dim {
                let (a, b) = (dense[(row, i)], dense[(row, j)]);
                dense[(row, i)] = c * a - s * b;
                dense[(row, j)] = s * a + c * b;
            }
        }
        let eig = dense.clone().symmetric_eigen().eigenvalues;
        assert_eq!(eig.iter().filter(|&&e| e < 0.0).count(), negatives);
        let (mut rows, mut cols, mut vals) = (vec![], vec![], vec![]);
        for c in 0..dim {
            for r in c..dim {
                if dense[(r, c)].abs() > 1e-300 {
                    rows.push(r);
                    cols.push(c);
                    vals.push(dense[(r, c)]);
                }
            }
        }
        // All rows declared primal: no regularization, the inertia is the matrix's own.
        let mut kkt = build(dim, 0, &rows, &cols, &vals);
        let reg = Regularization {
            primal: 0.0,
            dual: 0.0,
            ..Regularization::default()
        };
        let inertia = kkt.factor(reg).unwrap();
        assert_eq!(inertia.negative, negatives, "dim {dim}");
        assert_eq!(inertia.positive, dim - negatives, "dim {dim}");
        assert_eq!(inertia.regularized, 0);
    }
}

#[test]
fn inertia_flags_a_convex_kkt_and_a_nonconvex_one() {
    // [H, aᵀ; a, 0] with H = diag(1, h22), a = (1, 0): inertia (2, 1) iff h22 > 0 (H on the
    // null space of a is h22).
    for &(h22, expect_ok) in &[(1.0, true), (-1.0, false)] {
        let rows = [0, 1, 2];
        let cols = [0, 1, 0];
        let vals = [1.0, h22, 1.0];
        let mut kkt = build(2, 1, &rows, &cols, &vals);
        let inertia = kkt.factor(Regularization::default()).unwrap();
        assert_eq!(
            inertia.is_quasi_definite_like(2, 1),
            expect_ok,
            "{inertia:?}"
        );
    }
}

#[test]
fn malformed_patterns_are_rejected() {
    assert!(KktSolver::from_lower_triplets(2, 1, &[0], &[1]).is_err());
    assert!(KktSolver::from_lower_triplets(2, 1, &[5], &[0]).is_err());
    assert!(KktSolver::new(2, 0, vec![0, 1, 1], vec![0]).is_err());
    let mut kkt = build(2, 0, &[0, 1], &[0, 1], &[1.0, 1.0]);
    assert!(kkt.solve_refined(&mut [1.0, 1.0], 1, 1e-12).is_err());
}

/// An equality-only KKT matrix shaped like a long chain's at a large convexification shift:
/// H = 3.3e4·I, A the 250×251 difference matrix with entries ±8e-3, zero dual block. Its Schur
/// complement A H⁻¹ Aᵀ has eigenvalues from ~8e-9 down to ~3e-13, below an absolute 1e-9
/// regularization; equilibration must make the refined solve accurate all the same.
#[test]
fn badly_scaled_equality_kkt_is_solved_accurately() {
    let (n, m) = (251, 250);
    let (mut rows, mut cols, mut vals) = (vec![], vec![], vec![]);
    let mut dense = DMatrix::<f64>::zeros(n + m, n + m);
    for k in 0..n {
        rows.push(k);
        cols.push(k);
        vals.push(3.3e4);
        dense[(k, k)] = 3.3e4;
    }
    for i in 0..m {
        for (j, v) in [(i, 8e-3), (i + 1, -8e-3)] {
            rows.push(n + i);
            cols.push(j);
            vals.push(v);
            dense[(n + i, j)] = v;
            dense[(j, n + i)] = v;
        }
    }
    let mut kkt = build(n, m, &rows, &cols, &vals);
    let inertia = kkt.factor(Regularization::default()).unwrap();
    assert_eq!((inertia.positive, inertia.negative), (n, m));
    // Primal rows of a converged dual residual (zero), equality residuals of size 1e-4.
    let b = DVector::from_fn(n + m, |k, _| {
        if k < n {
            0.0
        } else {
            1e-4 * ((k - n) as f64).cos()
        }
    });
    let mut x = b.as_slice().to_vec();
    kkt.solve_refined(&mut x, 4, 1e-14).unwrap();
    // The equality rows A Δd = b_E must hold to the accuracy of the data.
    let worst = (0..m)
        .map(|i| (8e-3 * (x[i] - x[i + 1]) - b[n + i]).abs())
        .fold(0.0f64, f64::max);
    assert!(worst <= 1e-12, "equality rows violated by {worst:e}");
    let expected = dense.lu().solve(&b).unwrap();
    let err = x
        .iter()
        .zip(expected.iter())
        .map(|(a, e)| (a - e).abs() / (1.0 + e.abs()))
        .fold(0.0f64, f64::max);
    assert!(err <= 1e-6, "relative error {err:e}");
}

/// Row ∞-norms of `S K S` with the solver's current values and scale.
fn scaled_row_norms(kkt: &KktSolver) -> Vec<f64> {
    let mut norms = vec![0.0f64; kkt.dim];
    for c in 0..kkt.dim {
        for p in kkt.col_ptr[c]..kkt.col_ptr[c + 1] {
            let r = kkt.row_idx[p];
            let v = (kkt.values[p] * kkt.scale[r] * kkt.scale[c]).abs();
            norms[r] = norms[r].max(v);
            norms[c] = norms[c].max(v);
        }
    }
    norms
}

#[test]
fn equilibration_from_the_last_scale_balances_shifted_matrices_and_solves_them() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (n, m) = (120, 40);
    let (rows, cols, vals, dense) = random_quasi_definite(&mut rng, n, m, 0.05);
    let mut kkt = build(n, m, &rows, &cols, &vals);
    let base = kkt.values().to_vec();
    let warm = Regularization {
        equilibration: Equilibration::RuizFromLast,
        ..Regularization::default()
    };
    for sigma in [0.0, 0.5, 3.0, 30.0, 1.0] {
        // The primal diagonal shifted by σ, as a spectrum slice or an inertia trial does.
        kkt.values_mut().copy_from_slice(&base);
        for k in 0..n {
            let at = kkt.diagonal_position(k);
            kkt.values_mut()[at] += sigma;
        }
        let inertia = kkt.factor(warm).unwrap();
        assert_eq!((inertia.positive, inertia.negative), (n, m), "σ = {sigma}");
        for norm in scaled_row_norms(&kkt) {
            assert!((norm - 1.0).abs() <= 0.1, "σ = {sigma}: row norm {norm}");
        }
        let mut shifted = dense.clone();
        for k in 0..n {
            shifted[(k, k)] += sigma;
        }
        let b = DVector::from_fn(n + m, |_, _| rng.random_range(-1.0..1.0));
        let expected = shifted.lu().solve(&b).unwrap();
        let mut x = b.as_slice().to_vec();
        kkt.solve_refined(&mut x, 5, 1e-14).unwrap();
        let err = x
            .iter()
            .zip(expected.iter())
            .map(|(a, e)| (a - e).abs())
            .fold(0.0f64, f64::max);
        assert!(
            err <= 1e-10 * expected.amax().max(1.0),
            "σ = {sigma}: {err:e}"
        );
    }
}

/// Factors `kkt` and solves it for the right-hand side (1, 2, …, dim).
fn solution_of(kkt: &mut KktSolver) -> Vec<f64> {
    kkt.factor(Regularization::default()).unwrap();
    let mut x: Vec<f64> = (1..=kkt.dim()).map(|k| k as f64).collect();
    kkt.solve_refined(&mut x, 5, 1e-14).unwrap();
    x
}

#[test]
fn a_pattern_analysed_before_shares_its_analysis_and_the_results_are_the_same() {
    let mut rng = ChaCha8Rng::seed_from_u64(18);
    let (n, m) = (60, 20);
    let (rows, cols, vals, _) = random_quasi_definite(&mut rng, n, m, 0.1);
    let mut first = build(n, m, &rows, &cols, &vals);
    let expected = solution_of(&mut first);
    let mut again = build(n, m, &rows, &cols, &vals);
    assert!(std::sync::Arc::ptr_eq(&first.analysis, &again.analysis));
    assert_eq!(solution_of(&mut again), expected);
    // As many other patterns as are remembered: the first is forgotten, analysed anew, and
    // gives the same answer bit for bit.
    for k in 0..super::analysis::REMEMBERED {
        let (rows, cols, vals, _) = random_quasi_definite(&mut rng, n + 1 + k, m, 0.1);
        let other = build(n + 1 + k, m, &rows, &cols, &vals);
        assert!(!std::sync::Arc::ptr_eq(&first.analysis, &other.analysis));
    }
    let mut anew = build(n, m, &rows, &cols, &vals);
    assert!(!std::sync::Arc::ptr_eq(&first.analysis, &anew.analysis));
    assert_eq!(solution_of(&mut anew), expected);
}

#[test]
fn the_up_looking_factorization_gives_faers_factors_bit_for_bit() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let mut compared = 0;
    for &(n, m, density) in &[
        (5, 2, 0.5),
        (40, 15, 0.1),
        (120, 60, 0.03),
        (300, 10, 0.01),
        (20, 0, 0.2),
        (80, 30, 0.05),
    ] {
        let (rows, cols, vals, _) = random_quasi_definite(&mut rng, n, m, density);
        let mut kkt = build(n, m, &rows, &cols, &vals);
        if !kkt.is_up_looking() {
            continue;
        }
        // Indefinite primal blocks too (random diagonal signs: negative pivots, large growth),
        // a pivot at the replacement threshold, and every equilibration.
        let plain = kkt.values().to_vec();
        for trial in 0..4 {
            let values = kkt.values_mut();
            values.copy_from_slice(&plain);
            if trial >= 2 {
                for c in 0..n {
                    let p = kkt.diagonal_position(c);
                    let sign = if rng.random::<f64>() < 0.3 {
                        -0.05
                    } else {
                        1.0
                    };
                    kkt.values_mut()[p] *= sign;
                }
            }
            let reg = Regularization {
                pivot_threshold: if trial == 3 { 1e-2 } else { 1e-13 },
                equilibration: [
                    Equilibration::Ruiz,
                    Equilibration::Off,
                    Equilibration::RuizFromLast,
                    Equilibration::Ruiz,
                ][trial],
                ..Regularization::default()
            };
            let ours = kkt.factor(reg);
            let factors = kkt.factor_values().to_vec();
            let faers = kkt.factor_by_faer_only(reg);
            assert_eq!(ours, faers, "n={n} m={m} trial {trial}");
            let same = factors
                .iter()
                .zip(kkt.factor_values())
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "n={n} m={m} trial {trial}: factors differ");
            compared += 1;
        }
    }
    assert!(compared >= 16, "only {compared} factorizations compared");
}

#[test]
fn the_up_looking_factorization_reports_a_zero_pivot_where_faer_does() {
    // [[1, 1], [1, 1]]: the second pivot is exactly 0 with no replacement.
    let (rows, cols) = (vec![0, 1, 1], vec![0, 0, 1]);
    let mut kkt = build(2, 0, &rows, &cols, &[1.0, 1.0, 1.0]);
    assert!(kkt.is_up_looking());
    let reg = Regularization {
        primal: 0.0,
        pivot_threshold: 0.0,
        pivot_replacement: 0.0,
        equilibration: Equilibration::Off,
        ..Regularization::default()
    };
    let ours = kkt.factor(reg);
    assert!(
        matches!(ours, Err(super::KktError::Breakdown(_))),
        "{ours:?}"
    );
    assert_eq!(ours, kkt.factor_by_faer_only(reg));
    // The work vector is clean again: the next factorization is right.
    kkt.values_mut()[2] = 2.0;
    let inertia = kkt.factor(reg).unwrap();
    assert_eq!((inertia.positive, inertia.negative), (2, 0));
    let factors = kkt.factor_values().to_vec();
    kkt.factor_by_faer_only(reg).unwrap();
    assert_eq!(factors, kkt.factor_values());
}
