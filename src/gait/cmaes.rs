//! CMA-ES, the covariance matrix adaptation evolution strategy (Hansen, "The CMA Evolution
//! Strategy: A Tutorial", 2016, Table 1 and eq. 38–47), minimizing `f: ℝⁿ → ℝ` from rankings
//! of sampled points alone (no derivatives).
//!
//! Generation `g` samples `λ` points `x_k = m + σ·y_k`, `y_k = B·D·z_k`, `z_k ~ N(0, I)`
//! (`C = B·D²·Bᵀ`), ranks them by `f` and, with weights `w_i ∝ ln((λ+1)/2) − ln i` over the
//! best `μ = ⌊λ/2⌋` (`Σw = 1`, `μ_eff = 1/Σw²`):
//! ```text
//!   ⟨y⟩_w = Σ w_i·y_{i:λ},                m ← m + σ·⟨y⟩_w
//!   p_σ ← (1 − c_σ)·p_σ + √(c_σ(2 − c_σ)μ_eff)·C^{−1/2}·⟨y⟩_w
//!   h_σ = [‖p_σ‖ / √(1 − (1 − c_σ)^{2(g+1)}) < (1.4 + 2/(n+1))·E‖N(0, I)‖]
//!   p_c ← (1 − c_c)·p_c + h_σ·√(c_c(2 − c_c)μ_eff)·⟨y⟩_w
//!   C ← (1 − c₁ − c_μ)·C + c₁·(p_c·p_cᵀ + (1 − h_σ)·c_c(2 − c_c)·C) + c_μ·Σ w_i·y_{i:λ}·y_{i:λ}ᵀ
//!   σ ← σ·exp((c_σ/d_σ)·(‖p_σ‖/E‖N(0, I)‖ − 1))
//! ```
//! (rank-one update through the evolution path `p_c`, rank-μ update from the selected steps,
//! cumulative step-size adaptation through `p_σ`), with the tutorial's default constants:
//! `λ = 4 + ⌊3 ln n⌋`, `c_c = (4 + μ_eff/n)/(n + 4 + 2μ_eff/n)`,
//! `c_σ = (μ_eff + 2)/(n + μ_eff + 5)`, `c₁ = 2/((n + 1.3)² + μ_eff)`,
//! `c_μ = min(1 − c₁, 2(μ_eff − 2 + 1/μ_eff)/((n + 2)² + μ_eff))`,
//! `d_σ = 1 + 2·max(0, √((μ_eff − 1)/(n + 1)) − 1) + c_σ`,
//! `E‖N(0, I)‖ ≈ √n·(1 − 1/(4n) + 1/(21n²))`. `C` is decomposed every generation.
//!
//! Determinism: generation `g`'s normal samples come from a `ChaCha8Rng` seeded with the run's
//! seed on stream `g`, drawn in candidate order before any evaluation; the candidates are
//! evaluated in parallel (rayon) into their own slots. Results do not depend on the number of
//! threads.

use nalgebra::{DMatrix, DVector, SymmetricEigen};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// The strategy's state (module header).
#[derive(Debug, Clone)]
pub struct CmaEs {
    mean: DVector<f64>,
    sigma: f64,
    cov: DMatrix<f64>,
    /// Eigenvectors of `cov` (columns).
    b: DMatrix<f64>,
    /// Square roots of the eigenvalues of `cov`.
    d: DVector<f64>,
    pc: DVector<f64>,
    ps: DVector<f64>,
    weights: Vec<f64>,
    mu_eff: f64,
    cc: f64,
    cs: f64,
    c1: f64,
    cmu: f64,
    damps: f64,
    chi_n: f64,
    lambda: usize,
    generation: usize,
}

/// Smallest sampling spread, relative to `1 + max |x₀|`.
pub const RESOLUTION: f64 = 1e-9;

/// Generations without a lower best value that end a run: `10 + ⌈30n/λ⌉` (the tutorial's
/// history length for TolHistFun).
pub fn stall_generations(n: usize, lambda: usize) -> usize {
    10 + (30 * n).div_ceil(lambda.max(1))
}

