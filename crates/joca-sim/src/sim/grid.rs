//! The sub-frame grid that the frames of one instant share: how many cells a shutter needs
//! (from the scene's image-space travel), a centred shutter's weights on it, and the frames
//! integrated on it.

use super::{Episode, MAX_SUBFRAMES, Simulator, pool};
use crate::geometry::V3;
use crate::render::{self, CameraFrame, Target};
use joca_core::PinholeCamera;
use rayon::prelude::*;

/// The sub-frame grid of one frame: `cells` equal cells over `span_s` seconds centred on
/// `centre_s` (the frame's time). A shutter of `s ≤ span_s` seconds is open over
/// `[centre − s/2, centre + s/2]`: shorter shutters nest in longer ones and share their renders,
/// ground truth and 180° count. Each cell is rendered at its centre and stands for the scene
/// over the whole cell (a box filter in time).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShutterGrid {
    /// The frame's time, seconds: the middle of every shutter.
    pub centre_s: f64,
    /// The longest shutter the grid covers, seconds.
    pub span_s: f64,
    /// Number of cells (odd, so that the middle one is rendered at the centre).
    pub cells: usize,
}

impl ShutterGrid {
    /// A grid of `cells` (made odd, at least 1) over `span_s` centred on `centre_s`.
    pub fn new(centre_s: f64, span_s: f64, cells: usize) -> Self {
        Self { centre_s, span_s: span_s.max(0.0), cells: cells.max(1) | 1 }
    }

    fn step_s(&self) -> f64 {
        self.span_s / self.cells as f64
    }

    /// The time cell `k` is rendered at.
    pub fn time(&self, k: usize) -> f64 {
        self.centre_s + (k as f64 - (self.cells / 2) as f64) * self.step_s()
    }

    /// Each cell's share of a shutter of `shutter_s` seconds centred on the grid: the overlap of
    /// the cell with the open shutter over the shutter's length (they sum to 1). A shutter
    /// shorter than a cell is the middle cell alone, a sharp frame.
    pub fn weights(&self, shutter_s: f64) -> Vec<f32> {
        let mut out = vec![0.0f32; self.cells];
        let middle = self.cells / 2;
        let step = self.step_s();
        if !(shutter_s > 0.0 && step > 0.0) || shutter_s <= step {
            out[middle] = 1.0;
            return out;
        }
        // In units of cells, from the centre: the shutter covers [−r, r], cell k covers
        // [k − m − 1/2, k − m + 1/2].
        let r = 0.5 * shutter_s.min(self.span_s) / step;
        for (k, o) in out.iter_mut().enumerate() {
            let c = k as f64 - middle as f64;
            let overlap = ((c + 0.5).min(r) - (c - 0.5).max(-r)).max(0.0);
            *o = (overlap / (2.0 * r)) as f32;
        }
        out
    }
}

/// A centred shutter's [`ShutterGrid::weights`] in ring form: `inner` on every cell within
/// `full` cells of the middle, `edge` on the two cells at `full + 1` (0 when the shutter ends
/// on a cell boundary), nothing beyond.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct RingWeights {
    pub(super) full: usize,
    pub(super) inner: f32,
    pub(super) edge: f32,
}

impl RingWeights {
    /// The ring form of `weights` (symmetric about the middle cell, as every centred shutter's
    /// are: checked in debug builds).
    pub(super) fn of(weights: &[f32]) -> Self {
        let m = weights.len() / 2;
        let inner = weights[m];
        let full = (1..=m).take_while(|&k| weights[m - k] == inner).count();
        let edge = if full < m { weights[m - full - 1] } else { 0.0 };
        let ring = Self { full, inner, edge };
        debug_assert!(weights.iter().enumerate().all(|(k, &wk)| wk == ring.weight(k.abs_diff(m))));
        ring
    }

    /// The weight of a cell `d` cells from the middle.
    pub(super) fn weight(&self, d: usize) -> f32 {
        if d <= self.full {
            self.inner
        } else if d == self.full + 1 {
            self.edge
        } else {
            0.0
        }
    }

    /// The farthest ring with a non-zero weight.
    pub(super) fn reach(&self) -> usize {
        if self.edge > 0.0 { self.full + 1 } else { self.full }
    }
}

