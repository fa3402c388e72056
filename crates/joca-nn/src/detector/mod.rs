//! The object detector: single-stage, anchor-free, CenterNet-style (Zhou et al., "Objects as
//! Points"), on a small ResNet-style backbone, trainable from scratch.
//!
//! ```text
//! image [1,3,H,W] (8-bit / 255 − 0.5)
//!  stem    conv3×3 s2, GN, ReLU                          [c,  H/2,  W/2]
//!  layer1  conv3×3 s2, GN, ReLU + BasicBlock              [2c, H/4,  W/4]   ← "conv2" features
//!  layer2  BasicBlock s2 + BasicBlock                     [4c, H/8,  W/8]
//!  layer3  BasicBlock s2 + BasicBlock                     [8c, H/16, W/16]
//!  layer4  (deep only) BasicBlock s2 + BasicBlock         [16c, H/32, W/32]
//!  neck    top-down: 1×1 laterals, nearest upsampling, 3×3 smoothing  [4c, H/4, W/4]
//!  heads   heatmap (one channel per class, sigmoid), log box size, sub-cell centre offset:
//!          each a 3×3 conv + ReLU and a 1×1 conv, or one 3×3 conv for all three (`shared_head`)
//! ```
//!
//! Group normalisation instead of batch normalisation: the paper trains with batch size 1.
//! The stride-4 `layer1` output is what the NeuralAE semantic branch reads (paper supplementary:
//! "the conv2 layer output"). Any input size works; the output grid is `ceil(H/4) × ceil(W/4)`.
//!
//! The network computes in the floating-point type of its input: given a bfloat16 image
//! ([`Precision::Bf16`]) every convolution runs in bfloat16 on bfloat16 copies of its float32
//! weights (mixed precision by hand, what PyTorch's CPU autocast does, which tch does not expose),
//! group normalisation takes bfloat16 activations with float32 scales and accumulates in float32,
//! and the heads' final 1×1 layers and every output are float32. Gradients flow through the
//! copies into the float32 weights, so the optimiser and the saved weights stay float32.

mod bench;
mod decode;
mod loss;
mod model;
mod precision;

pub use bench::{forward_flops, time_detector, time_training, training_step_times};
pub use decode::decode;
pub use loss::{DetectionLoss, Regression, Targets};
pub use model::{
    DetectorModel, FrameLoss, LossParts, MAX_DETECTIONS, MIN_SCORE, TrainFrame, WeightAverage,
};

use joca_core::{Class, Rgb8Image};
use serde::{Deserialize, Serialize};
use tch::nn;
use tch::{Device, Kind, Tensor};

/// Output stride of the heads, pixels.
pub const STRIDE: i64 = 4;

/// Size of the detector.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DetectorConfig {
    /// Channels of the stem; stages have 2×, 4×, 8× this.
    pub width: i64,
    /// Number of classes.
    pub classes: i64,
    /// Add a fourth stage at stride 32 (16× width channels) to the backbone and the neck: a
    /// receptive field for large objects. Off in the shipped weights.
    #[serde(default)]
    pub deep: bool,
    /// One 3×3 hidden convolution for all three heads (each keeps its own 1×1 output layer)
    /// instead of one per head: the heads' hidden layers are ~40 % of the forward FLOPs at
    /// width 16, and sharing them saves two thirds of that. Off in the shipped weights.
    #[serde(default)]
    pub shared_head: bool,
}

impl DetectorConfig {
    /// The architecture a weights file was saved from, read from its tensors' names and shapes
    /// (stem channels, heatmap classes, presence of the stride-32 stage). Loading the file
    /// still checks every tensor.
    pub fn of_weights(path: &std::path::Path) -> Result<Self, crate::NnError> {
        let err =
            |reason: String| crate::NnError::Weights { path: path.display().to_string(), reason };
        let tensors = Tensor::read_safetensors(path)
            .map_err(|e| err(format!("not a readable safetensors file ({e})")))?;
        let dim = |name: &str| {
            tensors.iter().find(|(n, _)| n == name).map(|(_, t)| t.size()[0]).ok_or_else(|| {
                err(format!("no tensor `{name}`: not a weights file of the joca detector"))
            })
        };
        Ok(Self {
            width: dim("backbone.stem.weight")?,
            classes: dim("heads.heatmap.out.bias")?,
            deep: tensors.iter().any(|(n, _)| n.starts_with("backbone.layer4_0.")),
            shared_head: tensors.iter().any(|(n, _)| n.starts_with("heads.shared.")),
        })
    }
}

