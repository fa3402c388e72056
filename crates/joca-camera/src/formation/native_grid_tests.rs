//! Formation on a sensor's native grid carried to the detector's input, checked against the
//! unshortened model: every native pixel formed by Eq. 2–3 with its own noise, then the frame
//! resized explicitly. The expected per-pixel `Σw²` is written out here from PyTorch's and the
//! area mean's definitions, independently of `input.rs`.

use super::tests::normal_cdf;
use super::*;
use joca_core::SeedStreams;

fn flat(width: usize, height: usize, value: f32) -> HdrImage {
    HdrImage::from_vec(width, height, vec![value; width * height * 3]).unwrap()
}

/// `Σw²` along one axis at output `d`, resizing `n_in` to `n_out`.
fn expected_factor(resampler: Resampler, n_in: usize, n_out: usize, d: usize) -> f64 {
    let r = n_in as f64 / n_out as f64;
    match resampler {
        Resampler::Bilinear => {
            // torch: src = max(r·(d + ½) − ½, 0); the upper tap is clamped to the last sample.
            let src = (r * (d as f64 + 0.5) - 0.5).max(0.0);
            if src >= (n_in - 1) as f64 {
                return 1.0;
            }
            let l = src - src.floor();
            (1.0 - l).powi(2) + l.powi(2)
        }
        Resampler::Area => {
            // Overlap of [d·r, (d+1)·r) with each unit cell, normalised by r.
            let (a, b) = (d as f64 * r, (d + 1) as f64 * r);
            (0..n_in)
                .map(|i| ((b.min(i as f64 + 1.0) - a.max(i as f64)).max(0.0) / r).powi(2))
                .sum()
        }
    }
}

/// Eq. 3's variance of one native pixel of a flat field at `level` DN, channel `c`, at E0, G0.
fn native_variance(level: f64, noise: f64, c: usize) -> f64 {
    noise * (Calibration::DEFAULT.sigma_p2[c] * level + Calibration::DEFAULT.sigma_r2[c])
}

struct Pooled {
    /// Per class of expected factor: (Σ (v − μ)², count).
    classes: Vec<(f64, f64, usize)>,
    sum: f64,
    count: usize,
}

impl Pooled {
    fn new() -> Self {
        Self { classes: Vec::new(), sum: 0.0, count: 0 }
    }

    fn add(&mut self, factor: f64, value: f64, mean: f64) {
        self.sum += value;
        self.count += 1;
        let key = (factor * 1e6).round() / 1e6;
        match self.classes.iter_mut().find(|(k, _, _)| *k == key) {
            Some(class) => {
                class.1 += (value - mean).powi(2);
                class.2 += 1;
            }
            None => self.classes.push((key, (value - mean).powi(2), 1)),
        }
    }

    fn mean(&self) -> f64 {
        self.sum / self.count as f64
    }
}

/// Both paths over `frames` flat frames: the explicit one (native formation, then the resize)
/// and the shortcut (formation at the input with the native grid's noise gain). Returns the
/// pooled statistics of channel `c`, explicit first; `linear` compares before clipping and
/// rounding.
fn both_paths(
    resampler: Resampler,
    native: (usize, usize),
    input: (usize, usize),
    (level, noise, c): (f32, f64, usize),
    linear: bool,
    frames: usize,
) -> (Pooled, Pooled) {
    let base = ImageFormation::new(Calibration::DEFAULT).unwrap().with_noise_scale(noise).unwrap();
    let shortcut = base.with_resampler(resampler).on_native_grid(native.0, native.1);
    let s = DynamicSettings::new(5e-3, 10.0);
    let streams = SeedStreams::new(23);
    let (big, small) = (flat(native.0, native.1, level), flat(input.0, input.1, level));
    let (mut explicit, mut short) = (Pooled::new(), Pooled::new());
    let mu = f64::from(level);
    for f in 0..frames as u64 {
        let (native_frame, input_frame): (Vec<f32>, Vec<f32>) = if linear {
            (
                base.form_linear(&big, s, 3.75, &mut streams.indexed("n", f)).data().to_vec(),
                shortcut.form_linear(&small, s, 3.75, &mut streams.indexed("s", f)).data().to_vec(),
            )
        } else {
            let to_f32 = |img: Rgb8Image| img.data().iter().map(|&v| f32::from(v)).collect();
            (
                to_f32(base.form(&big, s, 3.75, &mut streams.indexed("n", f))),
                to_f32(shortcut.form(&small, s, 3.75, &mut streams.indexed("s", f))),
            )
        };
        let resized = resampler.resize(&native_frame, native, input, 3);
        for y in 0..input.1 {
            for x in 0..input.0 {
                let factor = expected_factor(resampler, native.0, input.0, x)
                    * expected_factor(resampler, native.1, input.1, y);
                let k = (y * input.0 + x) * 3 + c;
                explicit.add(factor, f64::from(resized[k]), mu);
                short.add(factor, f64::from(input_frame[k]), mu);
            }
        }
    }
    (explicit, short)
}

