//! Fog's glow against closed forms: the isotropic single-scattering integral, the phase
//! function's normalisation, the forward-scattering limit's energy, the box passes' variance.

use super::*;

fn isotropic(_cos: f64) -> f64 {
    1.0 / (4.0 * PI)
}

/// ∫ f(θ) dΩ over the sphere by the midpoint rule in θ.
fn over_sphere(f: impl Fn(f64) -> f64) -> f64 {
    let steps = 20_000;
    let h = PI / steps as f64;
    (0..steps).map(|i| (i as f64 + 0.5) * h).map(|t| 2.0 * PI * t.sin() * f(t) * h).sum()
}

#[test]
fn the_phase_function_integrates_to_one() {
    for g in [0.0, 0.5, FOG_ASYMMETRY] {
        let total = over_sphere(|t| henyey_greenstein(g, t.cos()));
        assert!((total - 1.0).abs() < 1e-3, "g {g}: {total}");
    }
}

#[test]
fn isotropic_thin_fog_glows_as_the_closed_form() {
    // T → 0, p = 1/4π: L(θ)/(T·I/d²) = ∫₀^∞ dx / (x² + 1 − 2x cos θ) / 4π = (π − θ)/(4π sin θ).
    let depth = 1e-7;
    for theta in [0.01, 0.3, 1.0, 2.0] {
        let got = glow_profile(theta, depth, isotropic) / depth;
        let want = (PI - theta) / (4.0 * PI * theta.sin());
        assert!((got / want - 1.0).abs() < 1e-3, "θ {theta}: {got} vs {want}");
    }
    // Its energy over the sphere is π²/4 times T: isotropic scattering from the whole volume,
    // behind the source included (∫ d³x / (|x − a|²·|x − b|²) = π³/|a − b|).
    let energy = over_sphere(|t| glow_profile(t, depth, isotropic)) / depth;
    let want = PI * PI / 4.0;
    assert!((energy / want - 1.0).abs() < 5e-3, "{energy} vs {want}");
}

#[test]
fn forward_scattering_glows_with_t_times_the_transmitted_light() {
    // g → 1: every scattered photon keeps its direction, so it arrives as attenuated as the
    // direct beam: the glow's energy is T times the transmitted light (single scattering).
    let phase = |c: f64| henyey_greenstein(0.99, c);
    for depth in [0.1, 0.5, 1.0] {
        let energy = over_sphere(|t| glow_profile(t, depth, phase));
        assert!((energy / depth - 1.0).abs() < 0.03, "T {depth}: {energy}");
    }
    // Attenuation of the longer paths: fog's wider halo carries less than T at depth, more than
    // the forward limit's T·(its share of small angles) would lose at T → 0.
    let fog = |c: f64| henyey_greenstein(FOG_ASYMMETRY, c);
    let thin = over_sphere(|t| glow_profile(t, 1e-4, fog)) / 1e-4;
    let deep = over_sphere(|t| glow_profile(t, 2.0, fog)) / 2.0;
    assert!(thin > 1.0 && deep < thin, "{thin} {deep}");
}

#[test]
fn the_gaussians_hold_the_halo_within_the_fitted_range() {
    let fog = |c: f64| henyey_greenstein(FOG_ASYMMETRY, c);
    for depth in [0.25, 1.0, 3.0] {
        let profile = |t: f64| glow_profile(t, depth, fog);
        let a = fit_gaussians(profile);
        // Planar energy within 1.5 rad: the profile's against the fit's.
        let steps = 30_000;
        let h = 1.5 / steps as f64;
        let want: f64 =
            (0..steps).map(|i| (i as f64 + 0.5) * h).map(|t| 2.0 * PI * t * profile(t) * h).sum();
        let got: f64 = a.iter().sum();
        assert!((got / want - 1.0).abs() < 0.03, "T {depth}: {got} vs {want}");
        // Pointwise where the halo is seen (1 mrad to 0.5 rad).
        let sigmas = sigmas_rad();
        for theta in [1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 0.5] {
            let fit: f64 = a.iter().zip(sigmas).map(|(a, s)| a * gaussian(theta, s)).sum();
            let exact = profile(theta);
            assert!((fit / exact - 1.0).abs() < 0.15, "T {depth} θ {theta}: {fit} vs {exact}");
        }
    }
}

#[test]
fn three_extended_box_passes_spread_a_point_by_sigma_and_keep_its_light() {
    let (w, h) = (161, 161);
    for sigma in [0.5, 0.8, 2.0, 7.5, 20.0] {
        let mut plane = vec![0.0f32; w * h];
        plane[80 * w + 80] = 1.0;
        gaussian_blur(&mut plane, w, h, sigma);
        let total: f64 = plane.iter().map(|&v| f64::from(v)).sum();
        let var: f64 = plane
            .iter()
            .enumerate()
            .map(|(i, &v)| f64::from(v) * ((i % w) as f64 - 80.0).powi(2))
            .sum::<f64>()
            / total;
        assert!((total - 1.0).abs() < 1e-4, "σ {sigma}: {total}");
        assert!((var.sqrt() / sigma - 1.0).abs() < 1e-3, "σ {sigma}: {}", var.sqrt());
    }
}

