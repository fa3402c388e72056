//! NeuralAE, the adaptive camera control network of the paper (supplementary, after Onzon et al.
//! 2021), predicting exposure time and gain for the next frame.
//!
//! ```text
//! global branch   multi-scale luminance histograms of the 8-bit frame: 1×1 + 3×3 + 7×7 tiles
//!                 = 59 tiles × 256 bins, each normalised to sum 1        [1, 59, 256]
//!                 3 × (Conv1d k=4 s=4, ReLU): 59→64→64→32 channels          [1, 32, 4]
//!                 flatten 128 → Linear 256, ReLU → Linear 256               g [1, 256]
//! semantic branch detector stride-4 features (detached)                    [1, 2c, h, w]
//!                 compression conv 1×1 → 3·k channels, ReLU, split in three CFMs of k:
//!                 avg-pool CFM1, max-pool CFM2, max-pool CFM3, avg-pool the whole map
//!                 → 3k + 3k, concatenated with a 32-d embedding of the previous (E, G)
//!                 (Linear 2→32, ReLU, Linear 32→32)
//!                 → Linear 256, ReLU → Linear 256                           s [1, 256]
//! head            g + s → Linear 2 → sigmoid → (log E, G dB) within the ACC ranges
//! ```
//!
//! With a moving iris (`[run] aperture = "dynamic"`, beyond the paper: its future work) the head
//! has a third output, the iris's unit position `u = σ(o₃)` (`joca_camera::Iris`: fully open at
//! 0, stopped down at 1, even stops between), and the previous-settings embedding reads `u` too
//! (Linear 3→32).
//!
//! Sizes: the paper keeps NeuralAE's original layer widths with a ResNet-50 detector (a 784-d
//! semantic vector, 816 with the previous-settings embedding). Our detector's stride-4 map has
//! `2·width` = 32 channels, so the compression keeps k = 16 per CFM (6k = 96-d pooled vector,
//! 128 with the embedding); the branches meet in 256 dimensions as in the original.
//!
//! Outputs are bounded as the paper requires: exposure
//! `exp(log Emin + σ(o₁)·(log Emax − log Emin))` (a sigmoid in log space), gain
//! `Gmin + σ(o₂)·(Gmax − Gmin)` dB (already logarithmic).

use joca_camera::AccRanges;
use joca_core::Rgb8Image;
use tch::nn;
use tch::{Device, Kind, Tensor};

/// Histogram tiles per side at each scale.
const SCALES: [usize; 3] = [1, 3, 7];
/// Tiles over all scales (1 + 9 + 49).
pub const HISTOGRAM_TILES: i64 = 59;
/// Bins per histogram.
pub const BINS: i64 = 256;

/// The ACC ranges ([`AccRanges`]) in the units the network sees: `ln(seconds)` and dB.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AccBounds {
    /// `ln` of the shortest and longest exposure, seconds.
    pub log_exposure: (f64, f64),
    /// Gain range, dB.
    pub gain_db: (f64, f64),
    /// Whether NeuralAE also sets the iris (a third output, its unit position).
    pub iris: bool,
    /// How exposure and gain are output ([`AccOutputForm`]).
    pub form: AccOutputForm,
}

/// How NeuralAE's head gives exposure and gain.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum AccOutputForm {
    /// The paper's: absolute settings, a sigmoid over each range (log exposure, gain in dB).
    #[default]
    Absolute,
    /// A step from the previous frame's settings (the form AverageAE's factor has): exposure
    /// and linear gain each × 2^(s·tanh(o)), at most `s` stops a frame, then held inside the
    /// ranges (the value clamped, the gradient passed as if it were not, so a step past a bound
    /// is still pulled back). An untrained NeuralAE holds its settings.
    Relative {
        /// The largest step of each of exposure and gain, stops.
        max_stops: f64,
    },
}

impl AccBounds {
    /// The network's view of `ranges`.
    pub fn new(ranges: AccRanges) -> Self {
        let (e, g) = (ranges.exposure_s, ranges.gain_db);
        Self {
            log_exposure: (e.min.ln(), e.max.ln()),
            gain_db: (g.min, g.max),
            iris: false,
            form: AccOutputForm::Absolute,
        }
    }

    /// The same, with exposure and gain output in `form`.
    pub fn with_form(self, form: AccOutputForm) -> Self {
        Self { form, ..self }
    }

    /// The same, with NeuralAE setting the iris too.
    pub fn with_iris(self) -> Self {
        Self { iris: true, ..self }
    }

    /// The previous frame's settings as the network reads them: [`Self::unit`], then the iris's
    /// unit position where NeuralAE sets it ([`joca_camera::Iris::START_UNIT`] where none was
    /// set).
    pub fn previous(&self, exposure_s: f64, gain_db: f64, iris: Option<f64>) -> Vec<f32> {
        let mut v = self.unit(exposure_s, gain_db).to_vec();
        if self.iris {
            v.push(iris.unwrap_or(joca_camera::Iris::START_UNIT) as f32);
        }
        v
    }

