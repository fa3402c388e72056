//! Fog's glow: light scattered once by the droplets on its way from a bright source to the
//! camera, which Koschmieder's law (see [`super::fog`]) removes from the direct beam but does not
//! put back anywhere.
//!
//! **Model.** A point source seen at distance d through fog of extinction β (optical depth
//! T = β·d) sends the camera, along a ray at angle θ from it, the single-scattered radiance
//! `L(θ) = β ∫₀^∞ p(ψ) I e^{−β(s + r)} / r² ds` (the scattering point at s along the ray, r from
//! the source, ψ its scattering angle, p the Henyey–Greenstein phase function of asymmetry
//! [`FOG_ASYMMETRY`]). With s = d·(cos θ + sin θ·tan ξ) the integral becomes the smooth
//! `L(θ) = (I/d²)·T/sin θ · ∫_{θ−π/2}^{π/2} p(−sin ξ)·e^{−T(x+ρ)} dξ`, ψ = π/2 + ξ. Per unit of
//! the source's *transmitted* irradiance (I/d²)·e^{−T} this is [`glow_profile`] G(θ; T): what
//! the glow adds around a pixel is the pixel's transmitted light times G, and sums over pixels
//! (the glow is linear in the light).
//!
//! **Sources.** The airlight already stands for the fog's in-scatter of the sky's light, so the
//! glow comes from what a pixel sends above the airlight: `(L − A)₊` of the fogged pixel (lamps,
//! head and tail lights, lit windows, lamp-lit surfaces at night; almost nothing by day, when
//! sunlit surfaces sit near the horizon sky's radiance). The sky itself (no depth) adds none.
//!
//! **Numerics.** For each optical depth on a table (0 to [`MAX_DEPTH`], clamped beyond: the
//! transmitted light is then under 2 % and single scattering no longer describes the halo)
//! G(θ; T) is fitted, by non-negative least squares over log θ weighted by the energy per log θ,
//! with normalised planar Gaussians of σ = 1 mrad·2^k (k = 0 … 10): the glow of a frame is then
//! one Gaussian blur per σ of the sources weighted by their own depth's coefficient, each blur
//! three extended-box passes a direction (cost independent of σ). Light leaving the frame is lost and
//! sources outside it add none; angles are the pinhole's r_px / f_px (the halo's shape is exact
//! near the source, approximate at tens of degrees).
//!
//! Rain's forward scattering is a diffraction peak of width λ/D ≤ 10⁻³ rad for drops of
//! D ≥ 0.5 mm, narrower than a pixel: rain has no glow here.

use joca_core::PinholeCamera;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::OnceLock;

/// Henyey–Greenstein asymmetry g of fog droplets at visible wavelengths (Mie theory for
/// 5–20 µm water droplets gives 0.8–0.9).
pub const FOG_ASYMMETRY: f64 = 0.85;

/// The deepest optical depth on the fitted table; sources beyond use its coefficients.
pub const MAX_DEPTH: f64 = 4.0;

/// Optical depths on the table: 0, 1/8, …, [`MAX_DEPTH`].
const DEPTH_STEPS: usize = 32;

/// The Gaussians' σ: 1 mrad·2^k, radians.
const SIGMA0_RAD: f64 = 1e-3;
/// How many Gaussians (σ up to 1.02 rad).
const GAUSSIANS: usize = 11;

/// The Henyey–Greenstein phase function of asymmetry `g` at the scattering angle's cosine, per
/// steradian (it integrates to 1 over the sphere).
pub fn henyey_greenstein(g: f64, cos_psi: f64) -> f64 {
    (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * cos_psi).powf(1.5))
}

/// G(θ; T): single-scattered radiance at angle `theta` (radians, 0 < θ < π) from a point source
/// at optical depth `depth`, per unit of the source's transmitted irradiance, per steradian, with
/// phase function `phase` (a function of cos ψ). Integrated by the midpoint rule over ξ.
pub fn glow_profile(theta: f64, depth: f64, phase: impl Fn(f64) -> f64) -> f64 {
    const STEPS: usize = 1000;
    let (s, c) = theta.sin_cos();
    let lo = theta - FRAC_PI_2;
    let h = (FRAC_PI_2 - lo) / STEPS as f64;
    let mut sum = 0.0;
    for i in 0..STEPS {
        let xi = lo + (i as f64 + 0.5) * h;
        let (sx, cx) = xi.sin_cos();
        // Extra path over the direct one, in units of d: (x + ρ) − 1 ≥ 0.
        let extra = c + s * (sx / cx) + s / cx - 1.0;
        let attenuation = if depth > 0.0 { (-depth * extra).exp() } else { 1.0 };
        sum += phase(-sx) * attenuation;
    }
    depth * sum * h / s
}

