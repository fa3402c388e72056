//! Differentiable image formation: the same Eq. 2–3 as `joca_camera::ImageFormation`, on
//! tensors, so the task loss reaches the ACC through exposure and gain.
//!
//! The rendered `I0` (with the motion blur of the exposure it was rendered with) enters as a
//! constant: its dependence on exposure through blur is not differentiable — the gap DF-Grad's
//! GA supervision fills. For a given noise field `z` (taken from
//! `joca_camera::ImageFormation::input_normals`, i.e. the very sample the 8-bit formation
//! uses) the forward value equals the 8-bit frame. Clipping at 0 and 255 keeps the clamp's own
//! gradient (1 inside, 0 outside, so a saturated pixel passes no gradient to exposure and gain);
//! rounding to the nearest integer is straight-through (it passes the gradient unchanged).

use joca_camera::ImageFormation;
use tch::{Device, Kind, Tensor};

/// One frame's constant inputs.
#[derive(Debug, Clone, Copy)]
pub struct Scene<'a> {
    /// Interleaved RGB `I0`, `[H·W·3]`, calibrated DN.
    pub i0: &'a [f32],
    /// The noise sample `z`, same layout: `ImageFormation::input_normals` of the formation
    /// that forms the frame (the native grid's resize gain included).
    pub normals: &'a [f32],
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// The sensor's pixel pitch, µm.
    pub pixel_pitch_um: f64,
    /// The lens's light relative to the calibration aperture, (N0/N)² (1 at f/16), at the
    /// frame's f-number.
    pub light_factor: f64,
    /// The iris the frame's f-number was set in, where NeuralAE sets it (so the joint step can
    /// differentiate the light by the iris's position); `None` otherwise.
    pub iris: Option<joca_camera::Iris>,
}

/// `[1, 3, H, W]` frame in DN (0–255, integer-valued in the forward pass) of `scene` under
/// `formation`'s calibration and noise scale (the very formation the 8-bit path uses; the
/// native grid's noise gain arrives in `scene.normals`), differentiable in `exposure_s` and
/// `gain_db` (`[1]` tensors).
pub fn form(
    scene: &Scene<'_>,
    exposure_s: &Tensor,
    gain_db: &Tensor,
    formation: &ImageFormation,
    clip: ClipGradient,
    device: Device,
) -> Tensor {
    let (i0, normals, pixel_pitch_um) = (scene.i0, scene.normals, scene.pixel_pitch_um);
    let (w, h) = (scene.width as i64, scene.height as i64);
    let to_chw = |v: &[f32]| {
        // Contiguous NCHW: a permuted view would make convolutions keep a channels-last
        // layout that later `view`s cannot reinterpret.
        Tensor::from_slice(v)
            .to_device(device)
            .view([h, w, 3])
            .permute([2, 0, 1])
            .contiguous()
            .unsqueeze(0)
    };
    let i0 = to_chw(i0);
    let z = to_chw(normals);
    let c = formation.calibration();
    let n = formation.noise_scale();
    let g0 = 10f64.powf(c.gain_db / 20.0);
    let gain_ratio = (gain_db / 20.0 * std::f64::consts::LN_10).exp() / g0; // 10^(dB/20) / G0
    let area = (pixel_pitch_um / c.pixel_pitch_um).powi(2) * scene.light_factor;
    let scale = exposure_s / c.exposure_s * &gain_ratio * area; // [1]
    let i = i0 * scale.view([1, 1, 1, 1]);
    let sp = Tensor::from_slice(&c.sigma_p2.map(|v| (v * n) as f32))
        .to_device(device)
        .view([1, 3, 1, 1]);
    let sr = Tensor::from_slice(&c.sigma_r2.map(|v| (v * n) as f32))
        .to_device(device)
        .view([1, 3, 1, 1]);
    let g = gain_ratio.view([1, 1, 1, 1]);
    let var = (&g * sp * &i + &g * &g * sr).clamp_min(0.0);
    let noisy = &i + var.sqrt() * z;
    let clipped = match clip {
        ClipGradient::Clamp => noisy.clamp(0.0, 255.0),
        ClipGradient::StraightThrough => &noisy + (noisy.clamp(0.0, 255.0) - &noisy).detach(),
        ClipGradient::Smooth => {
            // Forward: the clamp. Backward: the soft clip x − τ·softplus((x − 255)/τ) +
            // τ·softplus(−x/τ), whose slope σ((255 − x)/τ) − σ(−x/τ) is ½ at either edge.
            let tau = SMOOTH_CLIP_DN;
            let soft = &noisy - ((&noisy - 255.0) / tau).softplus() * tau
                + (-&noisy / tau).softplus() * tau;
            noisy.clamp(0.0, 255.0).detach() + (&soft - soft.detach())
        }
    };
    // floor(x + 0.5) as the 8-bit formation rounds, with the gradient of the identity.
    let rounded = (&clipped + 0.5).floor();
    &clipped + (rounded - &clipped).detach()
}

/// The gradient of clipping at 0 and 255 in the differentiable formation.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ClipGradient {
    /// The clamp's own: 1 inside, 0 where a pixel saturates — a saturated pixel passes no
    /// gradient, so the task loss cannot ask a white frame for less light.
    #[default]
    Clamp,
    /// The identity's (straight-through): saturated pixels pass their gradient as if unclipped,
    /// so the loss can ask for less light where the frame is white.
    StraightThrough,
    /// A soft clip's ([`SMOOTH_CLIP_DN`] wide): a pixel passes a share of its gradient that
    /// falls smoothly from 1 inside the range to ½ at 0 and 255 and to e⁻¹ ≈ 0.27 one width
    /// beyond; the frame itself is still clipped hard.
    Smooth,
}

/// The width τ of the smooth clip's knee, DN.
pub const SMOOTH_CLIP_DN: f64 = 16.0;

/// The frame as the detector's input scaling (`DN / 255 − 0.5`).
pub fn to_detector_input(frame_dn: &Tensor) -> Tensor {
    frame_dn.to_kind(Kind::Float) / 255.0 - 0.5
}
