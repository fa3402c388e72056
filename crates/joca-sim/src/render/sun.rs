//! The sun in the sky: the sky brighter towards it, and its disc where the view sees it.
//!
//! **The aureole.** By day each sky pixel's radiance is multiplied by the CIE standard clear
//! sky's scattering indicatrix (CIE S 011/E:2003, ISO 15469, sky type 12: c = 10, d = −3,
//! e = 0.45) at its angle χ from the sun, relative to its value 90° away:
//! `f(χ) = 1 + 10·(e^{−3χ} − e^{−3π/2}) + 0.45·cos²χ` ([`indicatrix`]): 11.4 times next to the
//! sun, 1.36 opposite it, unchanged 90° away. The sky's gradation from horizon to zenith stays
//! the renderer's own; surfaces are still lit by the sky's uniform share. Every sky pixel of every
//! sub-frame reads `e^{−3χ}` from a table in `u = sin(χ/2) = √((1 − cos χ)/2)`, in which
//! `e^{−6·asin u}` is smooth, interpolated linearly ([`indicatrix_of_cos`]): within 5e-5 of the
//! closed form (tested), without an `acos` and an `exp` per pixel.
//!
//! **The disc.**
//! A white surface facing the sun reads `RADIANCE_SCALE_DN·SUN·ambient` (the renderer's unit:
//! radiance of a white Lambertian surface, E/π), so the disc's radiance is
//! `π·RADIANCE_SCALE_DN·SUN·ambient / Ω_sun` with `Ω_sun = π·ρ²` (ρ = [`SUN_RADIUS_RAD`]): about
//! 46,000 times the white surface, which clips any camera that exposes for the street. Drawn
//! only while the street lamps are off (by day and in the tunnel schedule's daylight), over the
//! sky alone (a nearer surface hides it); each pixel near the disc takes the share of its
//! 16 × 16 sub-samples whose view rays lie within the sun's angular radius (the disc spans
//! 2 pixels at a focal length of 200 px), so its light on the frame is the sun's irradiance to
//! within the sub-sampling.

use super::{CameraFrame, Target, View};
use crate::lighting::{RADIANCE_SCALE_DN, SUN};

/// The sun's angular radius, radians (0.2665°).
pub const SUN_RADIUS_RAD: f32 = 4.651e-3;

/// Sub-samples per pixel side.
const SUB: usize = 16;

/// The disc's radiance, DN, at ambient level `ambient` (1 by day).
pub fn disc_radiance(ambient: f32) -> f32 {
    let solid_angle = std::f32::consts::PI * SUN_RADIUS_RAD * SUN_RADIUS_RAD;
    std::f32::consts::PI * RADIANCE_SCALE_DN * SUN * ambient / solid_angle
}

/// The CIE clear sky's indicatrix at angle `chi` (radians) from the sun, relative to 90° away.
pub fn indicatrix(chi: f32) -> f32 {
    let c = chi.cos();
    1.0 + 10.0 * ((-3.0 * chi).exp() - (-1.5 * std::f32::consts::PI).exp()) + 0.45 * c * c
}

/// Intervals of the table in `u = sin(χ/2)`: linear interpolation of `e^{−6·asin u}` (second
/// derivative at most 36) errs by at most 36/(8·N²) = 4.3e-6, 4.3e-5 after the factor 10.
const TABLE_N: usize = 1024;

/// The indicatrix in tabled form: `e^{−3χ}` at `u = sin(χ/2) = k/TABLE_N`, k = 0 … TABLE_N, and
/// the formula's constant `e^{−3π/2}`, made once.
struct Indicatrix {
    g: [f32; TABLE_N + 1],
    at_right_angle: f32,
}