/// A normalised planar Gaussian of standard deviation `sigma` at radius `r` (same units).
fn gaussian(r: f64, sigma: f64) -> f64 {
    (-(r * r) / (2.0 * sigma * sigma)).exp() / (2.0 * PI * sigma * sigma)
}

/// The Gaussians' σ, radians.
fn sigmas_rad() -> [f64; GAUSSIANS] {
    std::array::from_fn(|k| SIGMA0_RAD * f64::from(1u32 << k))
}

/// Non-negative weights a_k with Σ a_k·N(θ; σ_k) ≈ `profile(θ)`, in the least-squares sense of
/// the energy per log θ (θ²·profile) on log-spaced θ from 0.2 mrad to 1.5 rad.
pub fn fit_gaussians(profile: impl Fn(f64) -> f64) -> [f64; GAUSSIANS] {
    const SAMPLES: usize = 120;
    let sigmas = sigmas_rad();
    let (lo, hi) = (2e-4f64.ln(), 1.5f64.ln());
    let thetas: Vec<f64> =
        (0..SAMPLES).map(|i| (lo + (hi - lo) * i as f64 / (SAMPLES - 1) as f64).exp()).collect();
    let basis: Vec<[f64; GAUSSIANS]> =
        thetas.iter().map(|&t| std::array::from_fn(|k| t * t * gaussian(t, sigmas[k]))).collect();
    let target: Vec<f64> = thetas.iter().map(|&t| t * t * profile(t)).collect();
    // Normal equations, solved by projected Gauss–Seidel (converges: M is positive definite).
    let mut m = [[0.0; GAUSSIANS]; GAUSSIANS];
    let mut v = [0.0; GAUSSIANS];
    for (b, y) in basis.iter().zip(&target) {
        for i in 0..GAUSSIANS {
            v[i] += b[i] * y;
            for j in 0..GAUSSIANS {
                m[i][j] += b[i] * b[j];
            }
        }
    }
    let mut a = [0.0; GAUSSIANS];
    for _ in 0..4000 {
        for i in 0..GAUSSIANS {
            let r: f64 = v[i] - (0..GAUSSIANS).map(|j| m[i][j] * a[j]).sum::<f64>();
            a[i] = (a[i] + r / m[i][i]).max(0.0);
        }
    }
    a
}

/// The fitted weights of every optical depth on the table, for fog's phase function.
fn table() -> &'static [[f32; GAUSSIANS]] {
    static TABLE: OnceLock<Vec<[f32; GAUSSIANS]>> = OnceLock::new();
    TABLE.get_or_init(|| {
        (0..=DEPTH_STEPS)
            .into_par_iter()
            .map(|j| {
                let depth = MAX_DEPTH * j as f64 / DEPTH_STEPS as f64;
                let phase = |c: f64| henyey_greenstein(FOG_ASYMMETRY, c);
                fit_gaussians(|t| glow_profile(t, depth, phase)).map(|a| a as f32)
            })
            .collect()
    })
}

/// Where optical depth `depth` falls on the table: the row below it and the share of the next.
fn table_row(depth: f32) -> (u32, f32) {
    let u = (depth.max(0.0) / MAX_DEPTH as f32 * DEPTH_STEPS as f32).min(DEPTH_STEPS as f32);
    let j = (u as usize).min(DEPTH_STEPS - 1);
    (j as u32, u - j as f32)
}

/// The weight of Gaussian `k` at a table position ([`table_row`]), linear between rows.
fn weight(table: &[[f32; GAUSSIANS]], (j, f): (u32, f32), k: usize) -> f32 {
    let j = j as usize;
    table[j][k] * (1.0 - f) + table[j + 1][k] * f
}