impl Default for DetectorConfig {
    fn default() -> Self {
        Self { width: 16, classes: Class::ALL.len() as i64, deep: false, shared_head: false }
    }
}

pub use precision::{Precision, PrecisionExt, native_bf16};

/// A convolution without bias, 'same' padding, that runs in its input's floating-point type.
#[derive(Debug)]
struct Conv {
    conv: nn::Conv2D,
    stride: i64,
    padding: i64,
}

impl Conv {
    fn new(vs: &nn::Path<'_>, name: &str, i: i64, o: i64, k: i64, stride: i64) -> Self {
        Self::with(vs, name, i, o, k, nn::ConvConfig { stride, bias: false, ..Default::default() })
    }

    /// A convolution with `cfg`'s stride, initialisers and bias; padding `k / 2`.
    fn with(vs: &nn::Path<'_>, name: &str, i: i64, o: i64, k: i64, cfg: nn::ConvConfig) -> Self {
        let cfg = nn::ConvConfig { padding: k / 2, ..cfg };
        Self { conv: nn::conv2d(vs / name, i, o, k, cfg), stride: cfg.stride, padding: k / 2 }
    }

    fn forward(&self, xs: &Tensor) -> Tensor {
        let kind = xs.kind();
        if kind == Kind::Float {
            return xs.apply(&self.conv);
        }
        let bias = self.conv.bs.as_ref().map(|b| b.to_kind(kind));
        xs.conv2d(&self.conv.ws.to_kind(kind), bias.as_ref(), [self.stride], [self.padding], [1], 1)
    }
}

fn conv(vs: &nn::Path<'_>, name: &str, i: i64, o: i64, k: i64, stride: i64) -> Conv {
    Conv::new(vs, name, i, o, k, stride)
}

fn norm(vs: &nn::Path<'_>, name: &str, channels: i64) -> nn::GroupNorm {
    nn::group_norm(vs / name, (channels / 8).max(1), channels, Default::default())
}

/// Two 3×3 convolutions with a residual connection (ResNet's BasicBlock).
#[derive(Debug)]
struct BasicBlock {
    conv1: Conv,
    norm1: nn::GroupNorm,
    conv2: Conv,
    norm2: nn::GroupNorm,
    shortcut: Option<(Conv, nn::GroupNorm)>,
}

impl BasicBlock {
    fn new(vs: &nn::Path<'_>, i: i64, o: i64, stride: i64) -> Self {
        let shortcut = (stride != 1 || i != o)
            .then(|| (conv(vs, "down", i, o, 1, stride), norm(vs, "down_norm", o)));
        Self {
            conv1: conv(vs, "conv1", i, o, 3, stride),
            norm1: norm(vs, "norm1", o),
            conv2: conv(vs, "conv2", o, o, 3, 1),
            norm2: norm(vs, "norm2", o),
            shortcut,
        }
    }

    fn forward(&self, xs: &Tensor) -> Tensor {
        let y = self.conv1.forward(xs).apply(&self.norm1).relu();
        let y = self.conv2.forward(&y).apply(&self.norm2);
        let skip = match &self.shortcut {
            Some((c, n)) => c.forward(xs).apply(n),
            None => xs.shallow_clone(),
        };
        (y + skip).relu()
    }
}

/// A 3×3 conv + ReLU (unless the heads share one) followed by a 1×1 conv to `out` channels,
/// the latter always in float32.
#[derive(Debug)]
struct Head {
    hidden: Option<Conv>,
    out: nn::Conv2D,
}

impl Head {
    fn new(vs: &nn::Path<'_>, channels: i64, out: i64, bias_init: f64, own_hidden: bool) -> Self {
        // Small output weights, as CenterNet initialises its heads: the first logits are then
        // the bias (heatmap: −2.19, a prior of 0.1), not noise that costs a loss in the thousands.
        let cfg = nn::ConvConfig {
            ws_init: nn::Init::Randn { mean: 0.0, stdev: 1e-3 },
            bs_init: nn::Init::Const(bias_init),
            ..Default::default()
        };
        Self {
            hidden: own_hidden.then(|| hidden(vs, channels)),
            out: nn::conv2d(vs / "out", channels, out, 1, cfg),
        }
    }

    /// `xs`: the neck's features, or the shared hidden layer's float32 output.
    fn forward(&self, xs: &Tensor) -> Tensor {
        match &self.hidden {
            Some(h) => hidden_forward(h, xs).apply(&self.out),
            None => xs.apply(&self.out),
        }
    }
}

