//! A generic ask/tell genetic algorithm, as the paper uses it twice (after TaCOS): for camera
//! hardware (population 10, mutation ×U(0.8, 1.2)) and for exposure/gain perturbations
//! (population 4, ×U(0.9, 1.1)). It knows nothing about cameras: genes are real numbers with
//! bounds, and a caller-supplied hook may rewrite a new genome (the camera codec snaps sensor
//! genes to the catalogue there).
//!
//! One generation: the caller *asks* for the members, evaluates each, and *tells* their fitness
//! (higher is better). The best half become parents and stay in the population (they are
//! evaluated again next generation, because in joint training the detector — and so every
//! fitness — keeps changing); the other half are offspring of two distinct random parents:
//! uniform crossover (each gene from either parent), then each gene multiplied by a factor
//! drawn from U(a, b) and, optionally, shifted by a normal draw (`GaConfig::with_shift`) or by
//! a uniform one in gene units with a chosen number of elites (`GaConfig::with_additive`,
//! TaCOS's published operator), clipped to its bounds, then the hook. A multiplicative mutation never changes a gene's sign
//! and crossover and clipping keep it too, so genes that must cross zero need the shift.
//!
//! ```
//! use joca_evolve::{Ga, GaConfig};
//! use rand::SeedableRng;
//!
//! let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
//! let config = GaConfig::new(10, vec![(0.1, 10.0); 2], (0.8, 1.2)).unwrap();
//! let mut ga = Ga::new(config, &mut rng);
//! for _ in 0..30 {
//!     // Maximise −(x−3)² − (y−7)².
//!     let fitness: Vec<f64> =
//!         ga.ask().iter().map(|g| -(g[0] - 3.0).powi(2) - (g[1] - 7.0).powi(2)).collect();
//!     ga.tell(&fitness, &mut rng, |_| {}).unwrap();
//! }
//! let (best, _) = ga.best().unwrap();
//! assert!((best[0] - 3.0).abs() < 0.5 && (best[1] - 7.0).abs() < 0.5);
//! ```
#![deny(missing_docs)]

use rand::Rng;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors of the GA.
#[derive(Debug, Error, PartialEq)]
pub enum GaError {
    /// A setting is out of range.
    #[error("{field} = {value} is invalid: {allowed}")]
    Config {
        /// The setting.
        field: &'static str,
        /// Its value.
        value: String,
        /// What is allowed.
        allowed: &'static str,
    },
    /// `tell` got a fitness list of the wrong length.
    #[error("tell got {got} fitness values for a population of {expected}")]
    FitnessCount {
        /// Population size.
        expected: usize,
        /// Values given.
        got: usize,
    },
}

/// GA settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GaConfig {
    /// Members per generation.
    pub population: usize,
    /// `(min, max)` of each gene.
    pub bounds: Vec<(f64, f64)>,
    /// Mutation factor range `(a, b)`: each gene of an offspring is multiplied by U(a, b).
    pub mutation: (f64, f64),
    /// Share of the population that survives as parents.
    pub parent_fraction: f64,
    /// Standard deviation of an additive normal mutation, as a fraction of each gene's range
    /// (0: none, the paper's operators).
    #[serde(default)]
    pub shift: f64,
    /// Half-widths `a` of an additive uniform mutation per gene, in the gene's own units: each
    /// gene of an offspring gets `+ U(−a, a)` after the factor (empty: none, the paper's printed
    /// operator; TaCOS's published GA adds U(−3, 3)).
    #[serde(default)]
    pub additive: Vec<f64>,
    /// Members carried unchanged into the next generation, best first (`None`: every parent,
    /// the paper's "best 50 % are parents" that stay). Parents still breed the offspring.
    #[serde(default)]
    pub elites: Option<usize>,
}

