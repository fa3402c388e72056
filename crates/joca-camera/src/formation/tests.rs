//! Checks of image formation against the paper's equations, written out independently here.

use super::*;
use joca_core::SeedStreams;

const CAL: Calibration = Calibration::DEFAULT;

fn flat(width: usize, height: usize, value: f32) -> HdrImage {
    HdrImage::from_vec(width, height, vec![value; width * height * 3]).unwrap()
}

/// Eq. 2 and Eq. 3 evaluated directly in f64 from the calibration constants.
fn expected_mean_var(i0: f64, s: DynamicSettings, p_um: f64, n: f64, c: usize) -> (f64, f64) {
    let g = 10f64.powf(s.gain_db / 20.0) / 10f64.powf(CAL.gain_db / 20.0);
    let i = i0 * (s.exposure_s / CAL.exposure_s) * g * (p_um / CAL.pixel_pitch_um).powi(2);
    (i, g * CAL.sigma_p2[c] * n * i + g * g * CAL.sigma_r2[c] * n)
}

fn channel_stats(img: &HdrImage, c: usize) -> (f64, f64, usize) {
    let v: Vec<f64> = img.data().iter().skip(c).step_by(3).map(|&x| f64::from(x)).collect();
    let n = v.len();
    let mean = v.iter().sum::<f64>() / n as f64;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    (mean, var, n)
}

#[test]
fn noise_mean_and_variance_follow_eq3_at_many_levels() {
    let formation = ImageFormation::new(CAL).unwrap();
    let streams = SeedStreams::new(11);
    let cases = [
        (DynamicSettings::new(5e-3, 10.0), 3.75), // the calibration point itself
        (DynamicSettings::new(2e-3, 24.0), 5.86), // shorter, more gain, bigger pixels
        (DynamicSettings::new(30e-3, 1.0), 1.55), // long exposure, small pixels
    ];
    for (k, (settings, pitch)) in cases.into_iter().enumerate() {
        for (level, i0) in [0.5f32, 5.0, 20.0, 60.0, 120.0, 200.0].into_iter().enumerate() {
            let img = flat(200, 100, i0);
            let mut rng = streams.indexed("noise", (k * 10 + level) as u64);
            let out = formation.form_linear(&img, settings, pitch, &mut rng);
            for c in 0..3 {
                let (want_mean, want_var) =
                    expected_mean_var(f64::from(i0), settings, pitch, 1.0, c);
                let (mean, var, n) = channel_stats(&out, c);
                // Standard errors of the sample mean and (Gaussian) sample variance; 5 of them
                // leave a false-alarm rate below 1e-6 per comparison.
                let se_mean = (want_var / n as f64).sqrt();
                let se_var = want_var * (2.0 / (n as f64 - 1.0)).sqrt();
                assert!(
                    (mean - want_mean).abs() < 5.0 * se_mean + 1e-4 * want_mean,
                    "case {k} level {i0} ch {c}: mean {mean} vs {want_mean}"
                );
                assert!(
                    (var - want_var).abs() < 5.0 * se_var,
                    "case {k} level {i0} ch {c}: var {var} vs {want_var}"
                );
            }
        }
    }
}

#[test]
fn noise_scale_multiplies_both_variances() {
    let formation = ImageFormation::new(CAL).unwrap().with_noise_scale(20.0).unwrap();
    let settings = DynamicSettings::new(5e-3, 10.0);
    let out = formation.form_linear(
        &flat(300, 100, 40.0),
        settings,
        3.75,
        &mut SeedStreams::new(3).stream("n"),
    );
    for c in 0..3 {
        let (_, want_var) = expected_mean_var(40.0, settings, 3.75, 20.0, c);
        let (_, var, n) = channel_stats(&out, c);
        assert!((var - want_var).abs() < 5.0 * want_var * (2.0 / n as f64).sqrt(), "ch {c}");
    }
}