    /// Settings NeuralAE reads and sets: exposure and gain, and the iris if it sets it.
    fn outputs(&self) -> i64 {
        if self.iris { 3 } else { 2 }
    }

    /// `(E, G)` as the `[0, 1]²` values the network is conditioned on.
    pub fn unit(&self, exposure_s: f64, gain_db: f64) -> [f32; 2] {
        let (a, b) = self.log_exposure;
        let (c, d) = self.gain_db;
        [((exposure_s.ln() - a) / (b - a)) as f32, ((gain_db - c) / (d - c)) as f32]
    }
}

/// Multi-scale luminance histograms of an 8-bit frame, `[59 · 256]`, each tile's histogram
/// normalised to sum 1 (luminance = mean of R, G, B, rounded down).
pub fn histograms(frame: &Rgb8Image) -> Vec<f32> {
    let (w, h) = (frame.width(), frame.height());
    let mut out = vec![0.0f32; (HISTOGRAM_TILES * BINS) as usize];
    let mut offset = 0;
    for &n in &SCALES {
        let mut counts = vec![0u32; n * n * BINS as usize];
        for y in 0..h {
            let ty = (y * n / h.max(1)).min(n - 1);
            for x in 0..w {
                let tx = (x * n / w.max(1)).min(n - 1);
                let p = frame.pixel(x, y);
                let luma = (u32::from(p[0]) + u32::from(p[1]) + u32::from(p[2])) / 3;
                counts[(ty * n + tx) * BINS as usize + luma as usize] += 1;
            }
        }
        for tile in counts.chunks(BINS as usize) {
            let total: u32 = tile.iter().sum();
            for (k, &c) in tile.iter().enumerate() {
                out[offset + k] = if total > 0 { c as f32 / total as f32 } else { 0.0 };
            }
            offset += BINS as usize;
        }
    }
    out
}

/// `x` clamped to `[lo, hi]` in value, with the gradient of `x` itself.
fn held(x: Tensor, lo: f64, hi: f64) -> Tensor {
    let clamped = x.clamp(lo, hi).detach();
    &x + (clamped - x.detach())
}

/// The NeuralAE network.
#[derive(Debug)]
pub struct NeuralAe {
    hist: [nn::Conv1D; 3],
    global: [nn::Linear; 2],
    compress: nn::Conv2D,
    cfm: i64,
    prev: [nn::Linear; 2],
    semantic: [nn::Linear; 2],
    out: nn::Linear,
    bounds: AccBounds,
}

/// What NeuralAE predicts for the next frame.
#[derive(Debug)]
pub struct AccOutput {
    /// Exposure, seconds `[1]` (differentiable).
    pub exposure_s: Tensor,
    /// Gain, dB `[1]` (differentiable).
    pub gain_db: Tensor,
    /// The iris's unit position `[1]` (differentiable), where NeuralAE sets it.
    pub iris: Option<Tensor>,
}

/// The output layer, initialised so that an untrained NeuralAE predicts the calibration settings
/// (E0 = 5 ms, G0 = 10 dB, and the iris at [`joca_camera::Iris::START_UNIT`]; with a relative
/// output, a zero step): small
/// weights, and biases at the logits of those settings. A random start would put the first
/// predictions anywhere in the ranges, often at an extreme where the task gradient is weak.
fn start_at_calibration(vs: &nn::Path<'_>, bounds: AccBounds) -> nn::Linear {
    let logit = |u: f64| (u / (1.0 - u)).ln();
    let unit: Vec<f32> = bounds
        .previous(5e-3, 10.0, Some(joca_camera::Iris::START_UNIT))
        .into_iter()
        .map(|u| logit(f64::from(u).clamp(0.01, 0.99)) as f32)
        .collect();
    let mut layer = nn::linear(
        vs / "out",
        256,
        bounds.outputs(),
        nn::LinearConfig {
            ws_init: nn::Init::Randn { mean: 0.0, stdev: 1e-3 },
            ..Default::default()
        },
    );
    if let Some(bias) = layer.bs.as_mut() {
        let _guard = tch::no_grad_guard();
        bias.copy_(&Tensor::from_slice(&unit));
        if let AccOutputForm::Relative { .. } = bounds.form {
            // A zero step: the settings are held.
            let _ = bias.narrow(0, 0, 2).fill_(0.0);
        }
    }
    layer
}

