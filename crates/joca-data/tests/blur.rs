//! Flow-based motion blur against the closed-form box-filtered profile of a moving square.
#![allow(clippy::unwrap_used)]

use joca_core::HdrImage;
use joca_data::blur::motion_blur;
use joca_data::flow::Flow;

/// ∫ of the ramp r(t) = max(t, 0).
fn ramp_integral(t: f64) -> f64 {
    let t = t.max(0.0);
    t * t / 2.0
}

/// Antiderivative of the square's row profile as the bilinear sampler sees it: value `v` on
/// pixels 20..=39, linear ramps between pixel centres 19→20 and 39→40, zero elsewhere.
fn profile_integral(s: f64, v: f64) -> f64 {
    v * (ramp_integral(s - 19.0) - ramp_integral(s - 20.0) - ramp_integral(s - 39.0)
        + ramp_integral(s - 40.0))
}

#[test]
fn a_square_moving_at_known_velocity_gets_the_box_filtered_profile() {
    let (w, h, v) = (64, 32, 100.0f32);
    let mut img = HdrImage::zeros(w, h);
    for y in 8..24 {
        for x in 20..40 {
            img.set_pixel(x, y, [v, v / 2.0, v / 4.0]);
        }
    }
    // The scene moves 4 px per frame interval; a shutter of 1.5 intervals smears it over 6 px.
    let flow = Flow::new(w, h, vec![[4.0, 0.0]; w * h]);
    let out = motion_blur(&img, &flow, 1.5);
    let d = 6.0;
    let mut worst = 0.0f64;
    for x in 0..w {
        // B(x) = (1/d) ∫_{x-d/2}^{x+d/2} f(s) ds, the box filter of length d along the motion.
        let expect = (profile_integral(x as f64 + d / 2.0, f64::from(v))
            - profile_integral(x as f64 - d / 2.0, f64::from(v)))
            / d;
        let got = f64::from(out.pixel(x, 16)[0]);
        worst = worst.max((got - expect).abs());
        // Other channels scale with their value; rows away from the square stay black.
        assert!((f64::from(out.pixel(x, 16)[1]) - got / 2.0).abs() < 1e-3);
        assert_eq!(out.pixel(x, 2), [0.0; 3]);
    }
    // 13 midpoint samples over 6 px: the only error is at the profile's kinks.
    assert!(worst < 0.01 * f64::from(v), "largest deviation {worst:.3} of {v}");
    // Energy is conserved along the row (the smear stays inside the image).
    let sum_in: f32 = (0..w).map(|x| img.pixel(x, 16)[0]).sum();
    let sum_out: f32 = (0..w).map(|x| out.pixel(x, 16)[0]).sum();
    assert!((sum_in - sum_out).abs() < 1e-2 * sum_in, "{sum_in} vs {sum_out}");
}
