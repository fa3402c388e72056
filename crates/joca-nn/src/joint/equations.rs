//! The paper's equations on tensors, as the joint step differentiates them: Eq. 4 and the
//! exposure cap (twins of `joca_camera`'s), DF-Grad's l_GA (Eq. 5), the step cost, and the formed
//! frame back to 8 bits.

use super::GaTarget;
use crate::acc::AccBounds;
use joca_camera::{DynamicSettings, Iris};
use joca_core::Rgb8Image;
use joca_core::units::DB_PER_STOP;
use tch::{Kind, Tensor};

pub(super) fn unit_tensor(value: &Tensor, range: (f64, f64)) -> Tensor {
    (value - range.0) / (range.1 - range.0)
}

/// DF-Grad's GA supervision loss (paper Sec. 5): the L1 distance between NeuralAE's prediction
/// `(E_pred, G_pred)` and the best perturbation `(Ẽ*, G̃*)` the GA found, each in normalised units
/// (log exposure and gain in dB, each range mapped to [0, 1]), averaged over the two:
/// `l_GA = (|Ẽ* − E_pred| + |G̃* − G_pred|) / 2`. NeuralAE's loss is `w_task·l_task + w_ga·l_GA`.
/// Where NeuralAE sets the iris too (`iris_pred`, a unit position already), `|ũ* − u|` joins
/// the mean as a third term.
pub(super) fn ga_supervision_loss(
    e_pred: &Tensor,
    g_pred_db: &Tensor,
    iris_pred: Option<&Tensor>,
    target: GaTarget,
    bounds: &AccBounds,
) -> Tensor {
    let (e_star, g_star_db) = (target.settings.exposure_s, target.settings.gain_db);
    let e_unit = unit_tensor(&e_pred.log(), bounds.log_exposure);
    let g_unit = unit_tensor(g_pred_db, bounds.gain_db);
    let e_star_unit =
        (e_star.ln() - bounds.log_exposure.0) / (bounds.log_exposure.1 - bounds.log_exposure.0);
    let g_star_unit = (g_star_db - bounds.gain_db.0) / (bounds.gain_db.1 - bounds.gain_db.0);
    let pair = (e_unit - e_star_unit).abs() + (g_unit - g_star_unit).abs();
    match (iris_pred, target.iris) {
        (Some(u), Some(u_star)) => (pair + (u - u_star).abs()).mean(Kind::Float) / 3.0,
        _ => pair.mean(Kind::Float) / 2.0,
    }
}

/// The step cost (beyond the paper): `l_step = (s_E² + s_G²) / 2`, the mean square of the
/// stops that NeuralAE moves exposure (`s_E = log₂(E_pred / E_prev)`) and gain
/// (`s_G = (G_pred − G_prev) / 6.02 dB`) from the settings it read. A quadratic control cost:
/// a step the task needs (a tunnel exit) is paid for, a step the task is indifferent to (a
/// zig-zag in steady light) is trained away. The iris, where NeuralAE sets it, pays none.
pub(super) fn step_cost(e_pred: &Tensor, g_pred_db: &Tensor, previous: DynamicSettings) -> Tensor {
    let s_e = (e_pred.log() - previous.exposure_s.ln()) / std::f64::consts::LN_2;
    let s_g = (g_pred_db - previous.gain_db) / DB_PER_STOP;
    (s_e.square() + s_g.square()).mean(Kind::Float) / 2.0
}

/// `1` in value, with the gradient of the light a lens iris at unit position `u` lets through
/// relative to its value here: `exp(ln L(u) − ln L(u)|detached)`, `L(u) = (N0/N(u))²`, so
/// `∂/∂u = ∂ ln L/∂u = −2·(ln N_n − ln N_w)`. Multiplying the exposure by it forms the very frame
/// of the scene's light factor while the task loss reaches `u`.
pub(super) fn iris_light_gradient(u: &Tensor, iris: Iris) -> Tensor {
    let (a, b) = iris.log_range();
    let log_light = (u * (b - a) + a) * -2.0;
    (&log_light - log_light.detach()).exp()
}

/// Eq. 4 on tensors (linear gain inside, dB outside), as `joca_camera::compensate_for_pixel_size`.
pub(super) fn eq4(
    e_pred: &Tensor,
    g_pred_db: &Tensor,
    pitch_um: f64,
    calibration_pitch_um: f64,
) -> (Tensor, Tensor) {
    let area = (pitch_um / calibration_pitch_um).powi(2);
    if area > 1.0 {
        let g_lin = (g_pred_db / 20.0 * std::f64::consts::LN_10).exp();
        let g_t = (&g_lin / area).clamp_min(1.0);
        let e_t = e_pred * &g_lin / (&g_t * area);
        (e_t, g_t.log10() * 20.0)
    } else {
        (e_pred / area, g_pred_db.shallow_clone())
    }
}

/// `joca_camera::limit_exposure` on tensors: an exposure beyond `max_exposure_s` is capped and
/// the gain raised by the same factor, up to `max_gain_db`.
///
/// The forward values are the camera crate's. The gradient is not the cap's own: capped exposure
/// and clamped gain both have derivative 0, so a prediction pushed past both (a small pixel at
/// night, after Eq. 4) would never hear from the task loss again, in daylight too. The gain's
/// clamp is therefore straight-through: its gradient is that of the unclamped gain, which carries
/// the exposure's excess, so `∂(E·G)/∂E_pred` and `∂(E·G)/∂G_pred` are those of the uncapped
/// product.
pub(super) fn limit_exposure(
    e: &Tensor,
    g_db: &Tensor,
    max_exposure_s: f64,
    max_gain_db: f64,
) -> (Tensor, Tensor) {
    let excess = (e / max_exposure_s).clamp_min(1.0);
    let g = g_db + excess.log10() * 20.0;
    let clamped = &g + (g.clamp_max(max_gain_db) - &g).detach();
    (e / &excess, clamped)
}

pub(super) fn tensor_to_rgb8(frame_dn: &Tensor) -> Rgb8Image {
    let s = frame_dn.size();
    let (h, w) = (s[2] as usize, s[3] as usize);
    let bytes: Vec<u8> = Vec::try_from(
        frame_dn
            .detach()
            .squeeze_dim(0)
            .permute([1, 2, 0])
            .contiguous()
            .view([-1])
            .clamp(0.0, 255.0)
            .to_kind(Kind::Uint8),
    )
    .unwrap_or_else(|_| vec![0; w * h * 3]);
    Rgb8Image::from_vec(w, h, bytes).unwrap_or_else(|_| Rgb8Image::zeros(w, h))
}

/// The task loss's pull on NeuralAE's outputs in l_GA's units: `w_task · ∂l_task/∂u` for the
/// exposure's and the gain's unit position `u` in its range, from the gradients by the frame's
/// exposure (seconds, at `exposure_s`) and gain (dB). The exposure's unit is log-scaled, so
/// `∂E/∂u = E · (ln E_max − ln E_min)`; the gain's is linear in dB. Eq. 4 scales the exposure by a
/// constant and shifts the gain, which changes neither; where the exposure cap binds, the gain
/// carries the pull instead. On a step where l_GA applies it pulls each unit by `w_ga / 2`.
pub(crate) fn task_gradient_units(
    by_exposure: f64,
    by_gain_db: f64,
    exposure_s: f64,
    bounds: &AccBounds,
    task_weight: f64,
) -> [f64; 2] {
    let (a, b) = bounds.log_exposure;
    let (c, d) = bounds.gain_db;
    [task_weight * by_exposure * exposure_s * (b - a), task_weight * by_gain_db * (d - c)]
}
