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
//! **Streaks.** A drop at depth z is imaged as a disc of d = f_px·D/z pixels that moves down by
//! ℓ = f_px·v·T/z pixels during a shutter of T seconds (the drop's fall; the camera's own motion
//! relative to the drops is not modelled). Its time-averaged image spreads the disc's area
//! (π/4)·d² over the swept rectangle, ℓ + d long and max(d, 1) wide, so each pixel there is
//! blended toward the drop's radiance by its share of that area: a few per cent for a 2 mm drop
//! over a 10 ms shutter (the share is ≈ D/(v·T) whatever the depth), more for short shutters.
//! A drop refracts a wide cone of the scene above and behind the camera (Garg and Nayar, 2004);
//! its radiance is taken as the sky's at 30° elevation. Streaks are drawn for drops from
//! [`NEAREST_M`] to [`FARTHEST_M`] of at least [`SMALLEST_MM`], where the scene lies behind
//! them; farther or smaller drops cover under 1 % of a pixel at the detector's input and act
//! through the extinction only.

use super::Target;
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

/// Where a drop's time-averaged image lies and how much of each pixel it covers.
#[derive(Debug, Clone, Copy)]
struct Swept {
    /// Image diameter, pixels.
    d: f64,
    /// Rectangle swept during the shutter, pixels: left, right, top, bottom.
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    /// Share of a fully covered pixel: the disc's area over the rectangle's.
    density: f64,
}

impl Swept {
    fn of(camera: &PinholeCamera, drop: &Drop, shutter_s: f64) -> Self {
        let d = camera.fx_px * drop.d_mm * 1e-3 / drop.z_m;
        let fall = camera.fy_px * terminal_speed_mps(drop.d_mm) * shutter_s / drop.z_m;
        let (width, length) = (d.max(1.0), fall + d);
        Self {
            d,
            x0: drop.u - width / 2.0,
            x1: drop.u + width / 2.0,
            y0: drop.v - length / 2.0,
            y1: drop.v + length / 2.0,
            // The disc's area spread evenly over the swept rectangle.
            density: std::f64::consts::FRAC_PI_4 * d * d / (width * length),
        }
    }
}

/// Draws `drop`'s streak over a shutter of `shutter_s` into `target` (radiance `radiance`),
/// where the scene lies behind the drop.
pub fn streak(
    target: &mut Target,
    camera: &PinholeCamera,
    drop: &Drop,
    shutter_s: f64,
    radiance: [f32; 3],
) {
    let swept = Swept::of(camera, drop, shutter_s);
    draw((&mut target.colour, &target.inv_depth, target.width), &swept, drop.z_m, radiance);
}

/// A view's interleaved RGB colour, its inverse depths and its width in pixels.
type Canvas<'a> = (&'a mut [f32], &'a [f32], usize);

