//! Tests of the patch search against its definitions.

use super::*;

fn image(w: usize, h: usize) -> Gray {
    let v = |x: f32, y: f32| 128.0 + 60.0 * (0.37 * x).sin() * (0.23 * y + 0.5).cos() + 0.7 * x;
    Gray::new(w, h, (0..w * h).map(|i| v((i % w) as f32, (i / w) as f32)).collect())
}

/// The whole-patch sampler against per-pixel bilinear sampling with clamped coordinates
/// (the unshortened computation), at offsets inside the image and reaching into the border.
#[test]
fn a_patch_equals_its_pixels_sampled_one_by_one() {
    let img = image(40, 30);
    let padded = Padded::new(&img, 16);
    let mut out = vec![0.0; 64];
    for &(x, y) in &[(3.25f32, 4.5f32), (0.0, 0.0), (-5.7, 2.1), (35.4, 25.9), (31.999, -0.001)] {
        padded.patch(x, y, 8, &mut out);
        for j in 0..8 {
            for i in 0..8 {
                let want = img.sample(x + i as f32, y + j as f32);
                let got = out[j * 8 + i];
                assert!((got - want).abs() < 1e-3, "({x}, {y}) + ({i}, {j}): {got} vs {want}");
            }
        }
    }
}

/// The one-pass distance and update against the two-pass mean-normalised residual:
/// `Σ (r − r̄)²` and `Σ (r − r̄) ∇I` with `r = I1(x + u) − I0(x)`.
#[test]
fn the_one_pass_sums_equal_the_mean_normalised_residual() {
    let (i0, i1) = (image(40, 30), image(40, 30));
    let (gx, gy) = i0.sobel();
    let t = Template::new(&i0, &gx, &gy, (10, 7), 8);
    let padded = Padded::new(&i1, 16);
    let mut buf = Vec::new();
    for u in [[0.3f32, -0.6f32], [2.5, 1.25], [-1.0, 0.0]] {
        let (ssd, [bx, by]) = t.at(&padded, u, &mut buf);
        let r: Vec<f32> = (0..64)
            .map(|k| i1.sample(10.0 + (k % 8) as f32 + u[0], 7.0 + (k / 8) as f32 + u[1]) - t.t[k])
            .collect();
        let mean = r.iter().sum::<f32>() / 64.0;
        let want_ssd: f32 = r.iter().map(|v| (v - mean).powi(2)).sum();
        let want_bx: f32 = r.iter().zip(&t.gx).map(|(v, g)| (v - mean) * g).sum();
        let want_by: f32 = r.iter().zip(&t.gy).map(|(v, g)| (v - mean) * g).sum();
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-3 * b.abs().max(1.0);
        assert!(close(ssd, want_ssd), "{ssd} vs {want_ssd}");
        assert!(close(bx, want_bx) && close(by, want_by), "{bx} {by} vs {want_bx} {want_by}");
    }
}

/// The AVX2 kernel against the portable patch sampling and sums, bit for bit, at offsets
/// inside the image and reaching past its border (where the patch is moved back); and
/// the AVX2 stripe search against the portable one.
#[cfg(target_arch = "x86_64")]
#[test]
#[allow(unsafe_code)]
fn the_avx2_kernel_gives_the_portable_bits() {
    if !std::arch::is_x86_feature_detected!("avx2") {
        eprintln!("skipped: this CPU has no AVX2");
        return;
    }
    let (i0, i1) = (image(40, 30), image(40, 30));
    let (gx, gy) = i0.sobel();
    let padded = Padded::new(&i1, 16);
    let mut buf = Vec::new();
    for origin in [(10, 7), (0, 0), (32, 22)] {
        let t = Template::new(&i0, &gx, &gy, origin, 8);
        for u in [[0.3f32, -0.6f32], [2.5, 1.25], [-1.0, 0.0], [-30.2, 4.7], [19.9, 30.1]] {
            let (a, [ax, ay]) = t.at(&padded, u, &mut buf);
            // SAFETY: the CPU has AVX2 (checked above); the template is 8×8.
            let (b, [bx, by]) = unsafe { t.at8_avx2(&padded, u) };
            assert_eq!(
                [a.to_bits(), ax.to_bits(), ay.to_bits()],
                [b.to_bits(), bx.to_bits(), by.to_bits()],
                "{origin:?} + {u:?}"
            );
        }
    }
    let (xs, ys) =
        ((0..=32).step_by(3).collect::<Vec<_>>(), (0..=22).step_by(3).collect::<Vec<_>>());
    let stripe = Stripe {
        i0: &i0,
        i1: &padded,
        gx: &gx,
        gy: &gy,
        xs: &xs,
        ys: &ys,
        size: 8,
        iterations: (6, 6),
    };
    let start: Vec<[f32; 2]> =
        (0..xs.len() * ys.len()).map(|k| [0.1 * (k % 5) as f32, -0.2]).collect();
    let (mut portable, mut avx2) = (start.clone(), start);
    stripe.search_portable::<false>(0, &mut portable);
    // SAFETY: the CPU has AVX2 (checked above).
    unsafe { stripe.search_avx2(0, &mut avx2) };
    let bits = |v: &[[f32; 2]]| v.iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&portable), bits(&avx2));
}
