//! The methods of the paper's comparison and ablations, and its scenarios.

use serde::{Deserialize, Serialize};

/// The methods of the paper's comparison and ablations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Ours: hardware GA + NeuralAE trained with DF-Grad + detector.
    Joca,
    /// TaCOS: hardware GA + AverageAE + detector.
    TacosAverage,
    /// A fixed camera at the nuScenes-like mount with NeuralAE trained by the task loss only.
    FixedNeural,
    /// Ablation: hardware GA + NeuralAE by the task loss only.
    NoGaLoss,
    /// Ablation: hardware GA + NeuralAE supervised by four fixed perturbations (±2.5 %).
    FixedPerturbation,
    /// Ablation: ours with the pre-trained detector frozen.
    FrozenDetector,
}

impl Method {
    /// Every method.
    pub const ALL: [Method; 6] = [
        Method::Joca,
        Method::TacosAverage,
        Method::FixedNeural,
        Method::NoGaLoss,
        Method::FixedPerturbation,
        Method::FrozenDetector,
    ];

    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::Joca => "joca",
            Method::TacosAverage => "tacos-average",
            Method::FixedNeural => "fixed-neural",
            Method::NoGaLoss => "no-ga-loss",
            Method::FixedPerturbation => "fixed-perturbation",
            Method::FrozenDetector => "frozen-detector",
        }
    }

    /// Parses a name, listing the valid ones on failure.
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|m| m.name() == name).ok_or_else(|| {
            format!("unknown method {name:?}; valid: {}", Self::ALL.map(Method::name).join(", "))
        })
    }

    /// Whether NeuralAE sets exposure and gain (all but `tacos-average`, which uses AverageAE).
    pub fn neural(self) -> bool {
        self != Method::TacosAverage
    }

    /// Whether the hardware GA designs the camera (all but `fixed-neural`).
    pub fn hardware_ga(self) -> bool {
        self != Method::FixedNeural
    }

    /// Whether the perturbation mode runs (the GA's, or the fixed perturbations').
    pub fn perturbations(self) -> bool {
        matches!(self, Method::Joca | Method::FixedPerturbation | Method::FrozenDetector)
    }
}

/// The scenarios of the paper's Table 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Scenario {
    /// Calibrated noise and motion.
    Calibrated,
    /// Noise variances × 10.
    Noise10,
    /// Noise variances × 20.
    Noise20,
    /// Motion during the shutter × 2.
    Blur2,
    /// Motion during the shutter × 4.
    Blur4,
}

impl Scenario {
    /// Every scenario.
    pub const ALL: [Scenario; 5] = [
        Scenario::Calibrated,
        Scenario::Noise10,
        Scenario::Noise20,
        Scenario::Blur2,
        Scenario::Blur4,
    ];

    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Scenario::Calibrated => "calibrated",
            Scenario::Noise10 => "noise10",
            Scenario::Noise20 => "noise20",
            Scenario::Blur2 => "blur2",
            Scenario::Blur4 => "blur4",
        }
    }

    /// Parses a name, listing the valid ones on failure.
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|s| s.name() == name).ok_or_else(|| {
            format!(
                "unknown scenario {name:?}; valid: {}",
                Self::ALL.map(Scenario::name).join(", ")
            )
        })
    }

    /// Multiplier of σp² and σr².
    pub fn noise_scale(self) -> f64 {
        match self {
            Scenario::Noise10 => 10.0,
            Scenario::Noise20 => 20.0,
            _ => 1.0,
        }
    }

    /// Multiplier of the motion during the shutter.
    pub fn motion_scale(self) -> f64 {
        match self {
            Scenario::Blur2 => 2.0,
            Scenario::Blur4 => 4.0,
            _ => 1.0,
        }
    }
}