impl NeuralAe {
    /// A freshly initialised NeuralAE reading detector features with `feature_channels`.
    pub fn new(vs: &nn::Path<'_>, feature_channels: i64, bounds: AccBounds) -> Self {
        let conv1 = |name: &str, i: i64, o: i64| {
            nn::conv1d(vs / name, i, o, 4, nn::ConvConfig { stride: 4, ..Default::default() })
        };
        let cfm = (feature_channels / 2).max(4);
        Self {
            hist: [
                conv1("hist1", HISTOGRAM_TILES, 64),
                conv1("hist2", 64, 64),
                conv1("hist3", 64, 32),
            ],
            global: [
                nn::linear(vs / "global1", 32 * 4, 256, Default::default()),
                nn::linear(vs / "global2", 256, 256, Default::default()),
            ],
            compress: nn::conv2d(vs / "compress", feature_channels, 3 * cfm, 1, Default::default()),
            cfm,
            prev: [
                nn::linear(vs / "prev1", bounds.outputs(), 32, Default::default()),
                nn::linear(vs / "prev2", 32, 32, Default::default()),
            ],
            semantic: [
                nn::linear(vs / "semantic1", 6 * cfm + 32, 256, Default::default()),
                nn::linear(vs / "semantic2", 256, 256, Default::default()),
            ],
            out: start_at_calibration(vs, bounds),
            bounds,
        }
    }

    /// Switches the head to `form`, its exposure and gain biases at the start `form` has (the
    /// calibration settings, or a zero step). Meant for a fresh network: trained weights of one
    /// form do not mean the same in the other.
    pub fn set_form(&mut self, form: AccOutputForm) {
        self.bounds = self.bounds.with_form(form);
        let logit = |u: f64| (u / (1.0 - u)).ln() as f32;
        let start: [f32; 2] = match form {
            AccOutputForm::Absolute => {
                let u = self.bounds.unit(5e-3, 10.0);
                [logit(f64::from(u[0])), logit(f64::from(u[1]))]
            }
            AccOutputForm::Relative { .. } => [0.0, 0.0],
        };
        if let Some(bias) = self.out.bs.as_mut() {
            let _guard = tch::no_grad_guard();
            bias.narrow(0, 0, 2).copy_(&Tensor::from_slice(&start));
        }
    }

    /// Predicts the next frame's settings from the last frame's histograms (`[59·256]`), the
    /// detector's stride-4 features of that frame (detached here) and the last settings
    /// ([`AccBounds::previous`]).
    pub fn forward(
        &self,
        histograms: &[f32],
        features: &Tensor,
        previous: &[f32],
        device: Device,
    ) -> AccOutput {
        let h = Tensor::from_slice(histograms).to_device(device).view([1, HISTOGRAM_TILES, BINS]);
        let h = self.hist.iter().fold(h, |x, c| x.apply(c).relu()); // [1, 32, 4]
        let g = h.flatten(1, 2).apply(&self.global[0]).relu().apply(&self.global[1]); // [1, 256]

        let f = features.detach().apply(&self.compress).relu(); // [1, 3k, h, w]
        let parts = f.split(self.cfm, 1);
        let avg = |t: &Tensor| t.mean_dim(&[2i64, 3][..], false, Kind::Float);
        let max = |t: &Tensor| t.amax(&[2i64, 3][..], false);
        let prev = Tensor::from_slice(previous).to_device(device).view([1, self.bounds.outputs()]);
        let e = prev.apply(&self.prev[0]).relu().apply(&self.prev[1]); // [1, 32]
        // [1, 6k + 32]
        let pooled = Tensor::cat(&[avg(&parts[0]), max(&parts[1]), max(&parts[2]), avg(&f), e], 1);
        let s = pooled.apply(&self.semantic[0]).relu().apply(&self.semantic[1]); // [1, 256]

        let raw = (g + s).apply(&self.out); // [1, 2] (or [1, 3] with the iris)
        let o = raw.sigmoid();
        let (a, b) = self.bounds.log_exposure;
        let (c, d) = self.bounds.gain_db;
        let iris = self.bounds.iris.then(|| o.select(1, 2));
        match self.bounds.form {
            AccOutputForm::Absolute => AccOutput {
                exposure_s: (o.select(1, 0) * (b - a) + a).exp(),
                gain_db: o.select(1, 1) * (d - c) + c,
                iris,
            },
            AccOutputForm::Relative { max_stops } => {
                let step = raw.narrow(1, 0, 2).tanh() * max_stops; // stops, [1, 2]
                let (log_e, g_db) =
                    (a + f64::from(previous[0]) * (b - a), c + f64::from(previous[1]) * (d - c));
                let log_e = held(step.select(1, 0) * std::f64::consts::LN_2 + log_e, a, b);
                let g_db = held(step.select(1, 1) * joca_core::units::DB_PER_STOP + g_db, c, d);
                AccOutput { exposure_s: log_e.exp(), gain_db: g_db, iris }
            }
        }
    }
}

#[cfg(test)]
mod tests;
