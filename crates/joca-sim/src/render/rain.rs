//! Rain: the extinction of the falling drops along every ray, and the streaks the nearest drops
//! draw during the shutter.
//!
//! **Drops.** Sizes follow Marshall and Palmer (1948): N(D) = N0·exp(−Λ·D) per m³ and mm of
//! diameter, N0 = 8000, Λ = 4.1·R^−0.21 for a rain rate R in mm/h. Each falls at its terminal
//! speed v(D) = 9.65 − 10.3·exp(−0.6·D) m/s (Atlas, Srivastava and Sekhon, 1973).
//!
//! **Extinction.** Drops are thousands of wavelengths wide, so each removes twice its cross
//! section from a beam (the extinction paradox, Q = 2): β = ∫ 2·(π/4)·D²·N(D) dD = π·N0/Λ³,
//! 0.365·R^0.63 per km (1.6 per km, a visibility of 1.9 km, at 10 mm/h). It acts on each ray as
//! fog does (Koschmieder, with the horizon sky as airlight).
//!
//! **Streaks.** A drop of diameter D at depth z is imaged as a disc of d = f_px·D/z pixels.
//! During the shutter it falls at v(D) while the camera moves with the ego vehicle, so its
//! image sweeps the path between its projections at the shutter's opening and closing: straight
//! down, ℓ = f_px·v·T/z pixels, for a standing camera; away from the focus of expansion, and
//! growing as the drop nears, for a driving one (the camera's pose at each instant is the ego's,
//! turning included; wind is not modelled). The time-averaged image is the average of the disc's
//! images at instants evenly spread over the shutter, about one per disc width of path, each a
//! square of side max(d, 1) carrying the disc's area (π/4)·d² (so the streak's light is exact
//! however it is sampled). A pixel's shares of the shutter add up (light adds over time) and
//! blend it toward the drop's radiance once: a few per cent for a 2 mm drop over a 10 ms shutter
//! (≈ D/(v·T) whatever the depth), more for short shutters. While the drop is nearer than
//! [`NEAREST_M`] / 2 it draws nothing.
//! A drop refracts a wide cone of the scene above and behind the camera (Garg and Nayar, 2004);
//! its radiance is taken as the sky's at 30° elevation. Streaks are drawn for drops from
//! [`NEAREST_M`] to [`FARTHEST_M`] of at least [`SMALLEST_MM`], where the scene lies behind
//! them; farther or smaller drops cover under 1 % of a pixel at the detector's input and act
//! through the extinction only.

use super::Target;
use crate::geometry::Pose2;
use joca_core::PinholeCamera;
use rand::Rng;

/// Marshall–Palmer's intercept N0, per m³ per mm.
pub const MP_N0: f64 = 8000.0;

/// The nearest drop drawn, metres (closer ones are a lens's concern: they blur away).
pub const NEAREST_M: f64 = 0.3;

/// The farthest drop drawn as a streak, metres.
pub const FARTHEST_M: f64 = 5.0;

/// The smallest drop drawn as a streak, millimetres.
pub const SMALLEST_MM: f64 = 0.5;

/// Drops break up above this diameter, millimetres.
pub const LARGEST_MM: f64 = 6.0;

/// Marshall–Palmer's slope Λ for rain rate `rate_mm_h`, per mm.
pub fn mp_slope(rate_mm_h: f64) -> f64 {
    4.1 * rate_mm_h.powf(-0.21)
}

/// The extinction coefficient of rain at `rate_mm_h`, per metre: π·N0/Λ³ (see the module).
pub fn extinction_per_m(rate_mm_h: f64) -> f64 {
    // N0 in m⁻³·mm⁻¹ times mm³ of ∫D²·exp(−ΛD)dD·(π/2)·... gives mm²/m³ = 10⁻⁶ m⁻¹.
    std::f64::consts::PI * MP_N0 / mp_slope(rate_mm_h).powi(3) * 1e-6
}

/// Terminal fall speed of a drop of diameter `d_mm`, m/s (Atlas et al., 1973; 0 below 0.03 mm).
pub fn terminal_speed_mps(d_mm: f64) -> f64 {
    (9.65 - 10.3 * (-0.6 * d_mm).exp()).max(0.0)
}

/// One drop at the middle of the shutter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drop {
    /// Image position of its centre, pixels.
    pub u: f64,
    /// Image position of its centre, pixels.
    pub v: f64,
    /// Depth, metres.
    pub z_m: f64,
    /// Diameter, millimetres.
    pub d_mm: f64,
}