impl Simulator {
    /// The frames of shutters integrated over `grid`, one per row of `weights` (each shutter's
    /// [`ShutterGrid::weights`]). The middle cell is `mid`, already rendered; the others are
    /// rendered in parallel, each once, and a cell no shutter overlaps is not rendered.
    ///
    /// Shutters are centred on the grid, so a shutter's weights are one value over a symmetric
    /// run of whole cells and one smaller value on the pair of cells just outside it (see
    /// [`RingWeights`]). Each frame is therefore summed ring by ring from the middle outwards,
    /// `((v₀ + v₋₁) + v₊₁) + …`, scaled once, plus its edge pair: the order of every addition
    /// depends only on the grid and that shutter, not on the other shutters sharing the grid nor
    /// on the thread count. Summing rings is also what makes many shutters cheap: the running
    /// sum is shared, and each cell is read once.
    pub(super) fn integrate(
        &self,
        episode: &Episode,
        camera: &PinholeCamera,
        grid: &ShutterGrid,
        weights: &[Vec<f32>],
        mid: &Target,
    ) -> Integrated {
        let (w, h) = (camera.width_px, camera.height_px);
        let objects = self.city.objects.len();
        let middle = grid.cells / 2;
        let rings: Vec<RingWeights> = weights.iter().map(|wk| RingWeights::of(wk)).collect();
        // Cells out to the outermost ring any shutter touches.
        let reach = rings.iter().map(RingWeights::reach).max().unwrap_or(0);
        let others: Vec<usize> =
            (middle - reach..=middle + reach).filter(|&k| k != middle).collect();
        let rendered: Vec<Target> = others
            .par_iter()
            .map(|&k| {
                let mut target = pool::take(w, h, objects, true);
                self.render_at(episode, camera, grid.time(k), &mut target);
                target
            })
            .collect();
        let target = |k: usize| -> &Target {
            if k == middle {
                mid
            } else {
                let i = if k < middle { k - (middle - reach) } else { k - (middle - reach) - 1 };
                &rendered[i]
            }
        };
        let colours = sum_rings(&rings, (middle, reach), |k| &target(k).colour);
        // Fog's light depths, for the glow of the integrated frame (none without fog, and none
        // needed when every sub-frame glowed on its own).
        let light_depths = if mid.light_depth.is_empty() || self.config.optics_per_subframe {
            Vec::new()
        } else {
            sum_rings(&rings, (middle, reach), |k| &target(k).light_depth)
        };
        pool::give(rendered);
        Integrated { colours, light_depths }
    }
}

/// Shutter-integrated buffers, one per shutter.
pub(super) struct Integrated {
    /// Colour (RGB, calibrated DN).
    pub(super) colours: Vec<Vec<f32>>,
    /// Fog's light-weighted optical depth ([`Target::light_depth`]); empty without fog.
    pub(super) light_depths: Vec<Vec<f32>>,
}

/// Each shutter's weighted sum of one buffer of the cells `middle ± reach`, `cell(k)` giving
/// cell k's buffer (all of one length), summed ring by ring (see [`Simulator::integrate`]).
fn sum_rings<'a>(
    rings: &[RingWeights],
    (middle, reach): (usize, usize),
    cell: impl Fn(usize) -> &'a [f32] + Sync,
) -> Vec<Vec<f32>> {
    // Over blocks of the image in parallel; within a block, rings in order.
    const BLOCK: usize = 4096;
    let mut out = vec![vec![0.0f32; cell(middle).len()]; rings.len()];
    let mut blocks: Vec<Vec<&mut [f32]>> = Vec::new();
    {
        let mut iters: Vec<_> = out.iter_mut().map(|o| o.chunks_mut(BLOCK)).collect();
        'blocks: loop {
            let mut row = Vec::with_capacity(iters.len());
            for it in &mut iters {
                match it.next() {
                    Some(b) => row.push(b),
                    None => break 'blocks,
                }
            }
            blocks.push(row);
        }
    }
    blocks.into_par_iter().enumerate().for_each(|(b, mut frames)| {
        let start = b * BLOCK;
        let len = frames.first().map_or(0, |f| f.len());
        let at = |k: usize| &cell(k)[start..start + len];
        let mut acc: Vec<f32> = at(middle).to_vec();
        for k in 0..=reach {
            if k > 0 {
                let (lo, hi) = (at(middle - k), at(middle + k));
                for ((a, &l), &u) in acc.iter_mut().zip(lo).zip(hi) {
                    *a = (*a + l) + u;
                }
            }
            for (frame, ring) in frames.iter_mut().zip(rings) {
                if ring.full != k {
                    continue;
                }
                if ring.edge == 0.0 {
                    frame.iter_mut().zip(&acc).for_each(|(f, &a)| *f = ring.inner * a);
                } else {
                    let (lo, hi) = (at(middle - k - 1), at(middle + k + 1));
                    for (((f, &a), &l), &u) in frame.iter_mut().zip(&acc).zip(lo).zip(hi) {
                        *f = ring.inner * a + ring.edge * (l + u);
                    }
                }
            }
        }
    });
    out
}

