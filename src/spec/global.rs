//! The `[global]` table a problem file may embed to ask for a global method around the local
//! solver: multistart, simulated annealing alone, or the annealing-then-SQP hybrid.
//!
//! ```toml
//! [global]
//! method = "hybrid"          # "multistart" (default), "anneal" or "hybrid"
//! starts = 8                 # extra starts besides the problem's own (multistart, hybrid)
//! perturbation = 0.25        # random-start scale, relative to each variable's range (multistart)
//! initial_temperature = 1.0  # annealing keys (anneal, hybrid), ASA's names
//! temperature_ratio_scale = 1e-5
//! max_evaluations = 20000
//! ```
//! Every key is optional; defaults are those of [`MultistartOptions`] and [`AnnealOptions`].
//! A key that the chosen method does not use is an error, so a typo in the method cannot
//! silently drop settings. The seed comes from the command line (`--seed`).

use serde::Deserialize;

use super::{Key, Source, is_positive as positive};
use crate::error::InputError;
use crate::solver::global::{AnnealOptions, GlobalMethod, MultistartOptions, StartGenerator};

/// Which global method a `[global]` table asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GlobalMethodName {
    /// Local solves from the start and from random perturbations of it.
    #[default]
    Multistart,
    /// Simulated annealing alone (no local solve).
    Anneal,
    /// Local solves from the start and from the best states of annealing runs (seed §6.2).
    Hybrid,
}

/// The `[global]` table. All keys optional.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GlobalSpec {
    /// "multistart" (default), "anneal" or "hybrid".
    pub method: Option<GlobalMethodName>,
    /// Extra starts besides the problem's own (multistart, hybrid); default 8.
    pub starts: Option<usize>,
    /// Random-start scale relative to each variable's range (multistart); default 0.25.
    pub perturbation: Option<f64>,
    /// Largest constraint violation of a feasible result (units of c); default 1e-6.
    pub feasibility_tolerance: Option<f64>,
    /// Annealing: initial parameter temperature (dimensionless); default 1.
    pub initial_temperature: Option<f64>,
    /// Annealing: ASA's Temperature_Ratio_Scale, in (0, 1); default 1e-5.
    pub temperature_ratio_scale: Option<f64>,
    /// Annealing: ASA's Temperature_Anneal_Scale, > 1; default 100.
    pub temperature_anneal_scale: Option<f64>,
    /// Annealing: ASA's Cost_Parameter_Scale_Ratio; default 1.
    pub cost_parameter_scale_ratio: Option<f64>,
    /// Annealing: initial cost temperature (units of the objective); default from samples.
    pub initial_cost_temperature: Option<f64>,
    /// Annealing: states sampled for the initial cost temperature; default 5.
    pub cost_samples: Option<usize>,
    /// Annealing: relative best-cost change that counts as none (ASA's Cost_Precision);
    /// default 1e-18.
    pub cost_precision: Option<f64>,
    /// Annealing: best-cost repeats in a row that stop a run; default 5.
    pub maximum_cost_repeat: Option<usize>,
    /// Annealing: acceptances between stopping checks; default 100.
    pub acceptance_check_interval: Option<usize>,
    /// Annealing: evaluations per run; default 100 000.
    pub max_evaluations: Option<usize>,
    /// Annealing: initial penalty weight relative to max(1, |f(start)|); default 10.
    pub penalty_weight: Option<f64>,
    /// Annealing: penalty growth factor while infeasible, ≥ 1; default 10.
    pub penalty_growth: Option<f64>,
    /// Annealing: generated states between penalty updates; default 1000.
    pub penalty_interval: Option<usize>,
}

/// Keys only the annealing methods use.
const ANNEAL_KEYS: [&str; 13] = [
    "initial_temperature",
    "temperature_ratio_scale",
    "temperature_anneal_scale",
    "cost_parameter_scale_ratio",
    "initial_cost_temperature",
    "cost_samples",
    "cost_precision",
    "maximum_cost_repeat",
    "acceptance_check_interval",
    "max_evaluations",
    "penalty_weight",
    "penalty_growth",
    "penalty_interval",
];

impl GlobalSpec {
    /// The method asked for.
    pub fn method(&self) -> GlobalMethodName {
        self.method.unwrap_or_default()
    }