/// The drops in `camera`'s view between [`NEAREST_M`] and [`FARTHEST_M`] at `rate_mm_h`: as
/// many as the volume holds on average, uniform in it, sized by Marshall–Palmer above
/// [`SMALLEST_MM`].
pub fn drops(camera: &PinholeCamera, rate_mm_h: f64, rng: &mut impl Rng) -> Vec<Drop> {
    let slope = mp_slope(rate_mm_h);
    let per_m3 = MP_N0 / slope * (-slope * SMALLEST_MM).exp();
    let (w, h) = (camera.width_px as f64, camera.height_px as f64);
    // The frustum's volume: (w/fx)·(h/fy)·∫z² dz.
    let (z0, z1) = (NEAREST_M, FARTHEST_M);
    let volume = w / camera.fx_px * h / camera.fy_px * (z1.powi(3) - z0.powi(3)) / 3.0;
    let count = (per_m3 * volume).round() as usize;
    (0..count)
        .map(|_| {
            // z with density ∝ z² (the frustum widens), then a uniform image position.
            let t: f64 = rng.random();
            let z_m = (z0.powi(3) + t * (z1.powi(3) - z0.powi(3))).cbrt();
            let u = rng.random::<f64>() * w;
            let v = rng.random::<f64>() * h;
            let e: f64 = rng.random();
            let d_mm = (SMALLEST_MM - (1.0 - e).ln() / slope).min(LARGEST_MM);
            Drop { u, v, z_m, d_mm }
        })
        .collect()
}

/// Below this share of a pixel a drop's streak is not drawn one by one: it joins a uniform veil
/// of its depth band (see [`streaks`]). A drop this faint changes no pixel by more than 0.2 % of
/// the difference between its radiance and the scene's.
pub const VEIL_SHARE: f64 = 2e-3;

/// Depth bands of the veil between [`NEAREST_M`] and [`FARTHEST_M`].
const VEIL_BANDS: usize = 8;

/// The ego's pose at an offset (s) from the middle of the shutter.
pub type EgoAt<'a> = &'a dyn Fn(f64) -> Pose2;

/// The most instants a streak is drawn from (a drop passing close to a fast camera).
const MAX_SAMPLES: usize = 512;

/// A drop's image at one instant of the shutter: centre, disc diameter (pixels), inverse depth.
#[derive(Debug, Clone, Copy)]
struct Instant {
    x: f64,
    y: f64,
    d: f64,
    inv_z: f32,
}

/// The camera during one shutter, from the ego's poses at its opening, middle and closing:
/// position (relative to the middle's, world axes, f64, so a standing camera is exact) and
/// heading (its sine and cosine), linear between those three (over tens of milliseconds the
/// ego's path is straight to well under a millimetre and its heading turns by hundredths of a
/// radian; the heading's vector is renormalised).
#[derive(Debug, Clone, Copy)]
struct ShutterMotion {
    half_s: f64,
    origin: [[f64; 3]; 3],
    heading: [(f64, f64); 3],
}

impl ShutterMotion {
    fn new(camera: &PinholeCamera, ego: EgoAt<'_>, shutter_s: f64) -> Self {
        let half_s = shutter_s / 2.0;
        let on = |q: Pose2| {
            let (s, c) = f64::from(q.yaw).sin_cos();
            let m = camera.mount_m;
            let o =
                [f64::from(q.x) + c * m[0] - s * m[1], f64::from(q.y) + s * m[0] + c * m[1], m[2]];
            (o, (s, c))
        };
        let [(o0, h0), (o1, h1), (o2, h2)] = [-half_s, 0.0, half_s].map(|dt| on(ego(dt)));
        let rel = |o: [f64; 3]| [o[0] - o1[0], o[1] - o1[1], o[2] - o1[2]];
        Self { half_s, origin: [rel(o0), [0.0; 3], rel(o2)], heading: [h0, h1, h2] }
    }

    /// The camera's position relative to the middle's and its heading's (sine, cosine), `dt`
    /// seconds after the middle.
    fn at(&self, dt: f64) -> ([f64; 3], (f64, f64)) {
        let u = if self.half_s > 0.0 { (dt / self.half_s + 1.0).clamp(0.0, 2.0) } else { 1.0 };
        let (k, f) = if u < 1.0 { (0, u) } else { (1, u - 1.0) };
        if f == 0.0 || f == 1.0 {
            let k = k + f as usize;
            return (self.origin[k], self.heading[k]);
        }
        let lerp = |a: f64, b: f64| a + f * (b - a);
        let (a, b) = (self.origin[k], self.origin[k + 1]);
        let o = [lerp(a[0], b[0]), lerp(a[1], b[1]), lerp(a[2], b[2])];
        let ((s0, c0), (s1, c1)) = (self.heading[k], self.heading[k + 1]);
        let (s, c) = (lerp(s0, s1), lerp(c0, c1));
        let norm = (s * s + c * c).sqrt();
        (o, (s / norm, c / norm))
    }
}