impl GaConfig {
    /// Settings with the paper's parent share (best 50 %).
    pub fn new(
        population: usize,
        bounds: Vec<(f64, f64)>,
        mutation: (f64, f64),
    ) -> Result<Self, GaError> {
        let c = Self {
            population,
            bounds,
            mutation,
            parent_fraction: 0.5,
            shift: 0.0,
            additive: Vec::new(),
            elites: None,
        };
        c.validate()?;
        Ok(c)
    }

    /// The same settings with an additive `U(−a, a)` mutation per gene (`additive[i]` for gene
    /// `i`, gene units) and `elites` members carried unchanged — TaCOS's published operator.
    pub fn with_additive(self, additive: Vec<f64>, elites: usize) -> Result<Self, GaError> {
        let c = Self { additive, elites: Some(elites), ..self };
        c.validate()?;
        Ok(c)
    }

    /// The same settings with an additive normal mutation of standard deviation `shift` times
    /// each gene's range (0 to 1).
    pub fn with_shift(self, shift: f64) -> Result<Self, GaError> {
        let c = Self { shift, ..self };
        c.validate()?;
        Ok(c)
    }

    /// Checks the settings.
    pub fn validate(&self) -> Result<(), GaError> {
        if self.population < 2 {
            return Err(GaError::Config {
                field: "population",
                value: self.population.to_string(),
                allowed: "at least 2",
            });
        }
        if self.bounds.is_empty()
            || self.bounds.iter().any(|(lo, hi)| lo > hi || !lo.is_finite() || !hi.is_finite())
        {
            return Err(GaError::Config {
                field: "bounds",
                value: format!("{:?}", self.bounds),
                allowed: "at least one finite (min, max) with min ≤ max",
            });
        }
        let (a, b) = self.mutation;
        if !(a > 0.0 && a <= b && b.is_finite()) {
            return Err(GaError::Config {
                field: "mutation",
                value: format!("{:?}", self.mutation),
                allowed: "(a, b) with 0 < a ≤ b",
            });
        }
        if !(0.0..=1.0).contains(&self.shift) {
            return Err(GaError::Config {
                field: "shift",
                value: self.shift.to_string(),
                allowed: "0 to 1",
            });
        }
        if !self.additive.is_empty()
            && (self.additive.len() != self.bounds.len()
                || self.additive.iter().any(|a| !(a.is_finite() && *a >= 0.0)))
        {
            return Err(GaError::Config {
                field: "additive",
                value: format!("{:?}", self.additive),
                allowed: "one finite half-width ≥ 0 per gene, or none",
            });
        }
        if self.elites.is_some_and(|e| e == 0 || e >= self.population) {
            return Err(GaError::Config {
                field: "elites",
                value: format!("{:?}", self.elites),
                allowed: "at least 1 and fewer than the population",
            });
        }
        if !(self.parent_fraction > 0.0 && self.parent_fraction < 1.0) {
            return Err(GaError::Config {
                field: "parent_fraction",
                value: self.parent_fraction.to_string(),
                allowed: "between 0 and 1",
            });
        }
        Ok(())
    }

    fn parents(&self) -> usize {
        ((self.population as f64 * self.parent_fraction).round() as usize)
            .clamp(1, self.population - 1)
    }
}

/// The GA's whole state; serialisable, so a run can be checkpointed between any two calls.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Ga {
    config: GaConfig,
    generation: usize,
    members: Vec<Vec<f64>>,
    best: Option<(Vec<f64>, f64)>,
}

impl Ga {
    /// A first generation drawn uniformly within the bounds.
    pub fn new(config: GaConfig, rng: &mut impl Rng) -> Self {
        let members = (0..config.population)
            .map(|_| {
                config
                    .bounds
                    .iter()
                    .map(|&(lo, hi)| if hi > lo { rng.random_range(lo..=hi) } else { lo })
                    .collect()
            })
            .collect();
        Self { config, generation: 0, members, best: None }
    }

