//! The named choices of `joca render`'s flags.

use clap::ValueEnum;
use joca_camera::Resampler;
use joca_sim::Illumination;

/// Illumination schedule of the episode.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Light {
    /// Full daylight.
    Day,
    /// Night: lamps, lit windows, vehicle lights.
    Night,
    /// Abrupt day ↔ tunnel switches every 4 s.
    Tunnel,
    /// Gradual day → night → day over 24 s.
    Cycle,
}

/// How a sensor's grid is resized to the detector input.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ResamplerArg {
    /// Two taps per axis, no anti-aliasing (the paper's detector transform).
    Bilinear,
    /// Overlap-weighted mean (binning).
    Area,
}

impl From<ResamplerArg> for Resampler {
    fn from(r: ResamplerArg) -> Self {
        match r {
            ResamplerArg::Bilinear => Resampler::Bilinear,
            ResamplerArg::Area => Resampler::Area,
        }
    }
}

impl From<Light> for Illumination {
    fn from(l: Light) -> Self {
        match l {
            Light::Day => Illumination::Day,
            Light::Night => Illumination::Night,
            Light::Tunnel => Illumination::Tunnel,
            Light::Cycle => Illumination::Cycle,
        }
    }
}
