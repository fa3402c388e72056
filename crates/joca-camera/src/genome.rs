//! Genome codec: the hardware GA sees a design as a vector of real genes.
//!
//! The sensor is categorical but its properties are ordered, so, following the paper (Sec. 5,
//! after Côté et al. and TaCOS), the default [`SensorEncoding::QuantisedContinuous`] gives the
//! GA three continuous genes (sensor width mm, height mm, pixel pitch µm) and, after every
//! variation, snaps them to the nearest catalogue row by raw Euclidean distance — no
//! normalisation, as in the paper — and writes the snapped values back into the genome, so
//! parents always carry real sensors. [`SensorEncoding::DiscreteIndex`] is the plain
//! alternative: one gene holding the row's position in the allowed list, rounded.
//!
//! Gene order: `[x_m, z_m, focal_length_mm, width_mm, height_mm, pixel_pitch_um]` or
//! `[x_m, z_m, focal_length_mm, sensor_position]`, then `f_number` where the space lets the
//! aperture vary (a space with the aperture fixed has no such gene, so its genomes and their
//! search are those of the paper).

use crate::CameraError;
use crate::catalogue::sensor;
use crate::design::{CameraDesign, DesignSpace};
use crate::settings::Bounds;
use serde::{Deserialize, Serialize};

/// How the sensor is encoded in the genome.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SensorEncoding {
    /// Width, height, pitch as continuous genes snapped to the nearest row (the paper's).
    #[default]
    QuantisedContinuous,
    /// One gene: the position in the allowed sensor list, rounded.
    DiscreteIndex,
}

/// One gene's name and bounds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeneSpec {
    /// Name with unit, e.g. `focal_length_mm`.
    pub name: &'static str,
    /// Allowed interval.
    pub bounds: Bounds,
}

/// Maps designs of a [`DesignSpace`] to gene vectors and back.
#[derive(Debug, Clone, PartialEq)]
pub struct GenomeCodec {
    space: DesignSpace,
    encoding: SensorEncoding,
}

impl GenomeCodec {
    /// A codec for `space` with the given sensor encoding.
    pub fn new(space: DesignSpace, encoding: SensorEncoding) -> Result<Self, CameraError> {
        if space.sensors.is_empty() {
            return Err(CameraError::NoSensor { constraint: "the design space".to_owned() });
        }
        Ok(Self { space, encoding })
    }

    /// The design space.
    pub fn space(&self) -> &DesignSpace {
        &self.space
    }

    /// Names and bounds of the genes, in genome order.
    pub fn genes(&self) -> Vec<GeneSpec> {
        let mut genes = vec![
            GeneSpec { name: "x_m", bounds: self.space.x_m },
            GeneSpec { name: "z_m", bounds: self.space.z_m },
            GeneSpec { name: "focal_length_mm", bounds: self.space.focal_length_mm },
        ];
        match self.encoding {
            SensorEncoding::QuantisedContinuous => {
                let range = |key: fn(usize) -> f64| {
                    let values = self.space.sensors.iter().map(|&i| key(i));
                    let min = values.clone().fold(f64::INFINITY, f64::min);
                    let max = values.fold(f64::NEG_INFINITY, f64::max);
                    Bounds::new(min, max)
                };
                genes.push(GeneSpec { name: "width_mm", bounds: range(|i| sensor(i).width_mm) });
                genes.push(GeneSpec { name: "height_mm", bounds: range(|i| sensor(i).height_mm) });
                genes.push(GeneSpec {
                    name: "pixel_pitch_um",
                    bounds: range(|i| sensor(i).pixel_pitch_um),
                });
            }
            SensorEncoding::DiscreteIndex => genes.push(GeneSpec {
                name: "sensor_position",
                bounds: Bounds::new(0.0, (self.space.sensors.len() - 1) as f64),
            }),
        }
        if !self.space.f_number.is_fixed() {
            genes.push(GeneSpec { name: "f_number", bounds: self.space.f_number });
        }
        genes
    }

    /// The nearest allowed sensor to `(width_mm, height_mm, pixel_pitch_um)` by raw Euclidean
    /// distance; ties go to the earlier catalogue row.
    pub fn nearest_sensor(&self, width_mm: f64, height_mm: f64, pixel_pitch_um: f64) -> usize {
        let dist2 = |i: usize| {
            let s = sensor(i);
            (s.width_mm - width_mm).powi(2)
                + (s.height_mm - height_mm).powi(2)
                + (s.pixel_pitch_um - pixel_pitch_um).powi(2)
        };
        // `min_by` keeps the first of equal elements, and `sensors` is ascending.
        self.space
            .sensors
            .iter()
            .copied()
            .min_by(|&a, &b| dist2(a).total_cmp(&dist2(b)))
            .unwrap_or(self.space.sensors[0])
    }