/// A resize case: its name, the native grid and the input, `(width, height)` px.
type Case = (&'static str, (usize, usize), (usize, usize));

const CASES: [Case; 3] = [
    // r = 10.25: a large downscale whose bilinear taps fall at four fractions.
    ("large downscale", (410, 328), (40, 32)),
    // r = 1.5: a small one, where area footprints share native pixels.
    ("small downscale", (120, 96), (80, 64)),
    // r = 0.5: an upscale from a grid smaller than the input.
    ("upscale", (40, 32), (80, 64)),
];

/// Per-pixel noise variance at 30 and 120 DN, calibrated and ×20: within 10 % of the explicit
/// path and of Eq. 3 × Σw², in every class of pixels that share a factor and hold ≥ 2,000
/// samples (together ≥ 90 % of the pixels; the rest are the few edge pixels whose taps clamp),
/// for both resamplers and the three kinds of resize.
#[test]
fn input_noise_matches_native_formation_then_resize() {
    for resampler in [Resampler::Bilinear, Resampler::Area] {
        for (name, native, input) in CASES {
            for (level, noise, c) in [(30.0, 1.0, 0), (120.0, 1.0, 1), (120.0, 20.0, 2)] {
                let (explicit, short) =
                    both_paths(resampler, native, input, (level, noise, c), true, 30);
                let var = native_variance(f64::from(level), noise, c);
                let big = |class: &&(f64, f64, usize)| class.2 >= 2000;
                let covered: usize = explicit.classes.iter().filter(big).map(|c| c.2).sum();
                assert!(covered * 10 >= explicit.count * 9, "{name}: {covered} compared");
                for (e, s) in explicit.classes.iter().zip(&short.classes).filter(|(e, _)| big(e)) {
                    assert_eq!(e.0, s.0);
                    let (ve, vs) = (e.1 / e.2 as f64, s.1 / s.2 as f64);
                    let want = var * e.0;
                    let what = format!("{resampler} {name} {level} DN ×{noise} Σw² {}", e.0);
                    assert!((vs / ve - 1.0).abs() < 0.1, "{what}: shortcut {vs} vs explicit {ve}");
                    assert!((vs / want - 1.0).abs() < 0.1, "{what}: shortcut {vs} vs Eq. 3 {want}");
                }
            }
        }
    }
}

/// The 8-bit frames' means at 30 and 120 DN agree within 0.05 DN; near 0 and 255 the explicit
/// path carries the bias of clipping every native pixel (closed form for a clipped normal),
/// which the shortcut, clipping the input pixel's smaller noise once, mostly does not.
#[test]
fn input_means_match_and_clipping_differs_as_stated() {
    let phi = |t: f64| (-t * t / 2.0).exp() / (2.0 * std::f64::consts::PI).sqrt();
    for resampler in [Resampler::Bilinear, Resampler::Area] {
        for (name, native, input) in CASES {
            for level in [30.0f32, 120.0] {
                let (e, s) = both_paths(resampler, native, input, (level, 1.0, 1), false, 40);
                let what = format!("{resampler} {name} {level} DN");
                assert!((e.mean() - s.mean()).abs() < 0.05, "{what}: {} {}", e.mean(), s.mean());
                assert!((s.mean() - f64::from(level)).abs() < 0.05, "{what}: {}", s.mean());
            }
        }
        // A large downscale at 2 DN and 252 DN, noise ×20 (σ ≈ 2.8 and 10.8 DN per native pixel).
        let (native, input) = (CASES[0].1, CASES[0].2);
        for level in [2.0f32, 252.0] {
            let (e, s) = both_paths(resampler, native, input, (level, 20.0, 1), false, 10);
            let mu = f64::from(level);
            let sd = native_variance(mu, 20.0, 1).sqrt();
            let tail = |t: f64| sd * (phi(t) - t * normal_cdf(-t));
            let clipped = mu + tail(mu / sd) - tail((255.0 - mu) / sd);
            let what = format!("{resampler} {level} DN");
            assert!((e.mean() - clipped).abs() < 0.1, "{what}: explicit {} vs {clipped}", e.mean());
            // The shortcut's clipping acts on a narrower distribution: its bias is smaller.
            assert!((s.mean() - mu).abs() < (clipped - mu).abs(), "{what}: {}", s.mean());
        }
    }
}
