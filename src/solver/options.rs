//! Solver settings: tolerances, limits, Hessian mode, QP method, globalization, verbosity; the
//! library's `Options` and a problem file's `[solver]` table are the same type.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use serde::{Deserialize, Serialize};

use super::Tuning;
use super::log::LogTarget;
use super::qp::QpMethod;

/// How the solver obtains second-order information.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum HessianMode {
    /// Exact if the problem provides it, else dense damped BFGS for small n, L-BFGS for large n.
    #[default]
    Auto,
    /// Dense damped (Powell) BFGS (L-BFGS is used instead above `qp::DENSE_LIMIT` variables).
    Bfgs,
    /// Limited-memory BFGS (no dense n×n matrix).
    Lbfgs,
    /// The problem's exact Lagrangian Hessian with inertia correction.
    Exact,
}

/// How the SQP method makes sure a step improves the ℓ1 merit function.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Globalization {
    /// Backtracking Armijo line search along the QP step (with a second-order correction).
    #[default]
    LineSearch,
    /// Fletcher's Sℓ1QP trust region: the QP step is bounded by an ℓ∞ radius that shrinks
    /// when the merit function's actual decrease falls short of the model's prediction and
    /// grows when it matches; the elastic penalty steering only asks for what the linearized
    /// constraints can reach within the radius.
    TrustRegion,
}