/// How finely a shutter is sampled: from the image-space travel of the scene.
impl Simulator {
    /// Number of sub-frames for a shutter from `t0` to `t1`, from the image-space travel of the
    /// scene seen in `mid`: about one per pixel of the largest displacement, odd (so the middle
    /// one falls on the shutter midpoint), at most [`MAX_SUBFRAMES`].
    pub(super) fn subframes(
        &self,
        episode: &Episode,
        camera: &PinholeCamera,
        t0: f64,
        t1: f64,
        mid: &Target,
    ) -> usize {
        if t1 <= t0 {
            return 1;
        }
        let c0 = CameraFrame::new(camera, episode.ego.pose_at(t0));
        let c1 = CameraFrame::new(camera, episode.ego.pose_at(t1));
        let cm = CameraFrame::new(camera, episode.ego.pose_at(0.5 * (t0 + t1)));
        let project = |c: &CameraFrame, p: V3| -> Option<(f32, f32)> {
            let q = c.camera_from_world(p);
            (q.z > render::NEAR_M).then(|| (c.cx + c.fx * q.x / q.z, c.cy + c.fy * q.y / q.z))
        };
        let mut travel = 0.0f32;
        let mut measure = |a: Option<(f32, f32)>, b: Option<(f32, f32)>| {
            if let (Some(a), Some(b)) = (a, b) {
                travel = travel.max(((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt());
            }
        };
        // Static scene: unproject a sparse grid of the middle view, reproject at both ends.
        let step = 6;
        for y in (step / 2..mid.height).step_by(step) {
            for x in (step / 2..mid.width).step_by(step) {
                let inv_z = mid.inv_depth[y * mid.width + x];
                if inv_z <= 0.0 {
                    continue;
                }
                let z = 1.0 / inv_z;
                let a = (x as f32 + 0.5 - cm.cx) / cm.fx;
                let b = (y as f32 + 0.5 - cm.cy) / cm.fy;
                let p = cm.origin + cm.forward * z + cm.right * (a * z) + V3::new(0.0, 0.0, -b * z);
                measure(project(&c0, p), project(&c1, p));
            }
        }
        // Moving objects in view: their own motion too.
        let mut seen: Vec<u32> = mid.id.iter().copied().filter(|&i| i > 0).collect();
        seen.sort_unstable();
        seen.dedup();
        for id in seen {
            let object = &self.city.objects[id as usize - 1];
            if object.motion.is_static() {
                continue;
            }
            for part in &object.parts {
                let p0 = object.position_at(t0).apply(part.offset);
                let p1 = object.position_at(t1).apply(part.offset);
                measure(project(&c0, p0), project(&c1, p1));
            }
        }
        let n = (travel.ceil() as usize).clamp(1, MAX_SUBFRAMES);
        n | 1
    }

    /// The grid of sub-frames for shutters up to `longest_s` centred on `request.time_s`: about
    /// one cell per pixel of the largest image-space travel over the longest shutter, odd, at
    /// most [`MAX_SUBFRAMES`]. `mid` is the view at the centre.
    pub(super) fn grid_for(
        &self,
        episode: &Episode,
        camera: &PinholeCamera,
        centre_s: f64,
        longest_s: f64,
        mid: &Target,
    ) -> ShutterGrid {
        let half = 0.5 * longest_s;
        let cells = self.subframes(episode, camera, centre_s - half, centre_s + half, mid);
        ShutterGrid::new(centre_s, longest_s, cells)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ring form stands for exactly the grid's weights, for shutters from shorter than a
    /// cell to the whole span, on odd grids of 1 to 31 cells.
    #[test]
    fn ring_weights_are_the_grid_weights() {
        for cells in (1..=31).step_by(2) {
            let grid = ShutterGrid::new(1.0, 0.04, cells);
            for i in 0..=400 {
                let shutter = 0.04 * f64::from(i) / 400.0;
                let weights = grid.weights(shutter);
                let ring = RingWeights::of(&weights);
                let m = cells / 2;
                for (k, &wk) in weights.iter().enumerate() {
                    assert_eq!(
                        wk.to_bits(),
                        ring.weight(k.abs_diff(m)).to_bits(),
                        "{cells} {i} {k}"
                    );
                }
                assert!(ring.reach() <= m);
                let total: f32 = weights.iter().sum();
                assert!((total - 1.0).abs() < 1e-5, "weights sum to {total}");
            }
        }
    }
}