/// A `w × h` view with focal length `f` px, everything at `depth_m`, black, one bright pixel.
fn lamp_scene(w: usize, h: usize, depth_m: f32, lamp: f32) -> (Vec<f32>, Vec<f32>, PinholeCamera) {
    let mut colour = vec![0.0f32; w * h * 3];
    let centre = (h / 2) * w + w / 2;
    colour[centre * 3..centre * 3 + 3].copy_from_slice(&[lamp; 3]);
    let cam = PinholeCamera::centred((w, h), (400.0, 400.0), [0.0, 0.0, 1.5]);
    (colour, vec![1.0 / depth_m; w * h], cam)
}

#[test]
fn a_lamp_glows_as_the_single_scattering_profile_says() {
    let (w, h) = (301, 301);
    // 20 m away in fog of 100 m visibility: β = ln 20 / 100, T ≈ 0.6.
    let (beta, d) = (20f64.ln() / 100.0, 20.0);
    let (mut colour, inv_depth, cam) = lamp_scene(w, h, d as f32, 1000.0);
    fog_glow(&mut colour, &inv_depth, (w, h), &cam, (beta, [0.0; 3]));
    let fog = |c: f64| henyey_greenstein(FOG_ASYMMETRY, c);
    let depth = beta * d;
    // Radiance at r pixels to the right: 1000 DN · Ω_px · G(r / f).
    let at = |r: usize| f64::from(colour[((h / 2) * w + w / 2 + r) * 3]);
    for r in [3, 10, 40, 120] {
        let theta = r as f64 / 400.0;
        let want = 1000.0 / (400.0 * 400.0) * glow_profile(theta, depth, fog);
        assert!((at(r) / want - 1.0).abs() < 0.2, "r {r}: {} vs {want}", at(r));
    }
    // The halo around the lamp: its energy is the fit's for this depth, less what leaves the
    // frame (±150 px at 400 px focal length: ±0.36 rad).
    let halo: f64 = colour.iter().step_by(3).map(|&v| f64::from(v)).sum::<f64>() - 1000.0;
    let at = table_row(depth as f32);
    let a: f64 = (0..GAUSSIANS).map(|k| f64::from(weight(table(), at, k))).sum();
    assert!(halo > 0.7 * 1000.0 * a && halo < 1000.0 * a, "{halo} vs {}", 1000.0 * a);
}

#[test]
fn only_light_above_the_airlight_glows() {
    let (w, h) = (64, 48);
    let cam = PinholeCamera::centred((w, h), (60.0, 60.0), [0.0, 0.0, 1.5]);
    let airlight = [150.0, 160.0, 170.0];
    // A frame at the airlight, and the sky (no depth) far above it: nothing changes.
    let mut flat: Vec<f32> = (0..w * h).flat_map(|_| airlight).collect();
    let before = flat.clone();
    fog_glow(&mut flat, &vec![0.05; w * h], (w, h), &cam, (0.03, airlight));
    assert_eq!(flat, before);
    let mut sky = vec![5000.0f32; w * h * 3];
    let before = sky.clone();
    fog_glow(&mut sky, &vec![0.0; w * h], (w, h), &cam, (0.03, airlight));
    assert_eq!(sky, before);
    // The glow is linear in the light above the airlight and repeats exactly.
    let (one, inv_depth, cam) = lamp_scene(81, 61, 15.0, 500.0);
    let glow_of = |scale: f32| {
        let mut c: Vec<f32> = one.iter().map(|v| v * scale).collect();
        fog_glow(&mut c, &inv_depth, (81, 61), &cam, (0.02, [0.0; 3]));
        c
    };
    let (a, b) = (glow_of(1.0), glow_of(2.0));
    assert_eq!(a, glow_of(1.0));
    for (x, y) in a.iter().zip(&b) {
        assert!((2.0 * x - y).abs() <= 1e-4 * y.abs().max(1.0), "{x} {y}");
    }
}

#[test]
fn a_wide_gaussian_on_the_pyramid_is_the_full_resolution_one() {
    let (w, h) = (160, 120);
    for (sigma, at) in [(10.0, (80, 60)), (25.0, (37, 90)), (50.0, (121, 33))] {
        let point = |p: usize| if p == at.1 * w + at.0 { 1000.0f32 } else { 0.0 };
        let mut full: Vec<f32> = (0..w * h).map(point).collect();
        gaussian_blur(&mut full, w, h, sigma);
        assert!(blur::level_for(sigma, h) >= 1, "σ {sigma}: full resolution");
        let pyramid = blur::gaussians_of_one_source(&point, sigma, (w, h));
        let (sum_f, sum_p): (f32, f32) = (full.iter().sum(), pyramid.iter().sum());
        assert!((sum_p / sum_f - 1.0).abs() < 0.02, "σ {sigma}: {sum_p} vs {sum_f}");
        let peak = full.iter().copied().fold(0.0, f32::max);
        // Within the frame's last grid pixels the doubling back holds the edge's value (the
        // light there falls toward the zero outside): up to 6 % of the peak at σ 50, 11 % of
        // the local value, over the last 2 px; inside, within 5 % of the peak.
        let (mut inside, mut edge) = (0.0f32, 0.0f32);
        for (i, (a, b)) in full.iter().zip(&pyramid).enumerate() {
            let (x, y) = (i % w, i / w);
            let border = x < 4 || y < 4 || x >= w - 4 || y >= h - 4;
            let e = if border { &mut edge } else { &mut inside };
            *e = e.max((a - b).abs());
        }
        assert!(inside < 0.05 * peak, "σ {sigma}: {inside} of peak {peak}");
        assert!(edge < 0.07 * peak, "σ {sigma}: {edge} of peak {peak} at the edge");
    }
}