#[test]
fn without_noise_formation_is_eq2_exactly() {
    let formation = ImageFormation::new(CAL).unwrap().with_noise_scale(0.0).unwrap();
    let img = flat(8, 20, 37.0);
    let mut rng = SeedStreams::new(1).stream("n");
    // Twice the exposure, +6.0206 dB (×2) gain, twice the pitch (×4 area): ×16.
    let s = DynamicSettings::new(10e-3, 10.0 + 20.0 * 2f64.log10());
    let out = formation.form_linear(&img, s, 7.5, &mut rng);
    for &v in out.data() {
        assert!((v - 37.0 * 16.0).abs() < 1e-3, "{v}");
    }
}

/// Abramowitz & Stegun 7.1.26 (|error| < 1.5e-7): an independent reference for Φ.
pub(super) fn normal_cdf(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs() / std::f64::consts::SQRT_2);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-(x * x) / 2.0).exp();
    if x >= 0.0 { 0.5 * (1.0 + erf) } else { 0.5 * (1.0 - erf) }
}

#[test]
fn clipping_at_zero_and_at_the_white_level() {
    let formation = ImageFormation::new(CAL).unwrap();
    let s = DynamicSettings::new(5e-3, 10.0);
    let mut rng = SeedStreams::new(5).stream("clip");
    // Far above white: every value saturates at exactly 255.
    let bright = formation.form(&flat(64, 64, 2000.0), s, 3.75, &mut rng);
    assert!(bright.data().iter().all(|&v| v == 255));
    // Black input: out = round(max(0, σr·z)), so P(out = 0) = Φ(0.5/σr) per channel.
    let dark = formation.form(&flat(256, 256, 0.0), s, 3.75, &mut rng);
    for c in 0..3 {
        let zeros = dark.data().iter().skip(c).step_by(3).filter(|&&v| v == 0).count();
        let n = 256 * 256;
        let p = normal_cdf(0.5 / CAL.sigma_r2[c].sqrt());
        let frac = zeros as f64 / n as f64;
        let se = (p * (1.0 - p) / n as f64).sqrt();
        assert!((frac - p).abs() < 5.0 * se, "ch {c}: {frac} vs {p}");
    }
    // Exactly at the white level half the noise is clipped away: P(out = 255) = Φ(0.5/σ) and
    // the mean drops to E[min(255, 255 + σz)] = 255 − σ/√(2π) (up to rounding, < 0.01 DN here).
    let edge = formation.form(&flat(256, 256, 255.0), s, 3.75, &mut rng);
    for c in 0..3 {
        let sigma = (CAL.sigma_p2[c] * 255.0 + CAL.sigma_r2[c]).sqrt();
        let values: Vec<f64> =
            edge.data().iter().skip(c).step_by(3).map(|&v| f64::from(v)).collect();
        let n = values.len() as f64;
        let p = normal_cdf(0.5 / sigma);
        let frac = values.iter().filter(|&&v| v == 255.0).count() as f64 / n;
        assert!((frac - p).abs() < 5.0 * (p * (1.0 - p) / n).sqrt(), "ch {c}: {frac} vs {p}");
        let mean = values.iter().sum::<f64>() / n;
        let want = 255.0 - sigma / (2.0 * std::f64::consts::PI).sqrt();
        assert!((mean - want).abs() < 5.0 * sigma / n.sqrt() + 0.02, "ch {c}: {mean} vs {want}");
    }
}

#[test]
fn quantisation_rounds_to_nearest() {
    let formation = ImageFormation::new(CAL).unwrap().with_noise_scale(0.0).unwrap();
    let s = DynamicSettings::new(5e-3, 10.0);
    let mut rng = SeedStreams::new(5).stream("q");
    for (i0, want) in [(10.49f32, 10u8), (10.51, 11), (0.4, 0), (254.6, 255)] {
        let out = formation.form(&flat(2, 2, i0), s, 3.75, &mut rng);
        assert!(out.data().iter().all(|&v| v == want), "{i0} -> {:?}", out.data());
    }
}

