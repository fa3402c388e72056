//! DIS optical flow on textured image pairs with known motion: translation, rotation, zoom, and
//! two regions moving differently. The expected flow is the motion that generated the pair
//! (closed form), not anything the implementation computed.
#![allow(clippy::unwrap_used)]

use joca_data::flow::{DisParams, DisPreset, Flow, Gray, dis};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const W: usize = 256;
const H: usize = 192;

/// A smooth random texture on the plane: value noise at four octaves, 0–255, defined at any real
/// (x, y) so warped copies can be sampled exactly.
struct Texture {
    grids: Vec<(f32, usize, Vec<f32>)>,
}

impl Texture {
    fn new(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let grids = [(16.0, 0.45f32), (8.0, 0.3), (4.0, 0.17), (2.0, 0.08)]
            .into_iter()
            .map(|(cell, amp)| {
                let n = 200;
                let values = (0..n * n).map(|_| amp * rng.random_range(-1.0f32..1.0)).collect();
                (cell, n, values)
            })
            .collect();
        Self { grids }
    }

    fn at(&self, x: f32, y: f32) -> f32 {
        let mut v = 0.0;
        for (cell, n, values) in &self.grids {
            let (gx, gy) = (x / cell + 50.0, y / cell + 50.0);
            let (x0, y0) = (gx.floor(), gy.floor());
            let (fx, fy) = (gx - x0, gy - y0);
            // Smoothstep interpolation: a C¹ texture, like a real scene blurred by optics.
            let (sx, sy) = (fx * fx * (3.0 - 2.0 * fx), fy * fy * (3.0 - 2.0 * fy));
            let idx = |i: f32, j: f32| values[(j as usize % n) * n + (i as usize % n)];
            let top = idx(x0, y0) * (1.0 - sx) + idx(x0 + 1.0, y0) * sx;
            let bottom = idx(x0, y0 + 1.0) * (1.0 - sx) + idx(x0 + 1.0, y0 + 1.0) * sx;
            v += top * (1.0 - sy) + bottom * sy;
        }
        (128.0 + 110.0 * v).clamp(0.0, 255.0)
    }
}

fn image(f: impl Fn(f32, f32) -> f32) -> Gray {
    Gray::new(W, H, (0..W * H).map(|k| f((k % W) as f32, (k / W) as f32)).collect())
}

fn flow(f: impl Fn(f32, f32) -> [f32; 2]) -> Flow {
    Flow::new(W, H, (0..W * H).map(|k| f((k % W) as f32, (k / W) as f32)).collect())
}

/// A pair under the map x ↦ m(x) (I1(m(x)) = I0(x)): I1 is sampled through the inverse map, and
/// the true flow is m(x) − x.
fn pair(
    tex: &Texture,
    forward: impl Fn(f32, f32) -> (f32, f32),
    inverse: impl Fn(f32, f32) -> (f32, f32),
) -> (Gray, Gray, Flow) {
    let i0 = image(|x, y| tex.at(x, y));
    let i1 = image(|x, y| {
        let (a, b) = inverse(x, y);
        tex.at(a, b)
    });
    let truth = flow(|x, y| {
        let (a, b) = forward(x, y);
        [a - x, b - y]
    });
    (i0, i1, truth)
}

/// EPE over the interior (a 16-pixel border is left out: content entering the view there has
/// no correspondence in I0).
fn interior_epe(estimate: &Flow, truth: &Flow) -> f64 {
    let mut sum = 0.0;
    let mut n = 0.0;
    for y in 16..H - 16 {
        for x in 16..W - 16 {
            let (a, b) = (estimate.at(x, y), truth.at(x, y));
            sum += f64::from((a[0] - b[0]).hypot(a[1] - b[1]));
            n += 1.0;
        }
    }
    sum / n
}

fn medium() -> DisParams {
    DisParams::preset(DisPreset::Medium)
}

#[test]
fn translation() {
    let tex = Texture::new(1);
    let (dx, dy) = (3.4f32, -1.7f32);
    let (i0, i1, truth) = pair(&tex, |x, y| (x + dx, y + dy), |x, y| (x - dx, y - dy));
    let zero = Flow::zeros(W, H);
    let est = dis(&i0, &i1, &medium());
    let epe = interior_epe(&est, &truth);
    eprintln!("translation: EPE {epe:.3} px (zero flow {:.3})", interior_epe(&zero, &truth));
    assert!(epe < 0.5, "translation EPE {epe:.3} (zero flow: {:.3})", interior_epe(&zero, &truth));
}

