//! What happens to light between the scene and the lens: fog along each pixel's ray
//! (Koschmieder's law), and rain's extinction by the same law.
//!
//! Light from a surface at distance r is attenuated by t = exp(−β·r) and replaced by airlight:
//! `L = L0·t + A·(1 − t)`, with β = ln(20)/V for a meteorological visibility V (the distance at
//! which a black object's contrast falls to 5 %). The airlight A is the horizon sky's radiance of
//! the moment; what hits nothing (sky, ground past the far plane) is pure airlight. The glow of
//! lamps and head lights in fog is [`super::glow`]'s.

use super::Target;
use joca_core::PinholeCamera;
use rayon::prelude::*;

/// Applies Koschmieder's law with visibility `visibility_m` to `target` seen through `camera`,
/// with airlight `airlight` (calibrated DN per channel), and writes each pixel's light depth for
/// fog's glow (light above the airlight × optical depth) into `target.light_depth` in the same
/// pass.
pub fn fog(target: &mut Target, camera: &PinholeCamera, visibility_m: f64, airlight: [f32; 3]) {
    extinction(target, camera, (fog_extinction(visibility_m), airlight), true);
}

/// Fog's extinction coefficient for a meteorological visibility, 1/m (ln 20 / V).
pub fn fog_extinction(visibility_m: f64) -> f64 {
    20f64.ln() / visibility_m
}

/// Koschmieder's law with extinction coefficient `beta_per_m` (rain's); empties
/// `target.light_depth` (fog's alone).
pub fn attenuate(target: &mut Target, camera: &PinholeCamera, beta_per_m: f64, airlight: [f32; 3]) {
    extinction(target, camera, (beta_per_m, airlight), false);
}

/// Each pixel's view-ray length per metre of depth along the optical axis, √(1 + a² + b²).
pub(crate) struct Rays {
    fx: f32,
    fy: f32,
    cx: f32,
    cy: f32,
}

impl Rays {
    pub(crate) fn new(camera: &PinholeCamera) -> Self {
        let (fx, fy) = (camera.fx_px as f32, camera.fy_px as f32);
        Self { fx, fy, cx: camera.cx_px as f32, cy: camera.cy_px as f32 }
    }

    /// Row `y`'s vertical slope b.
    pub(crate) fn slope(&self, y: usize) -> f32 {
        (y as f32 + 0.5 - self.cy) / self.fy
    }

    /// The length at column `x` of a row of slope `b`.
    pub(crate) fn length(&self, x: usize, b: f32) -> f32 {
        let a = (x as f32 + 0.5 - self.cx) / self.fx;
        (1.0 + a * a + b * b).sqrt()
    }
}

/// Koschmieder's law with `(β, airlight)`; with `glow_sources`, each pixel's light depth into
/// `target.light_depth` (else that buffer is emptied).
fn extinction(
    target: &mut Target,
    camera: &PinholeCamera,
    (beta_per_m, airlight): (f64, [f32; 3]),
    glow_sources: bool,
) {
    let beta = beta_per_m as f32;
    let rays = Rays::new(camera);
    let w = target.width;
    let Target { colour, inv_depth, light_depth, .. } = target;
    light_depth.clear();
    if glow_sources {
        light_depth.resize(inv_depth.len(), 0.0);
    }
    let row = |y: usize, colour: &mut [f32], inv_depth: &[f32], mut sources: Option<&mut [f32]>| {
        let b = rays.slope(y);
        for (x, (px, &inv_z)) in colour.chunks_exact_mut(3).zip(inv_depth).enumerate() {
            // Distance along the ray: depth z times the ray's length per unit z.
            let ray = if inv_z > 0.0 { rays.length(x, b) } else { 0.0 };
            let t = if inv_z > 0.0 { (-beta * (ray / inv_z)).exp() } else { 0.0 };
            for (v, a) in px.iter_mut().zip(airlight) {
                *v = *v * t + a * (1.0 - t);
            }
            if let Some(s) = sources.as_deref_mut() {
                s[x] = if inv_z > 0.0 {
                    super::glow::light_depth_of(px, airlight, beta * ray / inv_z)
                } else {
                    0.0
                };
            }
        }
    };
    let rows = colour.par_chunks_mut(w * 3).zip(inv_depth.par_chunks(w)).enumerate();
    if glow_sources {
        rows.zip(light_depth.par_chunks_mut(w)).for_each(|((y, (c, d)), s)| row(y, c, d, Some(s)));
    } else {
        rows.for_each(|(y, (c, d))| row(y, c, d, None));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::lens::tests::{camera, flat};

    #[test]
    fn fog_transmits_exp_minus_beta_r_and_the_sky_becomes_airlight() {
        // Visibility 300 m: β = ln 20 / 300. A wall at depth 150 m along the axis.
        let cam = camera(41, 41, 10.0, None);
        let mut t = flat(41, 41, 150.0, 100.0);
        t.inv_depth[0] = 0.0; // one pixel of sky
        fog(&mut t, &cam, 300.0, [40.0, 50.0, 60.0]);
        let tau = (-(20f64.ln()) / 300.0 * 150.0).exp(); // 0.2236 at the centre
        let centre = f64::from(t.colour[(20 * 41 + 20) * 3]);
        // The centre pixel's ray is 0.5 px off the axis: r = 150 m to 1e-7.
        assert!((centre - (100.0 * tau + 40.0 * (1.0 - tau))).abs() < 1e-3, "{centre}");
        assert_eq!(&t.colour[0..3], &[40.0, 50.0, 60.0]);
        // Off axis the ray is longer (corner: a = b = 20.5/800), so less of the wall is seen.
        let corner = f64::from(t.colour[(40 * 41 + 40) * 3]);
        let r = 150.0 * (1.0 + 2.0 * (20.5f64 / 800.0).powi(2)).sqrt();
        let tau_r = (-(20f64.ln()) / 300.0 * r).exp();
        assert!((corner - (100.0 * tau_r + 40.0 * (1.0 - tau_r))).abs() < 1e-3, "{corner}");
        // At the visibility distance a black object keeps 5 % of its contrast.
        let mut black = flat(1, 1, 300.0, 0.0);
        fog(&mut black, &camera(1, 1, 10.0, None), 300.0, [100.0; 3]);
        assert!((black.colour[0] - 95.0).abs() < 1e-3, "{}", black.colour[0]);
    }
}