    /// A first generation given by the caller (clipped to the bounds).
    pub fn with_members(config: GaConfig, members: Vec<Vec<f64>>) -> Self {
        let mut ga = Self { config, generation: 0, members, best: None };
        let bounds = ga.config.bounds.clone();
        for m in &mut ga.members {
            clip(m, &bounds);
        }
        ga
    }

    /// Applies `hook` to every current member (e.g. to snap a random first generation).
    pub fn apply(&mut self, mut hook: impl FnMut(&mut [f64])) {
        for m in &mut self.members {
            hook(m);
        }
    }

    /// The members to evaluate in this generation.
    pub fn ask(&self) -> &[Vec<f64>] {
        &self.members
    }

    /// Generations completed.
    pub fn generation(&self) -> usize {
        self.generation
    }

    /// Settings.
    pub fn config(&self) -> &GaConfig {
        &self.config
    }

    /// The best member seen so far and its fitness.
    pub fn best(&self) -> Option<(&[f64], f64)> {
        self.best.as_ref().map(|(g, f)| (g.as_slice(), *f))
    }

    /// Takes the fitness of every member (same order as [`Ga::ask`]; NaN counts as the worst)
    /// and breeds the next generation, calling `hook` on each new offspring.
    pub fn tell(
        &mut self,
        fitness: &[f64],
        rng: &mut impl Rng,
        mut hook: impl FnMut(&mut [f64]),
    ) -> Result<(), GaError> {
        if fitness.len() != self.members.len() {
            return Err(GaError::FitnessCount { expected: self.members.len(), got: fitness.len() });
        }
        let score = |f: f64| if f.is_nan() { f64::NEG_INFINITY } else { f };
        // Stable sort, best first: ties keep the earlier member.
        let mut order: Vec<usize> = (0..fitness.len()).collect();
        order.sort_by(|&a, &b| score(fitness[b]).total_cmp(&score(fitness[a])));
        let top = order[0];
        if self.best.as_ref().is_none_or(|(_, f)| score(fitness[top]) > *f) {
            self.best = Some((self.members[top].clone(), score(fitness[top])));
        }
        let parents: Vec<Vec<f64>> =
            order[..self.config.parents()].iter().map(|&i| self.members[i].clone()).collect();
        let elites = self.config.elites.unwrap_or(parents.len());
        let mut next: Vec<Vec<f64>> =
            order[..elites].iter().map(|&i| self.members[i].clone()).collect();
        let (a, b) = self.config.mutation;
        while next.len() < self.config.population {
            let i = rng.random_range(0..parents.len());
            let j = if parents.len() > 1 {
                let j = rng.random_range(0..parents.len() - 1);
                if j >= i { j + 1 } else { j }
            } else {
                i
            };
            let mut child: Vec<f64> = parents[i]
                .iter()
                .zip(&parents[j])
                .map(|(&x, &y)| if rng.random::<bool>() { x } else { y })
                .collect();
            for g in &mut child {
                *g *= if a < b { rng.random_range(a..b) } else { a };
            }
            if self.config.shift > 0.0 {
                for (g, &(lo, hi)) in child.iter_mut().zip(&self.config.bounds) {
                    *g += self.config.shift * (hi - lo) * standard_normal(rng);
                }
            }
            for (g, &a) in child.iter_mut().zip(&self.config.additive) {
                if a > 0.0 {
                    *g += rng.random_range(-a..a);
                }
            }
            clip(&mut child, &self.config.bounds);
            hook(&mut child);
            next.push(child);
        }
        self.members = next;
        self.generation += 1;
        Ok(())
    }
}

/// A standard normal draw (Box–Muller, one of the pair).
fn standard_normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>(); // (0, 1]
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

fn clip(genes: &mut [f64], bounds: &[(f64, f64)]) {
    for (g, &(lo, hi)) in genes.iter_mut().zip(bounds) {
        *g = g.clamp(lo, hi);
    }
}

#[cfg(test)]
mod tests;