#[test]
fn the_flow_does_not_depend_on_the_thread_count() {
    // Spatial propagation runs within fixed stripes of patch rows, whatever the threads.
    let tex = Texture::new(5);
    let (i0, i1, _) = pair(&tex, |x, y| (x + 2.2, y - 0.6), |x, y| (x - 2.2, y + 0.6));
    let with = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| dis(&i0, &i1, &medium()))
    };
    assert_eq!(with(1), with(3));
}

#[test]
fn rotation_about_the_centre() {
    let tex = Texture::new(2);
    let (cx, cy, a) = (W as f32 / 2.0, H as f32 / 2.0, 2.5f32.to_radians());
    let rot = move |x: f32, y: f32, a: f32| {
        let (s, c) = a.sin_cos();
        (cx + c * (x - cx) - s * (y - cy), cy + s * (x - cx) + c * (y - cy))
    };
    let (i0, i1, truth) = pair(&tex, |x, y| rot(x, y, a), |x, y| rot(x, y, -a));
    let epe = interior_epe(&dis(&i0, &i1, &medium()), &truth);
    // The flow reaches 2.5° × 160 px ≈ 7 px in the corners.
    eprintln!("rotation: EPE {epe:.3} px");
    assert!(epe < 0.5, "rotation EPE {epe:.3}");
}

#[test]
fn zoom_about_the_centre() {
    let tex = Texture::new(3);
    let (cx, cy, k) = (W as f32 / 2.0, H as f32 / 2.0, 1.04f32);
    let (i0, i1, truth) = pair(
        &tex,
        |x, y| (cx + k * (x - cx), cy + k * (y - cy)),
        |x, y| (cx + (x - cx) / k, cy + (y - cy) / k),
    );
    let epe = interior_epe(&dis(&i0, &i1, &medium()), &truth);
    eprintln!("zoom: EPE {epe:.3} px");
    assert!(epe < 0.5, "zoom EPE {epe:.3}");
}

#[test]
fn two_regions_moving_differently() {
    // Background moves (2, 1); a 96×80 textured block moves (−3, 2) over it.
    let bg = Texture::new(4);
    let fg = Texture::new(5);
    let (bx, by) = (2.0f32, 1.0f32);
    let (ox, oy) = (-3.0f32, 2.0f32);
    let inside = |x: f32, y: f32| (80.0..176.0).contains(&x) && (56.0..136.0).contains(&y);
    let i0 = image(|x, y| if inside(x, y) { fg.at(x, y) } else { bg.at(x, y) });
    let i1 =
        image(
            |x, y| {
                if inside(x - ox, y - oy) { fg.at(x - ox, y - oy) } else { bg.at(x - bx, y - by) }
            },
        );
    let truth = flow(|x, y| if inside(x, y) { [ox, oy] } else { [bx, by] });
    let est = dis(&i0, &i1, &medium());
    let epe = interior_epe(&est, &truth);
    eprintln!("two motions: EPE {epe:.3} px");
    assert!(epe < 0.5, "two-motion EPE {epe:.3}");
    // Both motions are found, not an average of them.
    let c = est.at(128, 96);
    assert!((c[0] - ox).abs() < 0.3 && (c[1] - oy).abs() < 0.3, "block centre {c:?}");
    let b = est.at(40, 170);
    assert!((b[0] - bx).abs() < 0.3 && (b[1] - by).abs() < 0.3, "background {b:?}");
}

#[test]
fn every_preset_beats_zero_flow_on_a_translation() {
    let tex = Texture::new(6);
    let (i0, i1, truth) = pair(&tex, |x, y| (x + 2.0, y + 1.0), |x, y| (x - 2.0, y - 1.0));
    let zero = interior_epe(&Flow::zeros(W, H), &truth);
    for preset in [DisPreset::UltraFast, DisPreset::Fast, DisPreset::Medium] {
        let epe = interior_epe(&dis(&i0, &i1, &DisParams::preset(preset)), &truth);
        eprintln!("{preset:?}: EPE {epe:.3} px (zero flow {zero:.3})");
        assert!(epe < 0.25 * zero, "{preset:?}: EPE {epe:.3} vs zero flow {zero:.3}");
    }
}