/// Why a run stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// The best value reached the target.
    Target,
    /// The generation budget is spent.
    Generations,
    /// The evaluation budget is spent.
    Evaluations,
    /// The sampling distribution collapsed (`σ·max √eig(C)` below [`RESOLUTION`] times the
    /// start's scale), or the best value did not fall for [`stall_generations`] generations
    /// (the tutorial's TolHistFun with tolerance 0).
    Converged,
    /// The observer asked to stop (e.g. an interrupt).
    Stopped,
}

/// Budget and target of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Budget {
    /// Most generations.
    pub generations: usize,
    /// Most evaluations of `f` (a generation is started only if it fits whole).
    pub evaluations: usize,
    /// Stop once the best value is at most this.
    pub target: f64,
}

/// What one generation leaves, for an observer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Generation {
    /// Generations done (1-based).
    pub generation: usize,
    /// Evaluations so far.
    pub evaluations: usize,
    /// Best value so far.
    pub best: f64,
    /// Step size after the update.
    pub sigma: f64,
}

/// The result of [`minimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct Minimum {
    /// The best point evaluated.
    pub x: Vec<f64>,
    /// Its value.
    pub value: f64,
    /// Generations run.
    pub generations: usize,
    /// Evaluations of `f`.
    pub evaluations: usize,
    /// Why the run stopped.
    pub stop: Stop,
}

impl CmaEs {
    /// A strategy centred at `mean` with step size `sigma` (the coordinates' unit) and
    /// `population` samples per generation (`None`: `4 + ⌊3 ln n⌋`; at least 2).
    pub fn new(mean: &[f64], sigma: f64, population: Option<usize>) -> Self {
        let n = mean.len().max(1);
        let nf = n as f64;
        let lambda = population
            .unwrap_or(4 + (3.0 * nf.ln()).floor() as usize)
            .max(2);
        let mu = (lambda / 2).max(1);
        let raw: Vec<f64> = (1..=mu)
            .map(|i| ((lambda as f64 + 1.0) / 2.0).ln() - (i as f64).ln())
            .collect();
        let total: f64 = raw.iter().sum();
        let weights: Vec<f64> = raw.iter().map(|w| w / total).collect();
        let mu_eff = 1.0 / weights.iter().map(|w| w * w).sum::<f64>();
        let cc = (4.0 + mu_eff / nf) / (nf + 4.0 + 2.0 * mu_eff / nf);
        let cs = (mu_eff + 2.0) / (nf + mu_eff + 5.0);
        let c1 = 2.0 / ((nf + 1.3).powi(2) + mu_eff);
        let cmu =
            (1.0 - c1).min(2.0 * (mu_eff - 2.0 + 1.0 / mu_eff) / ((nf + 2.0).powi(2) + mu_eff));
        let damps = 1.0 + 2.0 * (((mu_eff - 1.0) / (nf + 1.0)).sqrt() - 1.0).max(0.0) + cs;
        let chi_n = nf.sqrt() * (1.0 - 1.0 / (4.0 * nf) + 1.0 / (21.0 * nf * nf));
        let n = mean.len();
        CmaEs {
            mean: DVector::from_column_slice(mean),
            sigma,
            cov: DMatrix::identity(n, n),
            b: DMatrix::identity(n, n),
            d: DVector::from_element(n, 1.0),
            pc: DVector::zeros(n),
            ps: DVector::zeros(n),
            weights,
            mu_eff,
            cc,
            cs,
            c1,
            cmu,
            damps,
            chi_n,
            lambda,
            generation: 0,
        }
    }

    /// Samples per generation (λ).
    pub fn population(&self) -> usize {
        self.lambda
    }

    /// The distribution's mean.
    pub fn mean(&self) -> &[f64] {
        self.mean.as_slice()
    }

    /// The step size σ.
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// The largest standard deviation of the sampling distribution along any direction,
    /// `σ·max √eig(C)`.
    pub fn spread(&self) -> f64 {
        self.sigma * self.d.max()
    }