impl Indicatrix {
    fn get() -> &'static Self {
        static TABLE: std::sync::OnceLock<Indicatrix> = std::sync::OnceLock::new();
        TABLE.get_or_init(|| Indicatrix {
            g: std::array::from_fn(|k| (-6.0 * (k as f64 / TABLE_N as f64).asin()).exp() as f32),
            at_right_angle: (-1.5 * std::f32::consts::PI).exp(),
        })
    }

    #[inline]
    fn of_cos(&self, cos: f32) -> f32 {
        let c = cos.clamp(-1.0, 1.0);
        let at = ((1.0 - c) * 0.5).sqrt() * TABLE_N as f32;
        let k = (at as usize).min(TABLE_N - 1);
        let t = at - k as f32;
        let g = self.g[k] + t * (self.g[k + 1] - self.g[k]);
        1.0 + 10.0 * (g - self.at_right_angle) + 0.45 * c * c
    }
}

/// [`indicatrix`] at the angle whose cosine is `cos` (clamped to [−1, 1]), from the table.
pub fn indicatrix_of_cos(cos: f32) -> f32 {
    Indicatrix::get().of_cos(cos)
}

/// Brightens the sky of `target` towards the sun and draws the sun's disc over it (nothing
/// while the lamps are on; no disc where it is out of view or behind a surface).
pub(super) fn draw_sun(view: &View<'_>, cam: &CameraFrame, target: &mut Target) {
    let light = &view.lighting;
    if light.lights_on() {
        return;
    }
    let d = light.sun_dir;
    aureole(d, cam, target);
    let depth = d[0] * cam.forward.x + d[1] * cam.forward.y + d[2] * cam.forward.z;
    if depth <= 0.0 {
        return;
    }
    let right = d[0] * cam.right.x + d[1] * cam.right.y + d[2] * cam.right.z;
    // The camera looks horizontally: image down is world −z.
    let (u, v) = (cam.cx + cam.fx * right / depth, cam.cy - cam.fy * d[2] / depth);
    // A box around the disc: its radius through the pinhole is at most f·ρ/depth² off axis.
    let (rx, ry) =
        (cam.fx * SUN_RADIUS_RAD / depth.powi(2), cam.fy * SUN_RADIUS_RAD / depth.powi(2));
    let (w, h) = (target.width as f32, target.height as f32);
    if u + rx < 0.0 || u - rx > w || v + ry < 0.0 || v - ry > h {
        return;
    }
    let cos_radius = SUN_RADIUS_RAD.cos();
    // Whether the view ray through image point (sx, sy) lies within the disc.
    let in_disc = |sx: f32, sy: f32| cos_to_sun(cam, d, sx, sy) >= cos_radius;
    let radiance = disc_radiance(light.ambient * light.beam);
    let (x0, x1) =
        ((u - rx - 1.0).floor().max(0.0) as usize, ((u + rx + 1.0).ceil().min(w)) as usize);
    let (y0, y1) =
        ((v - ry - 1.0).floor().max(0.0) as usize, ((v + ry + 1.0).ceil().min(h)) as usize);
    for y in y0..y1 {
        for x in x0..x1 {
            let p = y * target.width + x;
            if target.inv_depth[p] != 0.0 {
                continue;
            }
            let inside = (0..SUB * SUB)
                .filter(|&s| {
                    let sx = x as f32 + ((s % SUB) as f32 + 0.5) / SUB as f32;
                    in_disc(sx, y as f32 + ((s / SUB) as f32 + 0.5) / SUB as f32)
                })
                .count();
            let cover = inside as f32 / (SUB * SUB) as f32;
            for c in &mut target.colour[p * 3..p * 3 + 3] {
                *c += cover * (radiance - *c);
            }
        }
    }
}

