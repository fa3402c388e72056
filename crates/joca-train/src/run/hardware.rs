//! The hardware GA's settings: the paper's printed operator or TaCOS's published one.
//!
//! The paper (Sec. 5) multiplies each gene by U(0.8, 1.2) and keeps the best half. Once the
//! parents share a sensor, every offspring's sensor genes stay within 20 % of that sensor's and
//! snap back to it, so the search cannot leave it. TaCOS's published GA, whose recommendations
//! the paper follows, adds U(−3, 3) in gene units (mm, µm) after the factor and keeps 3 elites
//! of 10, so offspring can jump across the catalogue. The mount genes (x, z) span less than
//! 3 m, so their additive half-width is a third of their range, as 3 mm is a third of the
//! focal length's 9 mm range.

use super::ga_err;
use crate::TrainError;
use joca_camera::GenomeCodec;
use joca_evolve::GaConfig;

joca_core::named_enum! {
    /// The hardware GA's mutation operator.
    #[derive(Default)]
    pub enum HardwareMutation("hardware mutation") {
        /// TaCOS's published operator: each gene ×U(0.8, 1.2) + U(−a, a), a = 3 in gene units for
        /// the focal length (mm) and the sensor genes (mm, µm), a third of the range for the mount
        /// genes (whose ranges are under 3 m); the best 3 in 10 carried unchanged.
        #[default]
        Tacos = "tacos",
        /// The paper's printed operator: ×U(0.8, 1.2), the best half kept.
        Paper = "paper",
    }
}

/// The additive half-width of the focal length and sensor genes, in their units (TaCOS).
const ADDITIVE_GENE_UNITS: f64 = 3.0;
/// Elites carried unchanged per 10 members (TaCOS).
const ELITES_PER_10: f64 = 3.0;

/// The hardware GA's configuration for a population of `population` over `codec`'s genes.
pub(super) fn ga_config(
    mutation: HardwareMutation,
    population: usize,
    codec: &GenomeCodec,
) -> Result<GaConfig, TrainError> {
    let genes = codec.genes();
    let bounds: Vec<(f64, f64)> = genes.iter().map(|g| (g.bounds.min, g.bounds.max)).collect();
    let paper = GaConfig::new(population, bounds.clone(), (0.8, 1.2)).map_err(ga_err)?;
    match mutation {
        HardwareMutation::Paper => Ok(paper),
        HardwareMutation::Tacos => {
            let additive = genes
                .iter()
                .zip(&bounds)
                .map(|(g, &(lo, hi))| match g.name {
                    "x_m" | "z_m" => (hi - lo) / 3.0,
                    // The discrete encoding's position gene: 3 rows either way.
                    _ => ADDITIVE_GENE_UNITS,
                })
                .collect();
            let elites = ((population as f64 * ELITES_PER_10 / 10.0).round() as usize)
                .clamp(1, population - 1);
            paper.with_additive(additive, elites).map_err(ga_err)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use joca_camera::{DesignSpace, SensorEncoding, sensor_by_name};
    use joca_core::SeedStreams;
    use joca_evolve::Ga;
    use rand::Rng;
    use std::collections::BTreeSet;

    /// From a population of ten copies of one design (IMX172 behind 3.6 mm), five generations
    /// in which that sensor is the fittest (so the parents stay on it, as in a converged run):
    /// the sensors the offspring reach, and their pixel pitch range, µm.
    fn offspring_sensors(mutation: HardwareMutation, seed: u64) -> (BTreeSet<usize>, f64, f64) {
        let codec = GenomeCodec::new(DesignSpace::synthetic(), SensorEncoding::QuantisedContinuous)
            .unwrap();
        let s = sensor_by_name("IMX172").unwrap();
        let genome = vec![0.43, 1.65, 3.6, s.width_mm, s.height_mm, s.pixel_pitch_um];
        let config = ga_config(mutation, 10, &codec).unwrap();
        let mut ga = Ga::with_members(config, vec![genome; 10]);
        let mut rng = SeedStreams::new(seed).stream("ga");
        let mut reached = BTreeSet::new();
        for _ in 0..5 {
            let fitness: Vec<f64> = ga
                .ask()
                .iter()
                .map(|g| {
                    let d = codec.snap(&mut g.clone()).unwrap();
                    f64::from(u8::from(d.sensor_index == s.index)) + 0.1 * rng.random::<f64>()
                })
                .collect();
            ga.tell(&fitness, &mut rng, |g| {
                let _ = codec.snap(g);
            })
            .unwrap();
            for g in ga.ask() {
                reached.insert(codec.snap(&mut g.clone()).unwrap().sensor_index);
            }
        }
        let pitches = reached.iter().map(|&i| joca_camera::catalogue::sensor(i).pixel_pitch_um);
        let (lo, hi) = pitches.fold((f64::MAX, 0.0f64), |(a, b), p| (a.min(p), b.max(p)));
        (reached, lo, hi)
    }

    #[test]
    #[ignore = "prints the reach of both operators over 20 seeds"]
    fn print_reach() {
        for seed in 0..20 {
            let t = offspring_sensors(HardwareMutation::Tacos, seed);
            let p = offspring_sensors(HardwareMutation::Paper, seed);
            println!(
                "seed {seed}: tacos {} sensors, pitch {:.2}-{:.2} um; paper {} sensors, pitch {:.2}-{:.2} um",
                t.0.len(),
                t.1,
                t.2,
                p.0.len(),
                p.1,
                p.2
            );
        }
    }

    /// The default operator's offspring reach at least five sensors and pitches from under
    /// 1.5 µm to over 4 µm; the paper's reach only the converged sensor's near neighbours in
    /// the catalogue (never beyond 2.5 µm from IMX172's 1.55).
    #[test]
    fn the_default_operator_leaves_a_converged_sensor_and_the_papers_does_not() {
        for seed in 0..10 {
            let (tacos, lo, hi) = offspring_sensors(HardwareMutation::Tacos, seed);
            assert!(tacos.len() >= 5 && lo < 1.5 && hi > 4.0, "seed {seed}: {tacos:?} {lo}-{hi}");
            let (paper, _, hi) = offspring_sensors(HardwareMutation::Paper, seed);
            assert!(paper.len() < tacos.len() && hi <= 2.5, "seed {seed}: {paper:?} up to {hi}");
        }
        assert_eq!(HardwareMutation::default(), HardwareMutation::Tacos);
    }
}