    /// This generation's `λ` candidates, from the seeded stream of generation `g` (module
    /// header).
    pub fn sample(&self, seed: u64) -> Vec<Vec<f64>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(self.generation as u64);
        let n = self.mean.len();
        (0..self.lambda)
            .map(|_| {
                let z = DVector::from_iterator(n, (0..n).map(|_| standard_normal(&mut rng)));
                let y = &self.b * self.d.component_mul(&z);
                (&self.mean + y * self.sigma).as_slice().to_vec()
            })
            .collect()
    }

    /// Moves the distribution after ranking `candidates` (from [`CmaEs::sample`]) by their
    /// `values` (lower is better; NaN ranks last).
    pub fn update(&mut self, candidates: &[Vec<f64>], values: &[f64]) {
        let n = self.mean.len();
        let nf = n as f64;
        let mut order: Vec<usize> = (0..candidates.len()).collect();
        order.sort_by(|&a, &b| {
            rank_key(values[a])
                .total_cmp(&rank_key(values[b]))
                .then(a.cmp(&b))
        });
        let steps: Vec<DVector<f64>> = order
            .iter()
            .take(self.weights.len())
            .map(|&k| (DVector::from_column_slice(&candidates[k]) - &self.mean) / self.sigma)
            .collect();
        let mut yw = DVector::zeros(n);
        for (w, y) in self.weights.iter().zip(&steps) {
            yw += y * *w;
        }
        self.mean += &yw * self.sigma;
        // C^{-1/2}·⟨y⟩_w = B·D⁻¹·Bᵀ·⟨y⟩_w.
        let inv_sqrt = &self.b * (self.b.transpose() * &yw).component_div(&self.d);
        self.ps = &self.ps * (1.0 - self.cs)
            + inv_sqrt * (self.cs * (2.0 - self.cs) * self.mu_eff).sqrt();
        let g = (self.generation + 1) as f64;
        let norm_ps = self.ps.norm();
        let hsig = norm_ps / (1.0 - (1.0 - self.cs).powf(2.0 * g)).sqrt() / self.chi_n
            < 1.4 + 2.0 / (nf + 1.0);
        let h = if hsig { 1.0 } else { 0.0 };
        self.pc = &self.pc * (1.0 - self.cc)
            + &yw * (h * (self.cc * (2.0 - self.cc) * self.mu_eff).sqrt());
        let mut rank_mu = DMatrix::zeros(n, n);
        for (w, y) in self.weights.iter().zip(&steps) {
            rank_mu.ger(*w, y, y, 1.0);
        }
        let keep = 1.0 - self.c1 - self.cmu + (1.0 - h) * self.c1 * self.cc * (2.0 - self.cc);
        self.cov = &self.cov * keep + &self.pc * self.pc.transpose() * self.c1 + rank_mu * self.cmu;
        self.sigma *= ((self.cs / self.damps) * (norm_ps / self.chi_n - 1.0)).exp();
        self.generation += 1;
        self.decompose();
    }

    /// `B`, `D` from the symmetrized covariance (eigenvalues floored at 1e-20 of the largest).
    fn decompose(&mut self) {
        let sym = (&self.cov + self.cov.transpose()) * 0.5;
        let eig = SymmetricEigen::new(sym);
        let top = eig.eigenvalues.max().max(f64::MIN_POSITIVE);
        self.d = eig.eigenvalues.map(|e| e.max(1e-20 * top).sqrt());
        self.b = eig.eigenvectors;
    }
}

/// NaN ranks after every number.
fn rank_key(v: f64) -> f64 {
    if v.is_nan() { f64::INFINITY } else { v }
}

/// A standard normal sample (Box–Muller).
fn standard_normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random_range(0.0..1.0);
    let u2: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Minimizes `f` from `x0` with step size `sigma` and `population` samples per generation