/// Multiplies every sky pixel of `target` by the indicatrix at its view ray's angle from the
/// sun (direction `d`), a row at a time: the factors of a row's columns in one loop without
/// branches (vectorised), then applied where the row sees sky. A row's factors depend only on
/// the sun, the camera's heading and intrinsics, and the row, so each thread keeps the last
/// view's rows and reuses them while all of those are bit for bit the same (the sub-frames of
/// one shutter and the frames along a straight road).
fn aureole(d: [f32; 3], cam: &CameraFrame, target: &mut Target) {
    thread_local! {
        static LAST: std::cell::RefCell<Aureole> = std::cell::RefCell::new(Aureole::default());
    }
    let (w, h) = (target.width, target.height);
    LAST.with_borrow_mut(|aureole| {
        aureole.view(d, cam, (w, h));
        let rows = target.colour.chunks_exact_mut(3 * w).zip(target.inv_depth.chunks_exact(w));
        for (y, (colour, depth)) in rows.enumerate() {
            if depth.iter().all(|&z| z != 0.0) {
                continue;
            }
            let factors = &mut aureole.factors[y * w..(y + 1) * w];
            if !aureole.rows_made[y] {
                row_factors(&aureole.to_sun, (y as f32 + 0.5 - cam.cy) / cam.fy, factors);
                aureole.rows_made[y] = true;
            }
            for ((c, &z), &f) in colour.chunks_exact_mut(3).zip(depth).zip(&*factors) {
                if z == 0.0 {
                    c.iter_mut().for_each(|c| *c *= f);
                }
            }
        }
    });
}

/// One view's aureole factors, made a row at a time as rows with sky need them.
#[derive(Default)]
struct Aureole {
    /// What the factors depend on: the sun, the camera's heading and intrinsics (as bits), and
    /// the frame's size; `None` before the first view.
    key: Option<([u32; 11], (usize, usize))>,
    to_sun: SunInView,
    factors: Vec<f32>,
    rows_made: Vec<bool>,
}

impl Aureole {
    /// Makes these the factors of the view of the sun `d` through `cam` on a frame of `size`:
    /// unchanged where they are already, else no row made (the buffers kept, so a view of
    /// another heading, every sub-frame on a bend, allocates nothing).
    fn view(&mut self, d: [f32; 3], cam: &CameraFrame, (w, h): (usize, usize)) {
        let (f, r) = (cam.forward, cam.right);
        let values = [d[0], d[1], d[2], f.x, f.y, r.x, r.y, cam.fx, cam.fy, cam.cx, cam.cy];
        let key = Some((values.map(f32::to_bits), (w, h)));
        if self.key == key {
            return;
        }
        self.key = key;
        self.to_sun.view(d, cam, w);
        self.factors.resize(w * h, 0.0);
        self.rows_made.clear();
        self.rows_made.resize(h, false);
    }
}

/// The sun's direction in the camera's horizontal frame and the columns' rightward slopes: a
/// view ray `forward + a·right − b·up` (`a`, `b`: the pixel's slopes right and down) has the
/// cosine `(forward·d + a·right·d − b·d_z) / √(1 + a² + b²)` with the sun, since `forward` and
/// `right` are horizontal, orthogonal and of unit length.
#[derive(Default)]
struct SunInView {
    ahead: f32,
    right: f32,
    up: f32,
    slopes: Vec<f32>,
}

impl SunInView {
    /// Becomes the view of the sun `d` through `cam` on a frame `width` pixels wide.
    fn view(&mut self, d: [f32; 3], cam: &CameraFrame, width: usize) {
        self.ahead = d[0] * cam.forward.x + d[1] * cam.forward.y + d[2] * cam.forward.z;
        self.right = d[0] * cam.right.x + d[1] * cam.right.y + d[2] * cam.right.z;
        self.up = d[2];
        self.slopes.clear();
        self.slopes.extend((0..width).map(|x| (x as f32 + 0.5 - cam.cx) / cam.fx));
    }
}

