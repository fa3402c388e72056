//! How a configuration is read and identified: the fields its method reads
//! ([`RunConfig::as_read`]), what identifies its computation ([`RunConfig::identity`], the cell
//! cache's key and the provenance hash), and the weights' path a run directory records.

use super::{
    AccOutput, PerturbationScore, PerturbationSteps, RunConfig, TieBreak, WarmStart,
    paper_detector_lr,
};
use joca_record::Method;
use std::path::PathBuf;

impl RunConfig {
    /// The configuration as its method reads it: where the method searches no perturbations,
    /// the search's score, step and tie-break are set to what an absent field means; where its
    /// controller is AverageAE, NeuralAE's output form and warm start; where the detector is
    /// frozen, its learning rate. Two cells
    /// whose `as_read` are equal run the same way, so a preset's change of the search does not
    /// orphan a finished AverageAE cell.
    pub fn as_read(&self) -> RunConfig {
        let mut c = self.clone();
        if !c.method.neural() {
            // AverageAE has no NeuralAE to warm or to shape.
            c.warm_start = WarmStart::default();
            c.acc_output = AccOutput::default();
        }
        if c.method == Method::FrozenDetector {
            c.detector_lr = paper_detector_lr();
        }
        if !c.method.perturbations() {
            c.perturbation_score = PerturbationScore::default();
            c.perturbation_window = 1;
            c.perturbation_steps = PerturbationSteps::default();
            c.perturbation_tie_break = TieBreak::default();
        }
        c
    }

    /// What identifies the computation a run makes: [`as_read`](Self::as_read), with the
    /// detector's weights named by their content (`sha256:<hex>`) instead of their path, so the
    /// same cell started from another folder has the same identity and a changed weights file
    /// another. Its SHA-256 is `results.json`'s `provenance.config_sha256`, the cell cache's key.
    pub fn identity(&self) -> RunConfig {
        let mut c = self.as_read();
        if let Some(w) = &c.detector_weights {
            let named = match crate::checkpoint::sha256_of(w) {
                Ok(hex) => format!("sha256:{hex}"),
                Err(_) => format!("unreadable:{}", w.display()),
            };
            c.detector_weights = Some(PathBuf::from(named));
        }
        c
    }

    /// The configuration with the detector weights' path made absolute (where the file exists),
    /// so that the run directory's `config.toml` and checkpoint name the file wherever `joca
    /// eval` or `--resume` is started from.
    pub fn with_absolute_weights(mut self) -> RunConfig {
        if let Some(w) = &self.detector_weights
            && let Ok(abs) = w.canonicalize()
        {
            self.detector_weights = Some(abs);
        }
        self
    }
}