fn draw((colour, inv_depth, w): Canvas<'_>, s: &Swept, z_m: f64, radiance: [f32; 3]) {
    let inv_z = (1.0 / z_m) as f32;
    let h = inv_depth.len() / w.max(1);
    let cols = (s.x0.floor().max(0.0) as usize)..(s.x1.ceil().min(w as f64) as usize);
    for y in (s.y0.floor().max(0.0) as usize)..(s.y1.ceil().min(h as f64) as usize) {
        let oy = (s.y1.min(y as f64 + 1.0) - s.y0.max(y as f64)).max(0.0);
        for x in cols.clone() {
            let ox = (s.x1.min(x as f64 + 1.0) - s.x0.max(x as f64)).max(0.0);
            let p = y * w + x;
            if inv_depth[p] > inv_z {
                continue; // the scene is nearer than the drop here
            }
            let a = (s.density * ox * oy).min(1.0) as f32;
            for (c, r) in colour[p * 3..p * 3 + 3].iter_mut().zip(radiance) {
                *c += a * (r - *c);
            }
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
    colour: &mut [f32],
    inv_depth: &[f32],
    camera: &PinholeCamera,
    drops: &[Drop],
    shutter_s: f64,
    radiance: [f32; 3],
) {
    let band_m = (FARTHEST_M - NEAREST_M) / VEIL_BANDS as f64;
    let mut veil = [0.0f64; VEIL_BANDS];
    for drop in drops {
        let s = Swept::of(camera, drop, shutter_s);
        if s.density >= VEIL_SHARE {
            draw((&mut *colour, inv_depth, camera.width_px), &s, drop.z_m, radiance);
        } else {
            let band = (((drop.z_m - NEAREST_M) / band_m) as usize).min(VEIL_BANDS - 1);
            veil[band] += std::f64::consts::FRAC_PI_4 * s.d * s.d;
        }
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
mod tests {
    use super::*;
    use joca_core::SeedStreams;

    fn camera(w: usize, h: usize, f_px: f64) -> PinholeCamera {
        PinholeCamera {
            width_px: w,
            height_px: h,
            fx_px: f_px,
            fy_px: f_px,
            cx_px: w as f64 / 2.0,
            cy_px: h as f64 / 2.0,
            mount_m: [0.0, 0.0, 1.5],
            lens: None,
        }
    }

    #[test]
    fn extinction_and_fall_speed_match_their_closed_forms() {
        // β = π·N0/Λ³: at 10 mm/h Λ = 4.1·10^−0.21 = 2.5281 per mm, β = 1.5556e-3 per m.
        let lambda: f64 = 4.1 * 10f64.powf(-0.21);
        assert!((mp_slope(10.0) - lambda).abs() < 1e-12);
        let beta = extinction_per_m(10.0);
        assert!((beta - std::f64::consts::PI * 8000.0 / lambda.powi(3) * 1e-6).abs() < 1e-15);
        assert!((beta - 1.5556e-3).abs() < 1e-7, "{beta}");
        // The visibility ln 20 / β: 1.9 km in moderate rain, under 1 km in a downpour.
        assert!((20f64.ln() / beta - 1925.8).abs() < 0.5);
        assert!(20f64.ln() / extinction_per_m(50.0) < 1000.0);
        // Atlas et al.: 2 mm drops fall at 6.55 m/s, the largest near 9.4 m/s.
        assert!((terminal_speed_mps(2.0) - 6.5477).abs() < 1e-3);
        assert!((terminal_speed_mps(6.0) - 9.3686).abs() < 1e-3);
    }

    #[test]
    fn a_streak_is_as_long_as_the_drop_falls_during_the_shutter() {
        // A 2 mm drop 2 m away, 500 px focal length: d = 0.5 px, v = 6.55 m/s.
        for shutter_s in [5e-3, 20e-3, 40e-3] {
            let cam = camera(40, 400, 500.0);
            let mut t = Target::new(40, 400, 0);
            let drop = Drop { u: 20.5, v: 200.0, z_m: 2.0, d_mm: 2.0 };
            streak(&mut t, &cam, &drop, shutter_s, [1.0; 3]);
            let column: Vec<f32> = (0..400).map(|y| t.colour[(y * 40 + 20) * 3]).collect();
            let peak = column.iter().copied().fold(0.0f32, f32::max);
            // Covered length: the coverage summed along the column over its full value.
            let length = f64::from(column.iter().sum::<f32>() / peak);
            let want = 500.0 * terminal_speed_mps(2.0) * shutter_s / 2.0 + 0.5;
            assert!((length - want).abs() < 0.02 * want + 0.5, "{shutter_s}: {length} vs {want}");
            // Every pixel of it shares the disc's area: (π/4)·d²/(ℓ + d) with width 1 px.
            let share = std::f64::consts::FRAC_PI_4 * 0.25 / want;
            assert!((f64::from(peak) - share).abs() < 1e-6, "{peak} vs {share}");
            // Nothing left or right of the drop's column.
            assert!(t.colour.iter().enumerate().all(|(i, &c)| c == 0.0 || (i / 3) % 40 == 20));
        }
    }

    #[test]
    fn the_veil_of_faint_drops_keeps_the_light_of_drawing_every_drop() {
        // 320 × 240 at 186 px focal length, 25 mm/h, 10 ms: a grey scene 20 m away with a
        // wall 1 m away over its lower third (drops behind the wall are hidden there).
        let cam = camera(320, 240, 186.0);
        let drops = drops(&cam, 25.0, &mut SeedStreams::new(3).stream("rain"));
        let scene = || {
            let mut t = Target::new(320, 240, 0);
            t.colour.iter_mut().for_each(|c| *c = 60.0);
            for (k, d) in t.inv_depth.iter_mut().enumerate() {
                *d = if k / 320 >= 160 { 1.0 } else { 1.0 / 20.0 };
            }
            t
        };
        let radiance = [200.0f32; 3];
        let mut exact = scene();
        for drop in &drops {
            streak(&mut exact, &cam, drop, 10e-3, radiance);
        }
        let mut veiled = scene();
        streaks(&mut veiled.colour, &veiled.inv_depth, &cam, &drops, 10e-3, radiance);
        let drawn =
            drops.iter().filter(|d| Swept::of(&cam, d, 10e-3).density >= VEIL_SHARE).count();
        assert!(
            drawn * 3 < drops.len(),
            "{drawn} of {} drawn: the veil should take most",
            drops.len()
        );
        // The mean light above and below the wall's edge, and every pixel, against the exact one
        // (the difference to the radiance is 140 DN).
        for rows in [0..160usize, 160..240] {
            let mean = |t: &Target| {
                let v: Vec<f32> = rows
                    .clone()
                    .flat_map(|y| (0..320).map(move |x| (y, x)))
                    .map(|(y, x)| t.colour[(y * 320 + x) * 3])
                    .collect();
                f64::from(v.iter().sum::<f32>()) / v.len() as f64
            };
            let (e, v) = (mean(&exact), mean(&veiled));
            assert!(
                (e - v).abs() < 0.02 * (e - 60.0).abs().max(0.05),
                "rows {rows:?}: exact {e}, veiled {v}"
            );
        }
        let worst = exact
            .colour
            .iter()
            .zip(&veiled.colour)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 0.02 * 140.0, "worst pixel differs by {worst} DN");
    }

    #[test]
    fn streaks_stay_behind_nearer_surfaces_and_drops_fill_the_view_alike() {
        let cam = camera(40, 400, 500.0);
        let mut t = Target::new(40, 400, 0);
        // A wall at 1 m over the lower half: a drop at 2 m is hidden there.
        for y in 200..400 {
            for x in 0..40 {
                t.inv_depth[y * 40 + x] = 1.0;
            }
        }
        let drop = Drop { u: 20.5, v: 200.0, z_m: 2.0, d_mm: 2.0 };
        streak(&mut t, &cam, &drop, 40e-3, [1.0; 3]);
        assert!((0..200).any(|y| t.colour[(y * 40 + 20) * 3] > 0.0));
        assert!((200..400).all(|y| t.colour[(y * 40 + 20) * 3] == 0.0));
        // The same rate and seed give the same drops; their count follows the volume.
        let cam = camera(320, 240, 186.0);
        let a = drops(&cam, 10.0, &mut SeedStreams::new(1).stream("rain"));
        assert_eq!(a, drops(&cam, 10.0, &mut SeedStreams::new(1).stream("rain")));
        let slope = mp_slope(10.0);
        let per_m3 = 8000.0 / slope * (-slope * 0.5).exp();
        let volume = 320.0 / 186.0 * 240.0 / 186.0 * (125.0 - 0.027) / 3.0;
        assert_eq!(a.len(), (per_m3 * volume).round() as usize);
        let near = a.iter().filter(|d| d.z_m < (0.3f64.powi(3) / 2.0 + 62.5).cbrt()).count();
        // Half the volume lies nearer than the cube root of the mean of z0³ and z1³.
        assert!((near as f64 / a.len() as f64 - 0.5).abs() < 0.01, "{near} of {}", a.len());
        assert!(a.iter().all(|d| (0.5..=6.0).contains(&d.d_mm)));
    }
}