/// A 3×3 hidden convolution (with bias).
fn hidden(vs: &nn::Path<'_>, channels: i64) -> Conv {
    Conv::with(vs, "hidden", channels, channels, 3, Default::default())
}

/// The hidden convolution and its ReLU, as float32 for the output layers.
fn hidden_forward(hidden: &Conv, xs: &Tensor) -> Tensor {
    hidden.forward(xs).relu().to_kind(Kind::Float)
}

/// The heatmap, size and offset heads: each with its own hidden layer, or one hidden layer
/// shared by the three output layers ([`DetectorConfig::shared_head`]).
#[derive(Debug)]
struct Heads {
    shared: Option<Conv>,
    heatmap: Head,
    size: Head,
    offset: Head,
}

impl Heads {
    fn new(h: &nn::Path<'_>, channels: i64, classes: i64, shared: bool) -> Self {
        Self {
            shared: shared.then(|| hidden(&(h / "shared"), channels)),
            heatmap: Head::new(&(h / "heatmap"), channels, classes, -2.19, !shared),
            size: Head::new(&(h / "size"), channels, 2, 0.0, !shared),
            offset: Head::new(&(h / "offset"), channels, 2, 0.0, !shared),
        }
    }

    /// Heatmap logits, log sizes and offsets.
    fn forward(&self, xs: &Tensor) -> (Tensor, Tensor, Tensor) {
        let shared = self.shared.as_ref().map(|h| hidden_forward(h, xs));
        let x = shared.as_ref().unwrap_or(xs);
        (self.heatmap.forward(x), self.size.forward(x), self.offset.forward(x))
    }
}

/// What the detector computes for a batch of `n` images.
#[derive(Debug)]
pub struct DetectorOutput {
    /// Class heatmap logits `[n, classes, h, w]` (sigmoid gives the centre probability).
    pub heatmap: Tensor,
    /// `log(box size / STRIDE)` `[n, 2, h, w]` (width, height).
    pub size: Tensor,
    /// Centre offset within the cell `[n, 2, h, w]`, in cells.
    pub offset: Tensor,
    /// The backbone's stride-4 features `[n, 2·width, h, w]` (the NeuralAE's input).
    pub features: Tensor,
}

/// The CenterNet-style detector. Its variables live in the `VarStore` given to [`Detector::new`].
#[derive(Debug)]
pub struct Detector {
    config: DetectorConfig,
    stem: Conv,
    stem_norm: nn::GroupNorm,
    layer1_down: Conv,
    layer1_norm: nn::GroupNorm,
    layer1: BasicBlock,
    layer2: [BasicBlock; 2],
    layer3: [BasicBlock; 2],
    /// Optional stride-32 stage with its lateral and smoothing convolutions.
    layer4: Option<([BasicBlock; 2], Conv, Conv)>,
    lateral3: Conv,
    lateral2: Conv,
    lateral1: Conv,
    smooth2: Conv,
    smooth1: Conv,
    heads: Heads,
}

impl Detector {
    /// A freshly initialised detector under `vs` (heatmap bias −2.19: prior probability 0.1, as
    /// CenterNet initialises it).
    pub fn new(vs: &nn::Path<'_>, config: DetectorConfig) -> Self {
        let c = config.width;
        let b = vs / "backbone";
        let n = vs / "neck";
        let h = vs / "heads";
        Self {
            config,
            stem: conv(&b, "stem", 3, c, 3, 2),
            stem_norm: norm(&b, "stem_norm", c),
            layer1_down: conv(&b, "layer1_down", c, 2 * c, 3, 2),
            layer1_norm: norm(&b, "layer1_norm", 2 * c),
            layer1: BasicBlock::new(&(&b / "layer1"), 2 * c, 2 * c, 1),
            layer2: [
                BasicBlock::new(&(&b / "layer2_0"), 2 * c, 4 * c, 2),
                BasicBlock::new(&(&b / "layer2_1"), 4 * c, 4 * c, 1),
            ],
            layer3: [
                BasicBlock::new(&(&b / "layer3_0"), 4 * c, 8 * c, 2),
                BasicBlock::new(&(&b / "layer3_1"), 8 * c, 8 * c, 1),
            ],
            layer4: config.deep.then(|| {
                (
                    [
                        BasicBlock::new(&(&b / "layer4_0"), 8 * c, 16 * c, 2),
                        BasicBlock::new(&(&b / "layer4_1"), 16 * c, 16 * c, 1),
                    ],
                    conv(&n, "lateral4", 16 * c, 4 * c, 1, 1),
                    conv(&n, "smooth3", 4 * c, 4 * c, 3, 1),
                )
            }),
            lateral3: conv(&n, "lateral3", 8 * c, 4 * c, 1, 1),
            lateral2: conv(&n, "lateral2", 4 * c, 4 * c, 1, 1),
            lateral1: conv(&n, "lateral1", 2 * c, 4 * c, 1, 1),
            smooth2: conv(&n, "smooth2", 4 * c, 4 * c, 3, 1),
            smooth1: conv(&n, "smooth1", 4 * c, 4 * c, 3, 1),
            heads: Heads::new(&h, 4 * c, config.classes, config.shared_head),
        }
    }

