//! The lens's veiling glare on a frame (the model, its closed forms and its Gaussian bands:
//! [`joca_core::glare`]), between the lens's blur and the sensor.
//!
//! The glare spread function is blurred as Gaussians of σ = ¼ pixel·2^k (k = 0, 1, …, up to
//! twice the frame's diagonal), in angle through the pinhole's focal length (r_px / f_px: exact
//! near a source, approximate tens of degrees away), each weighted by its band of the mixing
//! distribution, on the pyramid of block means of fog's glow ([`super::glow`]); the bands of
//! σ ≤ 1 pixel stay on their pixel. As for the glow, light spread beyond the frame is lost and
//! the scene beyond it sends none: a uniform field reads `1 − g·(share beyond the frame)` of
//! itself, a little less towards the edges (the glare of what lies outside the view is not
//! rendered).

use super::glow::blur::{Rgb, add, block_mean, blur_rgb, sigma_on_level, upsample2};
use joca_core::PinholeCamera;
use joca_core::glare::Glare;
use rayon::prelude::*;

/// The narrowest band's σ, pixels.
const SIGMA0_PX: f64 = 0.25;

/// Bands up to this σ, pixels, stay on their pixel: a spread within a pixel or so of its source
/// is the lens's blur, not a veil (their share of the glare is erfc(θ0/2 px): 2.4 % where θ0
/// spans 3.2 pixels, as 1° does on the 320 × 240 frames of `joca bench render`, and under
/// 10⁻¹⁰ from 10 pixels up).
const ON_PIXEL_SIGMA_PX: f64 = 1.0;

/// The bands of a frame of `width × height` pixels seen with focal length `f_px`: σ in pixels
/// and weights.
fn bands(glare: &Glare, (width, height): (usize, usize), f_px: f64) -> (Vec<f64>, Vec<f64>) {
    let diagonal = ((width * width + height * height) as f64).sqrt();
    let mut sigmas_px = vec![SIGMA0_PX];
    while sigmas_px[sigmas_px.len() - 1] < 2.0 * diagonal {
        sigmas_px.push(sigmas_px[sigmas_px.len() - 1] * 2.0);
    }
    let sigmas_rad: Vec<f64> = sigmas_px.iter().map(|s| s / f_px).collect();
    let weights = glare.band_weights(&sigmas_rad);
    (sigmas_px, weights)
}

/// The pyramid level (grid step 2^j) of a band of `sigma_px`: the coarsest that keeps σ at least
/// 2 grid pixels wide (where in a block the light fell moves it by at most σ/4: the glare's
/// shape, not its total, and the ring test's 5 % hold) and at least 8 pixels on the short side.
fn level(sigma_px: f64, short_px: usize) -> usize {
    let mut j = 0;
    while 2.0 * f64::from(2u32 << j) <= sigma_px && short_px >> (j + 1) >= 8 {
        j += 1;
    }
    j
}

/// The pyramid of 2 × 2 block means of a frame (outside the frame counts as 0), levels 0 to
/// `top`, each with its size: each level the block mean of the one below.
fn pyramid(
    colour: &[f32],
    (width, height): (usize, usize),
    top: usize,
) -> Vec<(Vec<Rgb>, (usize, usize))> {
    let mut levels = vec![(
        colour.par_chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect::<Vec<Rgb>>(),
        (width, height),
    )];
    for _ in 0..top {
        let (fine, (fw, fh)) = &levels[levels.len() - 1];
        let coarse = block_mean(&|p| fine[p], (*fw, *fh), 2);
        levels.push((coarse, (fw.div_ceil(2), fh.div_ceil(2))));
    }
    levels
}

/// Applies `glare` to an RGB frame `colour` (interleaved, `width × height`) seen through
/// `camera`: `(1 − g)·E + g·(P ∗ E)`. Nothing changes without glare.
pub fn veiling_glare(
    colour: &mut [f32],
    (width, height): (usize, usize),
    camera: &PinholeCamera,
    glare: &Glare,
) {
    let n = width * height;
    if glare.is_off() || n == 0 || colour.len() != n * 3 {
        return;
    }
    let f_px = (camera.fx_px * camera.fy_px).sqrt();
    let (sigmas_px, weights) = bands(glare, (width, height), f_px);
    let g = glare.fraction;
    let levels: Vec<usize> = sigmas_px.iter().map(|&s| level(s, width.min(height))).collect();
    let top = levels.iter().copied().max().unwrap_or(0);
    let planes = pyramid(colour, (width, height), top);
    // What stays on its pixel, then each band on its level, summed from the coarsest down.
    let mut on_pixel = 1.0 - g;
    let mut sum: Vec<Rgb> = vec![[0.0; 3]; planes[top].0.len()];
    for j in (0..=top).rev() {
        if j < top {
            sum = upsample2(&sum, planes[j + 1].1, planes[j].1);
        }
        for k in (0..sigmas_px.len()).filter(|&k| levels[k] == j) {
            let w = g * weights[k] as f32;
            if sigmas_px[k] <= ON_PIXEL_SIGMA_PX {
                on_pixel += w;
                continue;
            }
            let mut plane = planes[j].0.clone();
            blur_rgb(&mut plane, planes[j].1, sigma_on_level(sigmas_px[k], j));
            sum.par_iter_mut().zip(&plane).for_each(|(v, p)| add(v, p.map(|x| x * w)));
        }
    }
    colour.par_chunks_exact_mut(3).zip(sum.par_iter()).for_each(|(px, s)| {
        for (v, s) in px.iter_mut().zip(s) {
            *v = on_pixel * *v + s;
        }
    });
}

#[cfg(test)]
mod tests;