/// Declares [`Options`] from one list: each setting's doc line, name, type, default and
/// (optionally) its range check. The struct, its `Default`, its `PartialEq` and
/// [`Options::validate`] are generated from that list, so a setting is added in one place.
macro_rules! settings {
    ($(
        $(#[doc = $doc:literal])*
        $(#[serde($serde:meta)])?
        $name:ident: $ty:ty = $default:expr $(, valid: $check:path)?;
    )*) => {
        /// Everything that steers a solve, and the `[solver]` table of every problem file
        /// (same names, except `qp_method`, which files spell `qp`). All keys are optional in a
        /// file; `Default` gives the documented defaults. [`Options::validate`] checks ranges.
        #[derive(Debug, Clone, Deserialize)]
        #[serde(default, deny_unknown_fields)]
        pub struct Options {
            $(
                $(#[doc = $doc])*
                $(#[serde($serde)])?
                pub $name: $ty,
            )*
            /// Set from outside (Ctrl-C) to stop at the end of the current iteration with status
            /// `Interrupted`, returning the best point so far. Not a file key.
            #[serde(skip)]
            pub interrupt: Option<Arc<AtomicBool>>,
            /// The SQP method's tuning constants (tests vary them). Not a file key.
            #[serde(skip)]
            pub tuning: Tuning,
            /// Where the log goes, who observes the iterations, how the objective is shown
            /// (default: nowhere; the command line passes stderr). Not a file key.
            #[serde(skip)]
            pub log: LogTarget,
        }

        impl Default for Options {
            fn default() -> Self {
                Options {
                    $($name: $default,)*
                    interrupt: None,
                    tuning: Tuning::default(),
                    log: LogTarget::default(),
                }
            }
        }

        /// Settings compare by value, the interrupt flag by identity.
        impl PartialEq for Options {
            fn eq(&self, other: &Self) -> bool {
                $(self.$name == other.$name &&)*
                self.tuning == other.tuning
                    && match (&self.interrupt, &other.interrupt) {
                        (None, None) => true,
                        (Some(a), Some(b)) => Arc::ptr_eq(a, b),
                        _ => false,
                    }
            }
        }

        impl Options {
            /// Checks every setting's range; the first one out of range is the error.
            pub fn validate(&self) -> Result<(), InvalidSetting> {
                $($(
                    $check(&self.$name).map_err(|why| InvalidSetting {
                        key: stringify!($name),
                        message: format!("`{}` {why}", stringify!($name)),
                    })?;
                )?)*
                Ok(())
            }
        }
    };
}

settings! {
    /// Scaled dual-optimality tolerance, in (0, 1).
    tolerance: f64 = 1e-6, valid: open_unit_interval;
    /// Scaled primal-feasibility tolerance, in (0, 1).
    constraint_tolerance: f64 = 1e-6, valid: open_unit_interval;
    /// Major-iteration limit.
    max_iterations: usize = 1000;
    /// Iterations within 100× `constraint_tolerance` of feasibility, in a window over which
    /// the objective must fall by more than
    /// `progress_tolerance` (relative to max(1, |f|)), or the solve ends `SlowProgress`; 0 (the
    /// default) turns the test off. Meant for a solve that a caller follows with a change of
    /// model (truss clean-up rounds), not for a final answer.
    progress_window: usize = 0;
    /// See `progress_window`; in (0, 1).
    progress_tolerance: f64 = 1e-3, valid: open_unit_interval;
    /// With `progress_window` on: feasible iterations per stretch of a second creep test. The
    /// solve also ends `SlowProgress` when the objective's decrease over the last stretch is at
    /// most half its decrease over the stretch before and at most `progress_tolerance`
    /// (relative): decreases shrinking by ½ or faster per stretch have less than the last one
    /// left to gain, so the window need not wait. 0 (the default) turns it off.
    progress_stretch: usize = 0;
    /// With `progress_stretch` on: the stretch test extrapolates instead of asking for ½. The
    /// solve ends `SlowProgress` when the last two stretches' decreases Δ₁ ≥ Δ₂ ≥ 0, continued
    /// geometrically (ratio Δ₂/Δ₁ per stretch) over the next `progress_window` iterations, add
    /// up to at most `progress_tolerance` (relative): the window's test applied to the
    /// decreases to come rather than to those seen. Off by default; the truss default rounds
    /// with `linear` mass turn it on (`truss::rounds`).
    progress_extrapolate: bool = false;
    /// Second-order corrections the line search tries after a rejected full step, 1–20, each
    /// from the constraint values at the last corrected point and kept only while the
    /// violation falls by 1 % or more (IPOPT's `max_soc`, `kappa_soc`). `None`: 1, except in
    /// the default rounds of a truss with `linear` mass, which try 4 (`truss::rounds`).
    second_order_corrections: Option<usize> = None, valid: correction_count;
    /// Wall-clock limit for one solve in seconds (positive); `None`: unlimited.
    max_time: Option<f64> = None, valid: positive_seconds;
    /// Second-order information (see [`HessianMode`]).
    hessian: HessianMode = HessianMode::Auto;
    /// Correction pairs kept by L-BFGS, at least 1.
    lbfgs_memory: usize = 10, valid: at_least_one;
    /// QP subproblem method: `Auto` (dense Goldfarb–Idnani for n ≤ [`super::qp::DENSE_LIMIT`],
    /// sparse interior point above), or either one forced (`Sparse` never forms an n×n matrix).
    /// The file key is `qp`.
    #[serde(rename = "qp")]
    qp_method: QpMethod = QpMethod::Auto;
    /// Line search (default) or trust region.
    globalization: Globalization = Globalization::LineSearch;
    /// 0 silent, 1 one line per iteration, 2 more detail. The log goes to `log`.
    verbosity: u8 = 1, valid: log_level;
}

/// A setting out of its range: which one, and a sentence saying so.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InvalidSetting {
    /// The setting's name (its key in a problem file's `[solver]` table).
    pub key: &'static str,
    /// E.g. "`tolerance` must be in (0, 1), got 2".
    pub message: String,
}

impl std::fmt::Display for InvalidSetting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for InvalidSetting {}

fn open_unit_interval(v: &f64) -> Result<(), String> {
    if *v > 0.0 && *v < 1.0 {
        Ok(())
    } else {
        Err(format!("must be in (0, 1), got {v}"))
    }
}

fn positive_seconds(t: &Option<f64>) -> Result<(), String> {
    match t {
        Some(t) if t.is_nan() || *t <= 0.0 => Err(format!("must be positive seconds, got {t}")),
        _ => Ok(()),
    }
}

fn at_least_one(n: &usize) -> Result<(), String> {
    if *n >= 1 {
        Ok(())
    } else {
        Err("must be at least 1".into())
    }
}

fn correction_count(n: &Option<usize>) -> Result<(), String> {
    match n {
        Some(n) if !(1..=20).contains(n) => Err("must be from 1 to 20".into()),
        _ => Ok(()),
    }
}

fn log_level(v: &u8) -> Result<(), String> {
    if *v <= 2 {
        Ok(())
    } else {
        Err(format!("must be 0, 1 or 2, got {v}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_empty_table_gives_the_defaults() {
        let parsed: Options = toml::from_str("").unwrap();
        assert_eq!(parsed, Options::default());
        assert_eq!(Options::default().validate(), Ok(()));
    }

    #[test]
    fn file_keys_set_the_library_fields() {
        let parsed: Options =
            toml::from_str("qp = \"sparse\"\nmax_time = 2.5\nglobalization = \"trust_region\"")
                .unwrap();
        assert_eq!(parsed.qp_method, QpMethod::Sparse);
        assert_eq!(parsed.max_time, Some(2.5));
        assert_eq!(parsed.globalization, Globalization::TrustRegion);
        assert!(toml::from_str::<Options>("tuning = 1").is_err());
        assert!(toml::from_str::<Options>("interrupt = true").is_err());
    }

    #[test]
    fn validate_names_the_first_setting_out_of_range() {
        let bad = Options {
            constraint_tolerance: 1.0,
            verbosity: 3,
            ..Options::default()
        };
        let e = bad.validate().unwrap_err();
        assert_eq!(e.key, "constraint_tolerance");
        assert_eq!(e.message, "`constraint_tolerance` must be in (0, 1), got 1");
        for (options, message) in [
            (
                Options {
                    max_time: Some(f64::NAN),
                    ..Options::default()
                },
                "`max_time` must be positive seconds, got NaN",
            ),
            (
                Options {
                    lbfgs_memory: 0,
                    ..Options::default()
                },
                "`lbfgs_memory` must be at least 1",
            ),
            (
                Options {
                    verbosity: 3,
                    ..Options::default()
                },
                "`verbosity` must be 0, 1 or 2, got 3",
            ),
            (
                Options {
                    second_order_corrections: Some(0),
                    ..Options::default()
                },
                "`second_order_corrections` must be from 1 to 20",
            ),
        ] {
            assert_eq!(options.validate().unwrap_err().message, message);
        }
    }
}