/// A drop's path through the image during one shutter.
#[derive(Debug, Clone, Copy)]
struct Path {
    /// The drop's offset from the middle's camera, world axes, metres, at the middle.
    offset: [f64; 3],
    v_fall: f64,
    d_mm: f64,
    /// Its image is taken at the middles of `count` equal parts of the shutter.
    count: usize,
    /// The largest share of a pixel the streak covers, about: the middle disc's area over the
    /// path's swept area.
    peak_share: f64,
}

impl Path {
    fn of(camera: &PinholeCamera, motion: &ShutterMotion, drop: &Drop) -> Self {
        let (_, (s, c)) = motion.at(0.0);
        let (x, y, z) = (
            (drop.u - camera.cx_px) * drop.z_m / camera.fx_px,
            (drop.v - camera.cy_px) * drop.z_m / camera.fy_px,
            drop.z_m,
        );
        // right·x + forward·z (right = (sin, −cos, 0), forward = (cos, sin, 0)); y is down.
        let offset = [s * x + c * z, -c * x + s * z, -y];
        let mut path = Self {
            offset,
            v_fall: terminal_speed_mps(drop.d_mm),
            d_mm: drop.d_mm,
            count: 0,
            peak_share: 0.0,
        };
        let h = motion.half_s;
        let (length, side) = match [-h, h].map(|dt| path.image(camera, motion, dt)) {
            [Some(a), Some(b)] => {
                (((a.x - b.x).powi(2) + (a.y - b.y).powi(2)).sqrt(), a.d.min(b.d).max(1.0))
            }
            _ => (MAX_SAMPLES as f64, 1.0),
        };
        // About one instant per square's side of path (the smallest square's): the squares
        // touch, the light is exact, and the coverage along the streak ripples by up to ~10 %
        // of the streak's own faint share.
        path.count = (((length / side).ceil() as usize) + 1).clamp(2, MAX_SAMPLES);
        let d = camera.fx_px * drop.d_mm * 1e-3 / drop.z_m;
        let w = d.max(1.0);
        path.peak_share = std::f64::consts::FRAC_PI_4 * d * d / (w * (length + w));
        path
    }

    /// The drop's image `dt` seconds after the shutter's middle (none while it is nearer than
    /// `NEAREST_M / 2`).
    fn image(&self, camera: &PinholeCamera, motion: &ShutterMotion, dt: f64) -> Option<Instant> {
        let (o, (s, c)) = motion.at(dt);
        let r = [
            self.offset[0] - o[0],
            self.offset[1] - o[1],
            self.offset[2] - o[2] - self.v_fall * dt,
        ];
        let (x, y, z) = (r[0] * s - r[1] * c, -r[2], r[0] * c + r[1] * s);
        (z >= NEAREST_M / 2.0).then(|| Instant {
            x: camera.cx_px + camera.fx_px * x / z,
            y: camera.cy_px + camera.fy_px * y / z,
            d: camera.fx_px * self.d_mm * 1e-3 / z,
            inv_z: (1.0 / z) as f32,
        })
    }

    /// Its image at the middles of `count` equal parts of the shutter, each carrying `1 / count`
    /// of it (instants where the drop is too near left out).
    fn instants<'a>(
        &'a self,
        camera: &'a PinholeCamera,
        motion: &'a ShutterMotion,
    ) -> impl Iterator<Item = Instant> + 'a {
        let n = self.count as f64;
        (0..self.count).filter_map(move |k| {
            let dt = motion.half_s * (2.0 * (k as f64 + 0.5) / n - 1.0);
            self.image(camera, motion, dt)
        })
    }
}

/// Draws `drop`'s streak over a shutter of `shutter_s` into `target` (radiance `radiance`),
/// where the scene lies behind the drop; `ego` places the camera during the shutter.
pub fn streak(
    target: &mut Target,
    camera: &PinholeCamera,
    ego: EgoAt<'_>,
    drop: &Drop,
    shutter_s: f64,
    radiance: [f32; 3],
) {
    let motion = ShutterMotion::new(camera, ego, shutter_s);
    let path = Path::of(camera, &motion, drop);
    let canvas = (&mut target.colour[..], &target.inv_depth[..], target.width);
    draw(canvas, (camera, &motion, &path), radiance, &mut Shares::default());
}

/// A view's interleaved RGB colour, its inverse depths and its width in pixels.
type Canvas<'a> = (&'a mut [f32], &'a [f32], usize);

/// Per pixel of the view, the share of the shutter the drop being drawn covers it, and the
/// pixels it touched (so that clearing costs what drawing did).
#[derive(Debug, Default)]
struct Shares {
    share: Vec<f32>,
    touched: Vec<u32>,
}

