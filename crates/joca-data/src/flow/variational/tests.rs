//! Tests of the variational refinement against its definitions.

use super::*;

/// Adds neighbour `m`'s smoothness pull on pixel `k` with weight `wkm`: `w (u_m + du_m − u_k)`
/// to the pull, `w` to the weight (`at` = incoming flow, increments, `k`). A function rather
/// than a closure so that it is always inlined into the sweep.
#[inline(always)]
fn pull_towards(
    (pull, weight): &mut ([f32; 2], f32),
    (base, du, k): (&[[f32; 2]], &[[f32; 2]], usize),
    m: usize,
    wkm: f32,
) {
    pull[0] += wkm * (base[m][0] + du[m][0] - base[k][0]);
    pull[1] += wkm * (base[m][1] + du[m][1] - base[k][1]);
    *weight += wkm;
}

/// The plain formulation the packed sweep replaced: the increment solved for, red–black
/// half-sweeps in image order from a copy of the other colour.
fn refine_plain(i0: &Gray, i1: &Gray, flow: &mut Flow, p: &RefineParams, iterations: usize) {
    let (w, h) = (i0.width(), i0.height());
    if w < 2 || h < 2 {
        return;
    }
    let n = w * h;
    let base: Vec<[f32; 2]> = flow.data.clone();
    let d = Derivatives::new(i0, i1, &base);
    let terms: Vec<Terms> = (0..n).map(|k| d.terms(k, p.zeta * p.zeta)).collect();
    let mut du = vec![[0.0f32; 2]; n];
    let mut systems = vec![System::default(); n];
    let mut smooth = vec![0.0f32; n];
    let e2 = p.epsilon * p.epsilon;
    for _ in 0..iterations {
        (systems.par_iter_mut(), smooth.par_iter_mut()).into_par_iter().enumerate().for_each(
            |(k, (system, smooth))| {
                *system = terms[k].system(du[k], p);
                let (x, y) = (k % w, k / w);
                let f = |m: usize| [base[m][0] + du[m][0], base[m][1] + du[m][1]];
                let here = f(k);
                let right = if x + 1 < w { f(k + 1) } else { here };
                let down = if y + 1 < h { f(k + w) } else { here };
                let g2 = (right[0] - here[0]).powi(2)
                    + (right[1] - here[1]).powi(2)
                    + (down[0] - here[0]).powi(2)
                    + (down[1] - here[1]).powi(2);
                *smooth = 0.5 * p.alpha / (g2 + e2).sqrt();
            },
        );
        for _ in 0..p.sweeps {
            for colour in 0..2 {
                // A pixel of one colour reads only pixels of the other, which this half-sweep
                // does not write: rows update in parallel from a copy, with the same bits as
                // the sequential sweep.
                let other = du.clone();
                du.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                    let start = (y + colour) % 2;
                    for x in (start..w).step_by(2) {
                        let k = y * w + x;
                        // Σ_m w_km (u_m + du_m − u_k) and Σ_m w_km over the 4-neighbours.
                        let mut sums = ([0.0f32; 2], 0.0f32);
                        let at = (&base[..], &other[..], k);
                        if x > 0 {
                            pull_towards(&mut sums, at, k - 1, smooth[k - 1]);
                        }
                        if x + 1 < w {
                            pull_towards(&mut sums, at, k + 1, smooth[k]);
                        }
                        if y > 0 {
                            pull_towards(&mut sums, at, k - w, smooth[k - w]);
                        }
                        if y + 1 < h {
                            pull_towards(&mut sums, at, k + w, smooth[k]);
                        }
                        let (pull, weight) = sums;
                        let s = systems[k];
                        let d = &mut row[x];
                        let new_u = (s.b1 + pull[0] - s.a12 * d[1]) / (s.a11 + weight);
                        d[0] += p.omega * (new_u - d[0]);
                        let new_v = (s.b2 + pull[1] - s.a12 * d[0]) / (s.a22 + weight);
                        d[1] += p.omega * (new_v - d[1]);
                    }
                });
            }
        }
    }
    for k in 0..n {
        flow.data[k] = [base[k][0] + du[k][0], base[k][1] + du[k][1]];
    }
}

fn image(w: usize, h: usize, shift: f32) -> Gray {
    let v = |x: f32, y: f32| {
        128.0 + 50.0 * (0.31 * x + shift).sin() * (0.17 * y).cos() + 20.0 * (0.05 * x * y).sin()
    };
    Gray::new(w, h, (0..w * h).map(|i| v((i % w) as f32, (i / w) as f32)).collect())
}

/// The packed, vectorised sweep against the plain one on odd and even sizes (every border
/// case of the packing): the same refined flow up to float rounding, and the refinement
/// moves the flow (the comparison is not between two unchanged fields).
#[test]
fn the_packed_sweep_equals_the_plain_red_black_sor() {
    for (w, h) in [(37, 23), (36, 24), (2, 3)] {
        let (i0, i1) = (image(w, h, 0.0), image(w, h, 0.6));
        let start: Vec<[f32; 2]> = (0..w * h)
            .map(|k| [0.5 + 0.02 * (k % w) as f32, -0.3 + 0.01 * (k / w) as f32])
            .collect();
        let mut packed = Flow::new(w, h, start.clone());
        let mut plain = Flow::new(w, h, start.clone());
        let p = RefineParams::default();
        refine(&i0, &i1, &mut packed, &p, 5);
        refine_plain(&i0, &i1, &mut plain, &p, 5);
        let (mut worst, mut moved) = (0.0f32, 0.0f32);
        for ((a, b), s) in packed.data().iter().zip(plain.data()).zip(&start) {
            worst = worst.max((a[0] - b[0]).abs()).max((a[1] - b[1]).abs());
            moved = moved.max((a[0] - s[0]).abs()).max((a[1] - s[1]).abs());
        }
        assert!(worst < 5e-5, "{w}×{h}: packed and plain differ by {worst} px");
        assert!(moved > 0.05, "{w}×{h}: the refinement moved the flow by {moved} px only");
    }
}