/// (`None`: the default λ) within `budget`; the candidates of a generation are evaluated in
/// parallel. `observe` sees every generation and stops the run by returning `false`. Returns
/// the best point evaluated (`x0` itself is evaluated first).
pub fn minimize(
    f: impl Fn(&[f64]) -> f64 + Sync,
    x0: &[f64],
    sigma: f64,
    population: Option<usize>,
    budget: Budget,
    seed: u64,
    mut observe: impl FnMut(&Generation) -> bool,
) -> Minimum {
    let mut es = CmaEs::new(x0, sigma, population);
    let mut best = Minimum {
        x: x0.to_vec(),
        value: rank_key(f(x0)),
        generations: 0,
        evaluations: 1,
        stop: Stop::Target,
    };
    let resolution = RESOLUTION * (1.0 + x0.iter().fold(0.0f64, |s, v| s.max(v.abs())));
    let stall = stall_generations(x0.len(), es.population());
    let mut improved_at = 0;
    best.stop = loop {
        if best.value <= budget.target {
            break Stop::Target;
        }
        if best.generations >= budget.generations {
            break Stop::Generations;
        }
        if best.evaluations + es.population() > budget.evaluations {
            break Stop::Evaluations;
        }
        if es.spread() < resolution || best.generations >= improved_at + stall {
            break Stop::Converged;
        }
        let candidates = es.sample(seed);
        let values: Vec<f64> = candidates.par_iter().map(|x| rank_key(f(x))).collect();
        for (x, &v) in candidates.iter().zip(&values) {
            if v < best.value {
                (best.x, best.value) = (x.clone(), v);
                improved_at = best.generations + 1;
            }
        }
        es.update(&candidates, &values);
        best.generations += 1;
        best.evaluations += candidates.len();
        let report = Generation {
            generation: best.generations,
            evaluations: best.evaluations,
            best: best.value,
            sigma: es.sigma(),
        };
        if !observe(&report) {
            break Stop::Stopped;
        }
    };
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rosenbrock(x: &[f64]) -> f64 {
        x.windows(2)
            .map(|w| 100.0 * (w[1] - w[0] * w[0]).powi(2) + (1.0 - w[0]).powi(2))
            .sum()
    }

    fn budget(generations: usize, target: f64) -> Budget {
        Budget {
            generations,
            evaluations: usize::MAX,
            target,
        }
    }

    /// The sphere in 20 dimensions from 3 units away: to 1e-10 within the tutorial's expected
    /// effort (a few thousand evaluations).
    #[test]
    fn minimizes_the_sphere() {
        let sphere = |x: &[f64]| x.iter().map(|v| v * v).sum::<f64>();
        let m = minimize(
            sphere,
            &[3.0; 20],
            1.0,
            None,
            budget(2000, 1e-10),
            1,
            |_| true,
        );
        assert_eq!(m.stop, Stop::Target, "{m:?}");
        assert!(m.value <= 1e-10);
        assert!(m.evaluations < 10_000, "{}", m.evaluations);
    }

    /// Rosenbrock in 8 dimensions from the origin: the curved valley needs the covariance
    /// (with σ adaptation alone the run exhausts its budget); minimum 0 at (1, …, 1).
    #[test]
    fn minimizes_rosenbrock() {
        let m = minimize(
            rosenbrock,
            &[0.0; 8],
            0.5,
            None,
            budget(5000, 1e-12),
            3,
            |_| true,
        );
        assert_eq!(m.stop, Stop::Target, "{m:?}");
        for v in &m.x {
            assert!((v - 1.0).abs() < 1e-4, "{:?}", m.x);
        }
    }

    /// Same seed, same run on one thread and on two; another seed, another run.
    #[test]
    fn runs_do_not_depend_on_the_thread_count() {
        let run = |threads: usize, seed: u64| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    minimize(
                        rosenbrock,
                        &[0.0; 6],
                        0.5,
                        Some(12),
                        budget(60, 0.0),
                        seed,
                        |_| true,
                    )
                })
        };
        let (one, two) = (run(1, 5), run(2, 5));
        assert_eq!(one, two);
        assert_eq!(one.evaluations, 1 + 60 * 12);
        assert_eq!(one.stop, Stop::Generations);
        assert_ne!(one.x, run(2, 6).x);
    }

    /// The budget and the observer bound a run.
    #[test]
    fn budgets_and_observers_stop_a_run() {
        let m = minimize(
            rosenbrock,
            &[0.0; 4],
            0.5,
            Some(10),
            Budget {
                generations: 100,
                evaluations: 55,
                target: 0.0,
            },
            1,
            |_| true,
        );
        assert_eq!(
            (m.stop, m.evaluations, m.generations),
            (Stop::Evaluations, 51, 5)
        );
        let m = minimize(rosenbrock, &[0.0; 4], 0.5, None, budget(100, 0.0), 1, |g| {
            g.generation < 3
        });
        assert_eq!((m.stop, m.generations), (Stop::Stopped, 3));
        // A flat function never improves on its start: the run ends after the stall length.
        let m = minimize(
            |_: &[f64]| 1.0,
            &[0.0; 4],
            0.5,
            Some(6),
            budget(1000, 0.0),
            1,
            |_| true,
        );
        assert_eq!(
            (m.stop, m.generations),
            (Stop::Converged, stall_generations(4, 6))
        );
    }
}
