//! What the sparse method adds to an indefinite Hessian to make its QP convex:
//! `H + δ_c I + diag(f)`, with `f_j = 2·max(0, −H_jj)` when H has negative diagonal entries.
//!
//! The flip `f` turns every negative diagonal entry into its absolute value: a coordinate
//! direction of negative curvature gets the curvature |H_jj| instead of forcing a uniform shift
//! δ_c ≥ |H_jj| onto every variable. It is invariant under a scaling of the variables (H_jj and
//! f_j scale alike), and it touches only the offending variables. Its source is separable
//! concavity in the problem: the Euler (buckling) mass of a compression member grows like
//! √|force|, so its diagonal entry `−¼k|λ|^{-3/2}` is large and negative on every strut whose
//! force goes to zero, while the rest of the reduced Hessian is positive definite. A uniform
//! shift large enough for the weakest strut (150 against a Hessian scale of 1e4 on
//! `through_deck_cantilever.toml`) damped every other step, and its rounds crawled to their
//! iteration limits with full steps. With the flip, the strut's own Newton step is −2λ, which
//! lands on its bound λ ≥ 0. The flip is tried only after H alone (plus the caller's floor)
//! fails the inertia test, so a Hessian already convex on the constraints' null space keeps its
//! exact Newton step; the uniform schedule follows when the flip is not enough.

/// The diagonal added to H by the convexification: `shift` on every variable plus `flip[j]`
/// on variable j (`flip` empty when no negative diagonal entry was flipped). Units: those of
/// H's diagonal in the solver's scaled variables.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Convexification {
    /// The uniform shift δ_c ≥ 0.
    pub shift: f64,
    /// Per-variable addition `2·max(0, −H_jj)`, or empty.
    pub flip: Vec<f64>,
}

impl Convexification {
    /// A uniform shift only.
    pub fn uniform(shift: f64) -> Self {
        Convexification {
            shift,
            flip: Vec::new(),
        }
    }

    /// The diagonal added at variable `j`.
    pub fn added(&self, j: usize) -> f64 {
        self.shift + self.flip.get(j).copied().unwrap_or(0.0)
    }

    /// `dᵀ E d` for the added diagonal E: the curvature the convexification adds along `d`.
    pub fn curvature(&self, d: &[f64]) -> f64 {
        d.iter()
            .enumerate()
            .map(|(j, v)| self.added(j) * v * v)
            .sum()
    }

    /// Whether nothing is added.
    pub fn is_zero(&self) -> bool {
        self.shift == 0.0 && self.flip.is_empty()
    }
}

/// The flip `2·max(0, −H_jj)` of the non-fixed variables' negative diagonal entries (`diagonal`
/// gives H_jj), or an empty vector when there is none.
pub fn negative_diagonal_flip(diagonal: impl Iterator<Item = f64>, fixed: &[bool]) -> Vec<f64> {
    let flip: Vec<f64> = diagonal
        .zip(fixed)
        .map(|(h, &fixed)| if fixed { 0.0 } else { (-2.0 * h).max(0.0) })
        .collect();
    if flip.iter().any(|&f| f > 0.0) {
        flip
    } else {
        Vec::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flip_touches_only_negative_free_diagonal_entries() {
        let flip = negative_diagonal_flip(
            [1.0, -2.0, -3.0, 0.0].into_iter(),
            &[false, false, true, false],
        );
        assert_eq!(flip, vec![0.0, 4.0, 0.0, 0.0]);
        assert!(negative_diagonal_flip([1.0, 0.0].into_iter(), &[false, false]).is_empty());
        let c = Convexification { shift: 0.5, flip };
        assert_eq!(c.added(1), 4.5);
        assert_eq!(c.curvature(&[1.0, 1.0, 0.0, 2.0]), 0.5 + 4.5 + 0.5 * 4.0);
    }
}