#[test]
fn parallel_equals_sequential_and_normals_reproduce_the_frame() {
    let formation = ImageFormation::new(CAL).unwrap();
    let s = DynamicSettings::new(7e-3, 14.0);
    let mut img = HdrImage::zeros(97, 53);
    for (i, v) in img.data_mut().iter_mut().enumerate() {
        *v = (i % 251) as f32;
    }
    let streams = SeedStreams::new(9);
    let a = formation.form(&img, s, 2.4, &mut streams.stream("f"));
    let b = formation.form_parallel(&img, s, 2.4, &mut streams.stream("f"));
    assert_eq!(a, b);

    let seed: u64 = streams.stream("f").random();
    let z = ImageFormation::standard_normals(97, 53, seed);
    assert_eq!(formation.input_normals(97, 53, seed), z);
    assert_eq!(formation.form_with_normals(&img, s, 2.4, &z), a);
    // On a native grid the input normals carry the resize's gain, and still reproduce the frame.
    let on_grid = formation.on_native_grid(1000, 530);
    let zg = on_grid.input_normals(97, 53, seed);
    let a_grid = on_grid.form(&img, s, 2.4, &mut streams.stream("f"));
    assert_eq!(on_grid.form_with_normals(&img, s, 2.4, &zg), a_grid);
    assert_eq!(on_grid.form_parallel(&img, s, 2.4, &mut streams.stream("f")), a_grid);
    assert_ne!(a_grid, a);
    let linear = formation.form_linear(&img, s, 2.4, &mut streams.stream("f"));
    let p = formation.params(s, 2.4);
    for (k, ((&i0, &zk), &lin)) in img.data().iter().zip(&z).zip(linear.data()).enumerate() {
        let c = k % 3;
        let i = i0 * p.intensity_scale;
        let sigma = (p.photon_var_per_dn[c] * i + p.read_var[c]).sqrt();
        assert!((i + sigma * zk - lin).abs() < 1e-3 * (1.0 + i), "{k}");
        let q = (i + sigma * zk).clamp(0.0, 255.0).round() as u8;
        assert!(q.abs_diff(a.data()[k]) <= 1, "{k}");
    }
}

#[test]
fn bad_calibration_names_the_field() {
    let mut c = CAL;
    c.sigma_r2[1] = -1.0;
    let e = ImageFormation::new(c).unwrap_err().to_string();
    assert!(e.contains("calibration.sigma_r2"), "{e}");
    assert!(ImageFormation::new(CAL).unwrap().with_noise_scale(f64::NAN).is_err());
}

#[test]
fn opening_the_aperture_scales_the_signal_by_the_inverse_square_of_the_f_number() {
    // f/2 against the calibration's f/16 at the same exposure and gain: 64× the light, and
    // Eq. 3's photon noise from that larger signal (the read noise unchanged).
    let settings = DynamicSettings::new(0.2e-3, 10.0);
    let open = ImageFormation::new(CAL).unwrap().with_f_number(2.0).unwrap();
    let out = open.form_linear(
        &flat(300, 100, 1.5),
        settings,
        3.75,
        &mut SeedStreams::new(5).stream("n"),
    );
    for c in 0..3 {
        let (base_mean, _) = expected_mean_var(1.5, settings, 3.75, 1.0, c);
        let want_mean = 64.0 * base_mean;
        let g = 1.0; // gain = G0
        let want_var = g * CAL.sigma_p2[c] * want_mean + g * g * CAL.sigma_r2[c];
        let (mean, var, n) = channel_stats(&out, c);
        assert!((mean - want_mean).abs() < 5.0 * (want_var / n as f64).sqrt(), "ch {c}: {mean}");
        assert!((var - want_var).abs() < 5.0 * want_var * (2.0 / n as f64).sqrt(), "ch {c}");
    }
    let f16 = ImageFormation::new(CAL).unwrap().with_f_number(16.0).unwrap();
    assert_eq!(f16, ImageFormation::new(CAL).unwrap());
    let e = ImageFormation::new(CAL).unwrap().with_f_number(0.5).unwrap_err().to_string();
    assert!(e.contains("f_number") && e.contains("32"), "{e}");
}