    fn anneal_keys_given(&self) -> Vec<&'static str> {
        let given = [
            self.initial_temperature.is_some(),
            self.temperature_ratio_scale.is_some(),
            self.temperature_anneal_scale.is_some(),
            self.cost_parameter_scale_ratio.is_some(),
            self.initial_cost_temperature.is_some(),
            self.cost_samples.is_some(),
            self.cost_precision.is_some(),
            self.maximum_cost_repeat.is_some(),
            self.acceptance_check_interval.is_some(),
            self.max_evaluations.is_some(),
            self.penalty_weight.is_some(),
            self.penalty_growth.is_some(),
            self.penalty_interval.is_some(),
        ];
        ANNEAL_KEYS
            .iter()
            .zip(given)
            .filter_map(|(k, g)| g.then_some(*k))
            .collect()
    }

    /// Checks ranges and that every key given is used by the method; `path` is where this
    /// table sits in the file (usually `["global"]`).
    pub fn validate(&self, source: &Source, path: &[Key<'_>]) -> Result<(), InputError> {
        let at = |key: &'static str, msg: String| {
            let mut p = path.to_vec();
            p.push(Key::Name(key));
            source.error_at(&p, msg)
        };
        let method = self.method();
        let name = match method {
            GlobalMethodName::Multistart => "multistart",
            GlobalMethodName::Anneal => "anneal",
            GlobalMethodName::Hybrid => "hybrid",
        };
        if method == GlobalMethodName::Multistart
            && let Some(key) = self.anneal_keys_given().first()
        {
            return Err(at(
                key,
                format!(
                    "`{key}` is an annealing setting, unused by method \"multistart\"; use method \"anneal\" or \"hybrid\""
                ),
            ));
        }
        if method != GlobalMethodName::Multistart && self.perturbation.is_some() {
            return Err(at(
                "perturbation",
                format!(
                    "`perturbation` is unused by method \"{name}\" (its starts come from annealing)"
                ),
            ));
        }
        if method == GlobalMethodName::Anneal && self.starts.is_some() {
            return Err(at(
                "starts",
                "`starts` is unused by method \"anneal\" (one annealing run); use method \"hybrid\" for several".into(),
            ));
        }
        if self.starts == Some(0) {
            return Err(at("starts", "`starts` must be at least 1".into()));
        }
        for (key, value) in [
            ("perturbation", self.perturbation),
            ("feasibility_tolerance", self.feasibility_tolerance),
            ("initial_temperature", self.initial_temperature),
            (
                "cost_parameter_scale_ratio",
                self.cost_parameter_scale_ratio,
            ),
            ("initial_cost_temperature", self.initial_cost_temperature),
            ("penalty_weight", self.penalty_weight),
        ] {
            if let Some(v) = value
                && !positive(v)
            {
                return Err(at(key, format!("`{key}` must be positive, got {v}")));
            }
        }
        if let Some(v) = self.temperature_ratio_scale
            && !(v > 0.0 && v < 1.0)
        {
            return Err(at(
                "temperature_ratio_scale",
                format!("`temperature_ratio_scale` must be in (0, 1), got {v}"),
            ));
        }
        if let Some(v) = self.temperature_anneal_scale
            && !(v > 1.0 && v.is_finite())
        {
            return Err(at(
                "temperature_anneal_scale",
                format!("`temperature_anneal_scale` must be greater than 1, got {v}"),
            ));
        }
        if let Some(v) = self.cost_precision
            && !(0.0..1.0).contains(&v)
        {
            return Err(at(
                "cost_precision",
                format!("`cost_precision` must be in [0, 1), got {v}"),
            ));
        }
        if let Some(v) = self.penalty_growth
            && !(v >= 1.0 && v.is_finite())
        {
            return Err(at(
                "penalty_growth",
                format!("`penalty_growth` must be at least 1, got {v}"),
            ));
        }
        for (key, value) in [
            ("maximum_cost_repeat", self.maximum_cost_repeat),
            ("acceptance_check_interval", self.acceptance_check_interval),
            ("max_evaluations", self.max_evaluations),
            ("penalty_interval", self.penalty_interval),
        ] {
            if value == Some(0) {
                return Err(at(key, format!("`{key}` must be at least 1")));
            }
        }
        Ok(())
    }

    /// Annealing options: defaults overridden by this table.
    pub fn anneal_options(&self, seed: u64) -> AnnealOptions {
        let d = AnnealOptions::default();
        AnnealOptions {
            seed,
            initial_temperature: self.initial_temperature.unwrap_or(d.initial_temperature),
            temperature_ratio_scale: self
                .temperature_ratio_scale
                .unwrap_or(d.temperature_ratio_scale),
            temperature_anneal_scale: self
                .temperature_anneal_scale
                .unwrap_or(d.temperature_anneal_scale),
            cost_parameter_scale_ratio: self
                .cost_parameter_scale_ratio
                .unwrap_or(d.cost_parameter_scale_ratio),
            initial_cost_temperature: self.initial_cost_temperature.or(d.initial_cost_temperature),
            cost_samples: self.cost_samples.unwrap_or(d.cost_samples),
            cost_precision: self.cost_precision.unwrap_or(d.cost_precision),
            maximum_cost_repeat: self.maximum_cost_repeat.unwrap_or(d.maximum_cost_repeat),
            acceptance_check_interval: self
                .acceptance_check_interval
                .unwrap_or(d.acceptance_check_interval),
            max_evaluations: self.max_evaluations.unwrap_or(d.max_evaluations),
            penalty_weight: self.penalty_weight.unwrap_or(d.penalty_weight),
            penalty_growth: self.penalty_growth.unwrap_or(d.penalty_growth),
            penalty_interval: self.penalty_interval.unwrap_or(d.penalty_interval),
            feasibility_tolerance: self
                .feasibility_tolerance
                .unwrap_or(d.feasibility_tolerance),
            interrupt: None,
        }
    }

    /// The global method with its settings; `seed` is the run's `--seed`.
    pub fn options(&self, seed: u64) -> GlobalMethod {
        let d = MultistartOptions::default();
        let multistart = |generator| MultistartOptions {
            starts: self.starts.unwrap_or(d.starts),
            perturbation: self.perturbation.unwrap_or(d.perturbation),
            seed,
            feasibility_tolerance: self
                .feasibility_tolerance
                .unwrap_or(d.feasibility_tolerance),
            generator,
        };
        match self.method() {
            GlobalMethodName::Multistart => {
                GlobalMethod::Multistart(multistart(StartGenerator::Perturb))
            }
            GlobalMethodName::Hybrid => GlobalMethod::Multistart(multistart(
                StartGenerator::Anneal(self.anneal_options(seed)),
            )),
            GlobalMethodName::Anneal => GlobalMethod::Anneal(self.anneal_options(seed)),
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct File {
        #[serde(default)]
        global: GlobalSpec,
    }

    fn source(text: &str) -> Source {
        Source {
            path: PathBuf::from("p.toml"),
            text: text.to_string(),
        }
    }

    fn check(text: &str) -> Result<GlobalSpec, InputError> {
        let s = source(text);
        let f: File = s.parse()?;
        f.global.validate(&s, &[Key::Name("global")])?;
        Ok(f.global)
    }

    #[test]
    fn defaults_are_multistart_with_documented_values() {
        let spec = check("").unwrap();
        let GlobalMethod::Multistart(m) = spec.options(42) else {
            panic!("default is multistart")
        };
        assert_eq!((m.starts, m.perturbation, m.seed), (8, 0.25, 42));
        assert!(matches!(m.generator, StartGenerator::Perturb));
    }

    #[test]
    fn hybrid_carries_annealing_settings_and_the_seed() {
        let spec = check(
            "[global]\nmethod = \"hybrid\"\nstarts = 3\ntemperature_ratio_scale = 1e-4\nmax_evaluations = 500\n",
        )
        .unwrap();
        let GlobalMethod::Multistart(m) = spec.options(7) else {
            panic!("hybrid is a multistart")
        };
        let StartGenerator::Anneal(a) = m.generator else {
            panic!("hybrid starts come from annealing")
        };
        assert_eq!(m.starts, 3);
        assert_eq!(
            (a.temperature_ratio_scale, a.max_evaluations, a.seed),
            (1e-4, 500, 7)
        );
        assert_eq!(a.temperature_anneal_scale, 100.0);
    }

    #[test]
    fn unknown_method_and_keys_are_positioned() {
        let e = check("[global]\nmethod = \"genetic\"\n").unwrap_err();
        assert_eq!(e.position.map(|p| p.0), Some(2));
        let e = check("[global]\nstart = 3\n").unwrap_err();
        assert!(e.message.contains("did you mean `starts`"), "{}", e.message);
    }

    #[test]
    fn out_of_range_values_point_at_their_key() {
        let e =
            check("[global]\nmethod = \"anneal\"\n\ntemperature_ratio_scale = 2.0\n").unwrap_err();
        assert_eq!(e.position, Some((4, 1)));
        assert!(e.message.contains("(0, 1)"), "{}", e.message);
        let e = check("[global]\nstarts = 0\n").unwrap_err();
        assert_eq!(e.position, Some((2, 1)));
        let e = check("[global]\nperturbation = nan\n").unwrap_err();
        assert!(e.message.contains("must be finite"), "{}", e.message);
    }

    #[test]
    fn keys_unused_by_the_method_are_errors() {
        let e = check("[global]\nstarts = 4\nmax_evaluations = 10\n").unwrap_err();
        assert_eq!(e.position, Some((3, 1)));
        assert!(
            e.message.contains("unused by method \"multistart\""),
            "{}",
            e.message
        );
        let e = check("[global]\nmethod = \"hybrid\"\nperturbation = 0.1\n").unwrap_err();
        assert_eq!(e.position, Some((3, 1)));
        let e = check("[global]\nmethod = \"anneal\"\nstarts = 2\n").unwrap_err();
        assert_eq!(e.position, Some((3, 1)));
    }
}
