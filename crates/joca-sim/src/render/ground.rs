//! The ground and the sky of a view, per pixel: where each ray below the horizon meets the
//! ground (shaded by sun and sky, lamps and head lights; the sky alone where something casts a
//! shadow on it), and the sky above it.

use super::shadow::Shadows;
use super::{CameraFrame, GROUND_FAR_M, Target, View, headlight};
use crate::city::City;
use crate::geometry::V3;
use crate::lighting::{self, RADIANCE_SCALE_DN};

/// Draws the ground where no object is nearer, and the sky where nothing was drawn; `lamp` is
/// the head lights' place and heading, `layers` what casts shadows (static, moving).
pub(super) fn ground_and_sky(
    city: &City,
    view: &View<'_>,
    cam: &CameraFrame,
    (lamp, heading): (V3, V3),
    layers: [Option<&Shadows>; 2],
    target: &mut Target,
) {
    let w = target.width;
    let light = &view.lighting;
    let up_irradiance = light.sun_sky([0.0, 0.0, 1.0]);
    let up_sun = light.direct_sun([0.0, 0.0, 1.0]);
    let mut shade = RowShadow::new(layers, w);
    let (lights_on, lamps_on) = (light.lights_on(), light.street_lamps_on());
    let k = RADIANCE_SCALE_DN;
    // Rightward slope of each column's view ray, once per view rather than once per pixel.
    let slopes: Vec<f32> = (0..w).map(|x| (x as f32 + 0.5 - cam.cx) / cam.fx).collect();
    let mut points = vec![(0.0f32, 0.0f32, 0.0f32); w];
    for y in 0..target.height {
        let b = (y as f32 + 0.5 - cam.cy) / cam.fy; // downward slope of the ray
        let row = y * w;
        let t = if b > 1e-6 { cam.origin.z / b } else { f32::INFINITY };
        if t > GROUND_FAR_M {
            let dir_z = -b / (1.0 + b * b).sqrt();
            let sky = light.sky(dir_z.max(0.0));
            for x in 0..w {
                if target.inv_depth[row + x] == 0.0 {
                    target.colour[(row + x) * 3..(row + x) * 3 + 3].copy_from_slice(&sky);
                }
            }
            continue;
        }
        let inv_t = 1.0 / t;
        ground_points(cam, t, &slopes, &mut points);
        shade.row(cam, t, y as u32 + 1);
        for (x, &(px, py, grain)) in points.iter().enumerate() {
            if target.inv_depth[row + x] >= inv_t {
                continue; // an object is nearer than the ground here
            }
            let albedo = city.ground_albedo_with(px, py, grain);
            let head =
                if lights_on { headlight(lamp, heading, V3::new(px, py, 0.0), None) } else { 0.0 };
            let i = (row + x) * 3;
            if let Some(e) = city.tunnel_irradiance(V3::new(px, py, 0.0), 1.0, up_irradiance) {
                for (out, rho) in target.colour[i..i + 3].iter_mut().zip(albedo) {
                    *out = k * rho * (e + head);
                }
            } else {
                let lamps = if lamps_on { city.lamp_irradiance(px, py) } else { 0.0 };
                let sun_sky = if shade.mask[x] { up_irradiance - up_sun } else { up_irradiance };
                for ((out, rho), tint) in
                    target.colour[i..i + 3].iter_mut().zip(albedo).zip(lighting::LAMP_TINT)
                {
                    *out = k * rho * (sun_sky + lamps * tint + head);
                }
            }
            target.inv_depth[row + x] = inv_t;
            target.id[row + x] = 0;
        }
    }
}

/// Which pixels of an image row see the ground in shadow, row by row.
struct RowShadow<'a> {
    layers: [Option<&'a Shadows>; 2],
    /// Per column of the current row: in shadow.
    mask: Vec<bool>,
    /// Scratch of [`Shadows::ground_line`], one per layer.
    seen: [Vec<u32>; 2],
    stretches: Vec<(f32, f32)>,
}

impl<'a> RowShadow<'a> {
    fn new(layers: [Option<&'a Shadows>; 2], width: usize) -> Self {
        Self {
            layers,
            mask: vec![false; width],
            seen: [Vec::new(), Vec::new()],
            stretches: Vec::new(),
        }
    }

    /// The mask of the row whose rays meet the ground at depth `t` (`stamp`: a number above
    /// every earlier row's). The ground point of column `x` is `origin + x·dir`, as
    /// [`ground_points`] computes it.
    fn row(&mut self, cam: &CameraFrame, t: f32, stamp: u32) {
        self.mask.iter_mut().for_each(|m| *m = false);
        if self.layers[0].is_none() {
            return;
        }
        let a0 = (0.5 - cam.cx) / cam.fx;
        let origin = [
            cam.origin.x + t * (cam.forward.x + a0 * cam.right.x),
            cam.origin.y + t * (cam.forward.y + a0 * cam.right.y),
        ];
        let dir = [t * cam.right.x / cam.fx, t * cam.right.y / cam.fx];
        let last = (self.mask.len() - 1) as f32;
        self.stretches.clear();
        for (layer, seen) in self.layers.iter().zip(&mut self.seen) {
            if let Some(s) = layer {
                s.ground_line((origin, dir), (0.0, last), (seen, stamp), &mut self.stretches);
            }
        }
        let width = self.mask.len();
        for &(lo, hi) in &self.stretches {
            // Columns x with lo ≤ x ≤ hi.
            let first = lo.ceil().max(0.0) as usize;
            let end = ((hi.floor() + 1.0).max(0.0) as usize).min(width);
            if first < end {
                self.mask[first..end].iter_mut().for_each(|m| *m = true);
            }
        }
    }
}

/// Where the view rays of one image row meet the ground, at depth `t` (`slopes`: each column's
/// rightward slope), and the ground's grain there: `(x, y, grain)` per column. The arithmetic
/// per column is that of one pixel alone; vector units only do several columns at once (the
/// AVX2 path gives the same bits as the portable one).
#[allow(unsafe_code)] // calling a target-feature function once the CPU is known to have it
pub(super) fn ground_points(
    cam: &CameraFrame,
    t: f32,
    slopes: &[f32],
    out: &mut [(f32, f32, f32)],
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { ground_points_avx2(cam, t, slopes, out) };
    }
    ground_points_portable(cam, t, slopes, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn ground_points_avx2(cam: &CameraFrame, t: f32, slopes: &[f32], out: &mut [(f32, f32, f32)]) {
    ground_points_portable(cam, t, slopes, out);
}

#[inline(always)]
pub(super) fn ground_points_portable(
    cam: &CameraFrame,
    t: f32,
    slopes: &[f32],
    out: &mut [(f32, f32, f32)],
) {
    for (o, &a) in out.iter_mut().zip(slopes) {
        let px = cam.origin.x + t * (cam.forward.x + a * cam.right.x);
        let py = cam.origin.y + t * (cam.forward.y + a * cam.right.y);
        *o = (px, py, crate::city::ground_grain(px, py));
    }
}