/// Blends the drop's time-averaged image into the pixels it covers: each instant's square (side
/// max(d, 1), the disc's area spread over it, a `1 / count` share of the shutter) adds its
/// overlap to the pixel's share of the shutter the drop covers it, where the scene lies behind
/// the drop at that instant; each pixel is then blended once by its share (light adds over
/// time, so the shares sum before blending).
fn draw(
    (colour, inv_depth, w): Canvas<'_>,
    (camera, motion, path): (&PinholeCamera, &ShutterMotion, &Path),
    radiance: [f32; 3],
    shares: &mut Shares,
) {
    let h = inv_depth.len() / w.max(1);
    shares.share.resize(inv_depth.len(), 0.0);
    for i in path.instants(camera, motion) {
        let side = i.d.max(1.0);
        let density = std::f64::consts::FRAC_PI_4 * i.d * i.d / (side * side) / path.count as f64;
        let (x0, x1, y0, y1) =
            (i.x - side / 2.0, i.x + side / 2.0, i.y - side / 2.0, i.y + side / 2.0);
        let cols = (x0.floor().max(0.0) as usize)..(x1.ceil().min(w as f64) as usize);
        for y in (y0.floor().max(0.0) as usize)..(y1.ceil().min(h as f64) as usize) {
            let oy = (y1.min(y as f64 + 1.0) - y0.max(y as f64)).max(0.0);
            for x in cols.clone() {
                let p = y * w + x;
                if inv_depth[p] > i.inv_z {
                    continue; // the scene is nearer than the drop here
                }
                let ox = (x1.min(x as f64 + 1.0) - x0.max(x as f64)).max(0.0);
                let a = (density * ox * oy) as f32;
                if a > 0.0 {
                    if shares.share[p] == 0.0 {
                        shares.touched.push(p as u32);
                    }
                    shares.share[p] += a;
                }
            }
        }
    }
    for p in shares.touched.drain(..) {
        let p = p as usize;
        let a = std::mem::take(&mut shares.share[p]).min(1.0);
        for (c, r) in colour[p * 3..p * 3 + 3].iter_mut().zip(radiance) {
            *c += a * (r - *c);
        }
    }
}

/// Draws all `drops`' streaks into `colour` (interleaved RGB of `camera`'s view, whose inverse
/// depths are `inv_depth`): each one whose share of a pixel reaches [`VEIL_SHARE`] as
/// [`streak`] does; the fainter ones (most of the far and small drops) as a veil instead — their
/// images' total area, by depth band, spread evenly over the view and blended into every pixel
/// whose scene lies behind the band. The veil keeps the frame's expected light and drops only
/// the sub-0.2 % texture (tested against drawing every drop).
pub fn streaks(
    (colour, inv_depth): (&mut [f32], &[f32]),
    camera: &PinholeCamera,
    ego: EgoAt<'_>,
    drops: &[Drop],
    shutter_s: f64,
    radiance: [f32; 3],
) {
    let band_m = (FARTHEST_M - NEAREST_M) / VEIL_BANDS as f64;
    let mut veil = [0.0f64; VEIL_BANDS];
    let mut shares = Shares::default();
    let motion = ShutterMotion::new(camera, ego, shutter_s);
    for drop in drops {
        let d = camera.fx_px * drop.d_mm * 1e-3 / drop.z_m;
        let area = std::f64::consts::FRAC_PI_4 * d * d;
        // A path only spreads the disc, so a drop below the veil's share standing still is
        // below it on any path: it joins the veil without its path being traced (the same
        // decision `Path::of` would reach, at a fraction of the cost for most drops).
        let w = d.max(1.0);
        if area / (w * w) >= VEIL_SHARE {
            let path = Path::of(camera, &motion, drop);
            if path.peak_share >= VEIL_SHARE {
                let canvas = (&mut *colour, inv_depth, camera.width_px);
                draw(canvas, (camera, &motion, &path), radiance, &mut shares);
                continue;
            }
        }
        let band = (((drop.z_m - NEAREST_M) / band_m) as usize).min(VEIL_BANDS - 1);
        veil[band] += area;
    }
    let pixels = inv_depth.len() as f64;
    // Per band: its share of every pixel, and the inverse depth of its middle.
    let bands: Vec<(f32, f32)> = (0..VEIL_BANDS)
        .map(|b| {
            let z = NEAREST_M + (b as f64 + 0.5) * band_m;
            ((veil[b] / pixels) as f32, (1.0 / z) as f32)
        })
        .collect();
    for (px, &inv_z) in colour.chunks_exact_mut(3).zip(inv_depth) {
        let a: f32 = bands.iter().filter(|b| inv_z <= b.1).map(|b| b.0).sum();
        if a > 0.0 {
            for (c, r) in px.iter_mut().zip(radiance) {
                *c += a * (r - *c);
            }
        }
    }
}

#[cfg(test)]
mod tests;