/// The indicatrix of each column of the row whose downward slope is `b`, into `out`.
#[allow(unsafe_code)] // calling a target-feature function once the CPU is known to have it
fn row_factors(sun: &SunInView, b: f32, out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { row_factors_avx2(sun, b, out) };
    }
    row_factors_portable(sun, b, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn row_factors_avx2(sun: &SunInView, b: f32, out: &mut [f32]) {
    row_factors_portable(sun, b, out);
}

#[inline(always)]
fn row_factors_portable(sun: &SunInView, b: f32, out: &mut [f32]) {
    let (base, bb, table) = (sun.ahead - b * sun.up, 1.0 + b * b, Indicatrix::get());
    for (f, &a) in out.iter_mut().zip(&sun.slopes) {
        *f = table.of_cos((base + a * sun.right) / (bb + a * a).sqrt());
    }
}

/// The cosine of the angle between the sun (direction `d`) and the view ray through image point
/// (`sx`, `sy`) of the horizontal camera `cam` (image down is world −z).
fn cos_to_sun(cam: &CameraFrame, d: [f32; 3], sx: f32, sy: f32) -> f32 {
    let (a, b) = ((sx - cam.cx) / cam.fx, (sy - cam.cy) / cam.fy);
    let ray = [
        cam.forward.x + a * cam.right.x,
        cam.forward.y + a * cam.right.y,
        cam.forward.z + a * cam.right.z - b,
    ];
    let norm = (ray[0] * ray[0] + ray[1] * ray[1] + ray[2] * ray[2]).sqrt();
    (ray[0] * d[0] + ray[1] * d[1] + ray[2] * d[2]) / norm
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table against the closed form at the same cosine, over every angle from the sun
    /// (finer near it, where the indicatrix is steepest).
    #[test]
    fn the_table_reads_the_indicatrix_within_5e_5() {
        let mut worst = 0.0f64;
        for i in 0..=200_000 {
            let chi = std::f32::consts::PI * (i as f32 / 200_000.0).powi(2);
            let c = chi.cos();
            let exact = indicatrix(c.clamp(-1.0, 1.0).acos());
            worst = worst.max((f64::from(indicatrix_of_cos(c)) / f64::from(exact) - 1.0).abs());
        }
        assert!(worst < 5e-5, "{worst}");
        assert!((indicatrix_of_cos(1.0) / indicatrix(0.0) - 1.0).abs() < 1e-6);
        assert!((indicatrix_of_cos(-1.5) / indicatrix(std::f32::consts::PI) - 1.0).abs() < 1e-6);
    }

    /// The kept rows are those a fresh thread makes for the same view, after a view of another
    /// heading in between; and each factor is the closed form's at its pixel's angle.
    #[test]
    fn kept_aureole_rows_equal_fresh_ones_and_the_closed_form() {
        let camera = joca_core::PinholeCamera::centred((64, 48), (40.0, 40.0), [0.0, 0.0, 1.5]);
        let pose = |yaw| crate::geometry::Pose2 { x: 0.0, y: 0.0, yaw };
        let d = [0.8f32, 0.3, 0.2];
        let norm = d.iter().map(|v| v * v).sum::<f32>().sqrt();
        let d = d.map(|v| v / norm);
        let sky = move |yaw: f32| {
            let cam = CameraFrame::new(&camera, pose(yaw));
            let mut target = Target::new(64, 48, 0);
            target.colour.iter_mut().for_each(|c| *c = 1.0);
            aureole(d, &cam, &mut target);
            target.colour
        };
        let first = sky(0.1);
        assert_ne!(sky(0.7), first);
        assert_eq!(sky(0.1), first);
        assert_eq!(std::thread::scope(|s| s.spawn(|| sky(0.1)).join().unwrap()), first);
        let cam = CameraFrame::new(&camera, pose(0.1));
        for (p, rgb) in first.chunks_exact(3).enumerate() {
            let cos = cos_to_sun(&cam, d, (p % 64) as f32 + 0.5, (p / 64) as f32 + 0.5);
            let exact = indicatrix(cos.clamp(-1.0, 1.0).acos());
            assert!((rgb[0] / exact - 1.0).abs() < 1e-4, "pixel {p}: {} against {exact}", rgb[0]);
        }
    }
}
