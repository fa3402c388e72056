//! Tests of DIS optical flow: pyramids, gradients, densification and whole-pair flows.

use super::*;

#[test]
fn patch_grid_covers_the_image() {
    assert_eq!(patch_origins(20, 8, 4), vec![0, 4, 8, 12]);
    assert_eq!(patch_origins(23, 8, 4), vec![0, 4, 8, 12]);
    assert_eq!(patch_origins(24, 8, 4), vec![0, 4, 8, 12, 16]);
    assert_eq!(patch_origins(5, 8, 4), vec![0]);
}

/// The densification against its definition, pixel by pixel: the average of the covering
/// patches' flows weighted by `1 / max(1, |I1(x + u_i) − I0(x)|)`, patches in the global
/// order, the last patch of a row or column reaching to the image's edge; bit for bit, over
/// several bands and a ragged edge (45 = 6·6 + 8 + 1: one column past the last patch; 70 =
/// 10·6 + 8 + 2).
#[test]
fn densification_is_the_weighted_average_of_the_covering_patches() {
    let (w, h, size) = (45, 70, 8);
    let image = |shift: f32| {
        let data = (0..w * h)
            .map(|k| {
                let (x, y) = ((k % w) as f32 + shift, (k / w) as f32);
                100.0 + 60.0 * (0.31 * x).sin() * (0.17 * y).cos() + 5.0 * (1.3 * x * y).sin()
            })
            .collect();
        Gray::new(w, h, data)
    };
    let (i0, i1) = (image(0.0), image(1.5));
    let (xs, ys) = (patch_origins(w, size, 6), patch_origins(h, size, 6));
    let flows: Vec<[f32; 2]> = (0..xs.len() * ys.len())
        .map(|k| [((k * 7) % 11) as f32 * 0.3 - 1.5, ((k * 5) % 13) as f32 * 0.2 - 1.0])
        .collect();
    let init = Flow::new(w, h, vec![[9.0, -9.0]; w * h]);
    let padded = Padded::new(&i1, 2 * size);
    let got = densify(&i0, &padded, &xs, &ys, &flows, &init, size);
    let mut warped = vec![0.0f32; 4 * size * size];
    let (last_x, last_y) = (*xs.last().unwrap(), *ys.last().unwrap());
    assert_eq!((w - last_x - size, h - last_y - size), (1, 2));
    for y in 0..h {
        for x in 0..w {
            let (mut su, mut sv, mut sw) = (0.0f32, 0.0f32, 0.0f32);
            for (k, (&py, &px)) in
                ys.iter().flat_map(|py| xs.iter().map(move |px| (py, px))).enumerate()
            {
                let pw = if px == last_x { w - px } else { size };
                let ph = if py == last_y { h - py } else { size };
                if !(px..px + pw).contains(&x) || !(py..py + ph).contains(&y) {
                    continue;
                }
                let u = flows[k];
                padded.rect(px as f32 + u[0], py as f32 + u[1], (pw, ph), &mut warped);
                let weight = 1.0 / (warped[(y - py) * pw + x - px] - i0.at(x, y)).abs().max(1.0);
                su += weight * u[0];
                sv += weight * u[1];
                sw += weight;
            }
            assert!(sw > 0.0, "pixel ({x}, {y}) is covered");
            assert_eq!(got[y * w + x], [su / sw, sv / sw], "pixel ({x}, {y})");
        }
    }
}

#[test]
fn resizing_a_constant_flow_scales_its_vectors() {
    let f = Flow::new(4, 3, vec![[1.0, -2.0]; 12]);
    let g = f.resized(8, 6);
    assert!(g.data().iter().all(|v| (v[0] - 2.0).abs() < 1e-6 && (v[1] + 4.0).abs() < 1e-6));
}

/// The row-wise resize against `sample` at every target pixel centre (the definition),
/// up and down, bit for bit.
#[test]
fn resizing_equals_sampling_at_the_pixel_centres() {
    let (w, h) = (13, 9);
    let f = Flow::new(
        w,
        h,
        (0..w * h).map(|k| [((k * 7) % 11) as f32 - 3.5, ((k * 5) % 13) as f32 * 0.25]).collect(),
    );
    for (tw, th) in [(52, 36), (6, 4), (13, 9), (27, 5)] {
        let g = f.resized(tw, th);
        let (sx, sy) = (w as f32 / tw as f32, h as f32 / th as f32);
        for y in 0..th {
            for x in 0..tw {
                let v = f.sample((x as f32 + 0.5) * sx - 0.5, (y as f32 + 0.5) * sy - 0.5);
                let want = [v[0] / sx, v[1] / sy];
                assert_eq!(g.at(x, y), want, "{tw}×{th} at ({x}, {y})");
            }
        }
    }
}

#[test]
fn coarsest_scale_follows_the_image_size() {
    let p = DisParams::preset(DisPreset::Medium);
    // 1920 / 32 = 60 → log2 ≈ 5.9 → 6.
    assert_eq!(p.coarsest_scale(1920, 1280), 6);
    assert_eq!(p.coarsest_scale(30, 20), 1);
    assert!(DisPreset::from_name("slow").unwrap_err().contains("ultrafast, fast, medium"));
}
