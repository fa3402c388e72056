//! The methods of the paper's comparison and ablations, and its scenarios.

joca_core::named_enum! {
    /// The methods of the paper's comparison and ablations.
    pub enum Method("method") {
        /// Ours: hardware GA + NeuralAE trained with DF-Grad + detector.
        Joca = "joca",
        /// TaCOS: hardware GA + AverageAE + detector.
        TacosAverage = "tacos-average",
        /// A fixed camera at the nuScenes-like mount with NeuralAE trained by the task loss only.
        FixedNeural = "fixed-neural",
        /// Ablation: hardware GA + NeuralAE by the task loss only.
        NoGaLoss = "no-ga-loss",
        /// Ablation: hardware GA + NeuralAE supervised by four fixed perturbations (±2.5 %).
        FixedPerturbation = "fixed-perturbation",
        /// Ablation: ours with the pre-trained detector frozen.
        FrozenDetector = "frozen-detector",
    }
}

impl Method {
    /// Whether NeuralAE sets exposure and gain (all but `tacos-average`, which uses AverageAE).
    pub fn neural(self) -> bool {
        self != Method::TacosAverage
    }

    /// Whether the hardware GA designs the camera (all but `fixed-neural`).
    pub fn hardware_ga(self) -> bool {
        self != Method::FixedNeural
    }

    /// Whether the detector trains in the loop (all but `frozen-detector`).
    pub fn trains_detector(self) -> bool {
        self != Method::FrozenDetector
    }

    /// Whether the perturbation mode runs (the GA's, or the fixed perturbations').
    pub fn perturbations(self) -> bool {
        matches!(self, Method::Joca | Method::FixedPerturbation | Method::FrozenDetector)
    }
}

joca_core::named_enum! {
    /// The scenarios of the paper's Table 1.
    pub enum Scenario("scenario") {
        /// Calibrated noise and motion.
        Calibrated = "calibrated",
        /// Noise variances × 10.
        Noise10 = "noise10",
        /// Noise variances × 20.
        Noise20 = "noise20",
        /// Motion during the shutter × 2.
        Blur2 = "blur2",
        /// Motion during the shutter × 4.
        Blur4 = "blur4",
    }
}

impl Scenario {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_those_of_files_written_before_and_serde_uses_them() {
        // Run directories and grids on disk hold these names: they must not change.
        assert_eq!(
            Method::NAMES,
            [
                "joca",
                "tacos-average",
                "fixed-neural",
                "no-ga-loss",
                "fixed-perturbation",
                "frozen-detector"
            ]
        );
        assert_eq!(Scenario::NAMES, ["calibrated", "noise10", "noise20", "blur2", "blur4"]);
        for m in Method::ALL {
            assert_eq!(serde_json::to_string(m).unwrap(), format!("\"{m}\""));
            assert_eq!(serde_json::from_str::<Method>(&format!("\"{m}\"")).unwrap(), *m);
        }
        let e = Scenario::from_name("fog").unwrap_err();
        assert_eq!(
            e,
            "unknown scenario \"fog\"; valid: calibrated, noise10, noise20, blur2, blur4"
        );
    }
}