    /// Snaps the sensor genes of `genes` to a catalogue row in place (the GA's post-variation
    /// hook) and clamps every gene into its bounds; returns the design it now encodes.
    pub fn snap(&self, genes: &mut [f64]) -> Result<CameraDesign, CameraError> {
        let specs = self.genes();
        if genes.len() != specs.len() {
            return Err(CameraError::GenomeLength { expected: specs.len(), got: genes.len() });
        }
        for (g, spec) in genes.iter_mut().zip(&specs) {
            if !g.is_finite() {
                return Err(CameraError::NotFinite { field: spec.name.to_owned(), value: *g });
            }
            *g = spec.bounds.clamp(*g);
        }
        let sensor_index = match self.encoding {
            SensorEncoding::QuantisedContinuous => {
                let i = self.nearest_sensor(genes[3], genes[4], genes[5]);
                let s = sensor(i);
                genes[3] = s.width_mm;
                genes[4] = s.height_mm;
                genes[5] = s.pixel_pitch_um;
                i
            }
            SensorEncoding::DiscreteIndex => {
                let position = genes[3].round();
                genes[3] = position;
                self.space.sensors[position as usize]
            }
        };
        let f_number = if self.space.f_number.is_fixed() {
            self.space.f_number.min
        } else {
            genes[specs.len() - 1]
        };
        Ok(CameraDesign {
            x_m: genes[0],
            z_m: genes[1],
            focal_length_mm: genes[2],
            sensor_index,
            f_number,
        })
    }

    /// The design encoded by `genes` (which are not modified).
    pub fn decode(&self, genes: &[f64]) -> Result<CameraDesign, CameraError> {
        let mut copy = genes.to_vec();
        self.snap(&mut copy)
    }

    /// The genes of `design`.
    pub fn encode(&self, design: &CameraDesign) -> Result<Vec<f64>, CameraError> {
        self.space.check(design)?;
        let mut genes = vec![design.x_m, design.z_m, design.focal_length_mm];
        let s = design.sensor();
        match self.encoding {
            SensorEncoding::QuantisedContinuous => {
                genes.extend([s.width_mm, s.height_mm, s.pixel_pitch_um]);
            }
            SensorEncoding::DiscreteIndex => {
                let position = self.space.sensors.iter().position(|&i| i == s.index).unwrap_or(0);
                genes.push(position as f64);
            }
        }
        if !self.space.f_number.is_fixed() {
            genes.push(design.f_number);
        }
        Ok(genes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn codec(encoding: SensorEncoding) -> GenomeCodec {
        GenomeCodec::new(DesignSpace::synthetic(), encoding).unwrap()
    }

    #[test]
    fn snapping_examples_from_the_paper_tables() {
        // Sensor sizes and pitches as printed in the paper's Table 1 map to these rows.
        let c = codec(SensorEncoding::QuantisedContinuous);
        for ((w, h, p), name) in [
            ((6.2, 4.65, 1.55), "IMX172"),
            ((7.37, 4.92, 2.4), "IMX178"),
            ((11.34, 7.13, 5.86), "IMX174"),
        ] {
            assert_eq!(sensor(c.nearest_sensor(w, h, p)).name, name);
            let mut genes = vec![1.0, 1.5, 5.0, w, h, p];
            let d = c.snap(&mut genes).unwrap();
            assert_eq!(d.sensor().name, name);
            let s = sensor(d.sensor_index);
            assert_eq!(&genes[3..], &[s.width_mm, s.height_mm, s.pixel_pitch_um]);
        }
    }

    #[test]
    fn snap_clamps_and_round_trips() {
        let c = codec(SensorEncoding::QuantisedContinuous);
        let mut genes = vec![-1.0, 9.0, 0.5, 100.0, 100.0, 100.0];
        let d = c.snap(&mut genes).unwrap();
        assert_eq!((d.x_m, d.z_m, d.focal_length_mm), (0.0, 1.7, 1.0));
        assert_eq!(c.encode(&d).unwrap(), genes);
        assert!(c.snap(&mut [1.0, 2.0]).is_err());
        assert!(c.snap(&mut [f64::NAN, 1.5, 3.0, 5.0, 4.0, 2.0]).is_err());
    }

    #[test]
    fn discrete_index_encoding() {
        let space = DesignSpace::synthetic().restricted_to_recording(1920, 1280).unwrap();
        let c = GenomeCodec::new(space.clone(), SensorEncoding::DiscreteIndex).unwrap();
        assert_eq!(c.genes().len(), 4);
        let d = c.decode(&[1.0, 1.5, 4.0, 2.6]).unwrap();
        assert_eq!(d.sensor_index, space.sensors[3]);
        assert_eq!(c.encode(&d).unwrap(), vec![1.0, 1.5, 4.0, 3.0]);
    }

    #[test]
    fn the_aperture_is_a_gene_only_where_it_may_vary() {
        // Fixed at f/16 (the paper's space): six genes, designs at f/16.
        let fixed = codec(SensorEncoding::QuantisedContinuous);
        assert_eq!(fixed.genes().len(), 6);
        assert_eq!(fixed.decode(&[1.0, 1.5, 5.0, 6.2, 4.65, 1.55]).unwrap().f_number, 16.0);
        // f/1.4–f/16: a seventh gene, clamped into its range, round-tripped.
        let space = DesignSpace::synthetic().with_f_numbers(1.4, 16.0).unwrap();
        let c = GenomeCodec::new(space, SensorEncoding::QuantisedContinuous).unwrap();
        assert_eq!(c.genes()[6].name, "f_number");
        let mut genes = vec![1.0, 1.5, 5.0, 6.2, 4.65, 1.55, 0.9];
        let d = c.snap(&mut genes).unwrap();
        assert_eq!(d.f_number, 1.4);
        assert_eq!(c.encode(&d).unwrap(), genes);
        assert!(DesignSpace::synthetic().with_f_numbers(0.5, 16.0).is_err());
        assert!(DesignSpace::synthetic().with_f_numbers(8.0, 4.0).is_err());
    }
}