/// For the tests: adds fog's glow to one instant's RGB view `colour` (interleaved, `width ×
/// height`, fogged: Koschmieder applied) whose pixels lie at `inv_depth` (1/m along the axis;
/// 0 = sky) seen through `camera`, in fog of extinction `beta_per_m` and airlight `airlight`.
#[cfg(test)]
fn fog_glow(
    colour: &mut [f32],
    inv_depth: &[f32],
    size: (usize, usize),
    camera: &PinholeCamera,
    (beta_per_m, airlight): (f64, [f32; 3]),
) {
    let mut depth = Vec::new();
    light_depth(colour, inv_depth, size, camera, (beta_per_m, airlight), &mut depth);
    fog_glow_integrated(colour, &depth, size, camera, airlight);
}

/// For the tests: each pixel's light above the airlight (summed over channels) times its
/// optical depth β·r, into `out` (0 for the sky), as [`super::fog::fog`] writes it in its own
/// pass. Summed over a shutter's sub-frames and divided by the integrated frame's light above
/// the airlight, it gives the light-weighted optical depth of what a pixel saw during the
/// shutter (a lamp's when the lamp streaked across a distant facade).
#[cfg(test)]
fn light_depth(
    colour: &[f32],
    inv_depth: &[f32],
    (width, height): (usize, usize),
    camera: &PinholeCamera,
    (beta_per_m, airlight): (f64, [f32; 3]),
    out: &mut Vec<f32>,
) {
    let beta = beta_per_m as f32;
    let rays = super::fog::Rays::new(camera);
    out.clear();
    out.resize(width * height, 0.0);
    out.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        let b = rays.slope(y);
        for (x, d) in row.iter_mut().enumerate() {
            let p = y * width + x;
            let inv_z = inv_depth[p];
            *d = if inv_z > 0.0 {
                light_depth_of(
                    &colour[p * 3..p * 3 + 3],
                    airlight,
                    beta * rays.length(x, b) / inv_z,
                )
            } else {
                0.0
            };
        }
    });
}

/// One pixel's light above the airlight, summed over channels, times its optical depth.
pub(crate) fn light_depth_of(px: &[f32], airlight: [f32; 3], depth: f32) -> f32 {
    excess(px, airlight).iter().sum::<f32>() * depth
}

/// A pixel's light above the airlight, per channel.
fn excess(px: &[f32], airlight: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|c| (px[c] - airlight[c]).max(0.0))
}

/// Adds fog's glow to a shutter-integrated RGB frame `colour` whose pixels' light-weighted
/// optical depths sum to `light_depth` (what [`super::fog::fog`] writes per sub-frame, summed
/// with the shutter's weights).
pub fn fog_glow_integrated(
    colour: &mut [f32],
    light_depth: &[f32],
    (width, height): (usize, usize),
    camera: &PinholeCamera,
    airlight: [f32; 3],
) {
    let n = width * height;
    if colour.len() != n * 3 || light_depth.len() != n || n == 0 {
        return;
    }
    let table = table();
    // Each pixel's excess over the airlight and where its optical depth falls on the table.
    let mut excesses = vec![[0.0f32; 3]; n];
    let mut rows = vec![(0u32, 0.0f32); n];
    let lit = excesses
        .par_chunks_mut(width)
        .zip(rows.par_chunks_mut(width))
        .enumerate()
        .map(|(y, (ex, at))| {
            let mut lit = false;
            for (x, (ex, at)) in ex.iter_mut().zip(at).enumerate() {
                let p = y * width + x;
                let e = excess(&colour[p * 3..p * 3 + 3], airlight);
                let light: f32 = e.iter().sum();
                if light > 0.0 && light_depth[p] > 0.0 {
                    (*ex, *at) = (e, table_row(light_depth[p] / light));
                    lit = true;
                }
            }
            lit
        })
        .reduce(|| false, |a, b| a || b);
    if !lit {
        return;
    }
    let f_px = (camera.fx_px * camera.fy_px).sqrt();
    let sigmas_px = sigmas_rad().map(|sigma| sigma * f_px);
    let source = |k: usize, p: usize| -> Rgb {
        let w = weight(table, rows[p], k);
        excesses[p].map(|e| e * w)
    };
    let glow = blur::sum_of_gaussians(&source, &sigmas_px, (width, height));
    for (px, g) in colour.chunks_exact_mut(3).zip(&glow) {
        px.iter_mut().zip(g).for_each(|(v, g)| *v += g);
    }
}

pub(crate) mod blur;
#[cfg(test)]
mod tests;

use blur::Rgb;
#[cfg(test)]
use blur::gaussian_blur;