    /// The configuration.
    pub fn config(&self) -> DetectorConfig {
        self.config
    }

    /// Runs the network on a `[n, 3, H, W]` image batch, computing in the image's type
    /// (float32 or bfloat16); the outputs are float32.
    pub fn forward(&self, image: &Tensor) -> DetectorOutput {
        let x = self.stem.forward(image).apply(&self.stem_norm).relu(); // [c, H/2, W/2]
        let x = self.layer1_down.forward(&x).apply(&self.layer1_norm).relu();
        let c2 = self.layer1.forward(&x); // [2c, H/4, W/4]
        let c3 = self.layer2[1].forward(&self.layer2[0].forward(&c2)); // [4c, H/8, W/8]
        let c4 = self.layer3[1].forward(&self.layer3[0].forward(&c3)); // [8c, H/16, W/16]
        let up = |t: &Tensor, like: &Tensor| {
            let s = like.size();
            t.upsample_nearest2d([s[2], s[3]], None, None)
        };
        let p4 = match &self.layer4 {
            Some((blocks, lateral4, smooth3)) => {
                let c5 = blocks[1].forward(&blocks[0].forward(&c4)); // [16c, H/32, W/32]
                smooth3
                    .forward(&(up(&lateral4.forward(&c5), &c4) + self.lateral3.forward(&c4)))
                    .relu()
            }
            None => self.lateral3.forward(&c4),
        };
        let p3 = self.smooth2.forward(&(up(&p4, &c3) + self.lateral2.forward(&c3))).relu();
        // [4c, H/4, W/4]
        let p2 = self.smooth1.forward(&(up(&p3, &c2) + self.lateral1.forward(&c2))).relu();
        let (heatmap, size, offset) = self.heads.forward(&p2);
        DetectorOutput { heatmap, size, offset, features: c2.to_kind(Kind::Float) }
    }
}

/// An 8-bit frame as the detector's input tensor `[1, 3, H, W]`, values in [−0.5, 0.5].
pub fn image_tensor(frame: &Rgb8Image, device: Device) -> Tensor {
    batch_tensor(&[frame], device, Precision::Fp32)
}

/// Frames of one size as a batch `[n, 3, H, W]` in `precision`'s type, values in [−0.5, 0.5].
/// Panics if the frames differ in size or there are none.
pub fn batch_tensor(frames: &[&Rgb8Image], device: Device, precision: Precision) -> Tensor {
    let (w, h) = (frames[0].width(), frames[0].height());
    assert!(frames.iter().all(|f| (f.width(), f.height()) == (w, h)), "frames of one size");
    // One pass from interleaved bytes to planar floats: `v / 255 − 0.5` (each value correctly
    // rounded, as the tensor ops `to_kind(Float) / 255 − 0.5` give it: tested) looked up per
    // byte, instead of four tensor passes over the batch.
    let lut: [f32; 256] = std::array::from_fn(|v| v as f32 / 255.0 - 0.5);
    let plane = w * h;
    let mut planar = vec![0.0f32; frames.len() * 3 * plane];
    for (f, out) in frames.iter().zip(planar.chunks_exact_mut(3 * plane)) {
        let (r, gb) = out.split_at_mut(plane);
        let (g, b) = gb.split_at_mut(plane);
        for (((px, r), g), b) in f.data().chunks_exact(3).zip(r).zip(g).zip(b) {
            (*r, *g, *b) = (lut[px[0] as usize], lut[px[1] as usize], lut[px[2] as usize]);
        }
    }
    let x = Tensor::from_slice(&planar).to_device(device).view([
        frames.len() as i64,
        3,
        h as i64,
        w as i64,
    ]);
    if precision == Precision::Fp32 { x } else { x.to_kind(precision.kind()) }
}

#[cfg(test)]
mod tests;
