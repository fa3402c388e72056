//! `test/showcase.json`: fixed closed-loop sequences on the test town, the same scenes for every
//! run, whose frames, settings and boxes the reports draw.

use crate::{Light, Settings};
use joca_core::{Annotation, Detection};
use serde::{Deserialize, Serialize};

/// One frame of a showcase sequence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShowcaseFrame {
    /// Frame index in the sequence.
    pub frame: usize,
    /// Simulation time, s.
    pub time_s: f64,
    /// Ambient light relative to full daylight.
    pub ambient: f32,
    /// Exposure (ms) and gain (dB) applied, written as two fields.
    #[serde(flatten)]
    pub settings: Settings,
    /// Ground truth at the shutter midpoint.
    pub boxes: Vec<Annotation>,
    /// Detections on the formed frame.
    pub detections: Vec<Detection>,
    /// The saved 8-bit frame, relative to `test/`, if saved.
    pub image: Option<String>,
}

/// A showcase sequence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Showcase {
    /// Name (`tunnel`, `day`, `night`).
    pub name: String,
    /// Illumination schedule (`day`, `night`, `tunnel`, `cycle`).
    pub illumination: Light,
    /// Output frame size, pixels.
    pub size_px: (usize, usize),
    /// Frames in order.
    pub frames: Vec<ShowcaseFrame>,
}

/// How the exposure controller answered the largest rise of ambient light in a showcase (the
/// tunnel exit): see [`Showcase::light_step`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightStep {
    /// Time of the first frame in the brighter light, s.
    pub time_s: f64,
    /// Ambient after the step over ambient before it.
    pub rise: f64,
    /// Exposure × linear gain of the last frame before the step over the smallest exposure ×
    /// gain within the window after it (from the step's first frame on): how far the controller
    /// took the light back.
    pub fall: f64,
    /// The window, s.
    pub window_s: f64,
}

impl ShowcaseFrame {
    /// Exposure × linear gain, ms.
    pub fn exposure_gain_ms(&self) -> f64 {
        self.settings.exposure_gain_ms()
    }
}

impl Showcase {
    /// The controller's answer to the largest frame-to-frame rise of ambient light, if some
    /// frame is at least `min_rise` times brighter than the one before it: the fall of exposure
    /// × gain within `window_s` seconds (closed loop, a frame's settings come from the frame
    /// before it, so the step's own frame still has the old settings).
    pub fn light_step(&self, min_rise: f64, window_s: f64) -> Option<LightStep> {
        let ratio = |k: usize| {
            f64::from(self.frames[k].ambient) / f64::from(self.frames[k - 1].ambient).max(1e-12)
        };
        let k = (1..self.frames.len()).max_by(|&a, &b| ratio(a).total_cmp(&ratio(b)))?;
        let rise = ratio(k);
        if rise < min_rise {
            return None;
        }
        let start = self.frames[k].time_s;
        let before = self.frames[k - 1].exposure_gain_ms();
        let least = self.frames[k..]
            .iter()
            .take_while(|f| f.time_s <= start + window_s + 1e-9)
            .map(ShowcaseFrame::exposure_gain_ms)
            .fold(f64::INFINITY, f64::min);
        Some(LightStep { time_s: start, rise, fall: before / least, window_s })
    }

    /// How far exposure × linear gain moved from each frame to the next, in stops (|log2| of
    /// their ratio), over the frames whose ambient light has not changed for at least `settle_s`
    /// (since the sequence began or its light last changed): a controller that holds the image
    /// level in steady light moves little, one that zig-zags moves every frame.
    pub fn steady_steps_stops(&self, settle_s: f64) -> Vec<f64> {
        let mut since = self.frames.first().map_or(0.0, |f| f.time_s);
        let mut out = Vec::new();
        for pair in self.frames.windows(2) {
            let (a, b) = (&pair[0], &pair[1]);
            let (la, lb) = (f64::from(a.ambient), f64::from(b.ambient));
            if (lb - la).abs() > 1e-3 * la.abs().max(lb.abs()) {
                since = b.time_s;
            } else if a.time_s - since >= settle_s - 1e-9 {
                out.push((b.exposure_gain_ms() / a.exposure_gain_ms()).log2().abs());
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(k: usize, ambient: f32, exposure_ms: f64, gain_db: f64) -> ShowcaseFrame {
        ShowcaseFrame {
            frame: k,
            time_s: 0.1 * k as f64,
            ambient,
            settings: Settings { exposure_ms, gain_db, f_number: None },
            boxes: Vec::new(),
            detections: Vec::new(),
            image: None,
        }
    }

    /// A `tunnel` showcase of `frames`.
    fn tunnel(frames: Vec<ShowcaseFrame>) -> Showcase {
        Showcase { name: "tunnel".into(), illumination: Light::Tunnel, size_px: (8, 6), frames }
    }

    /// A 500× step at frame 3; the controller keeps the old settings one frame, then drops to
    /// 10 ms and 0 dB (from 50 ms and 20 dB: 50× less), then creeps back up: the fall within
    /// 1 s is 50×, within 0.05 s (the step's own frame only) 1×.
    #[test]
    fn the_light_step_is_found_and_its_fall_measured() {
        let mut frames: Vec<ShowcaseFrame> = (0..3).map(|k| frame(k, 0.002, 50.0, 20.0)).collect();
        frames.push(frame(3, 1.0, 50.0, 20.0));
        frames.push(frame(4, 1.0, 10.0, 0.0));
        frames.extend((5..20).map(|k| frame(k, 1.0, 12.0, 0.0)));
        let s = tunnel(frames);
        let step = s.light_step(10.0, 1.0).unwrap();
        assert!((step.rise - 500.0).abs() < 1e-3 && (step.time_s - 0.3).abs() < 1e-9);
        assert!((step.fall - 50.0).abs() < 1e-9, "{step:?}");
        assert!((s.light_step(10.0, 0.05).unwrap().fall - 1.0).abs() < 1e-12);
        assert!(s.light_step(1000.0, 1.0).is_none());
    }

    /// In steady light a controller alternating ±1 stop moves 1 stop a frame; frames within
    /// the settling time of the sequence's start or of a change of light are left out.
    #[test]
    fn steady_light_steps_count_only_settled_frames() {
        // 0.0–0.9 s dark, alternating 40 / 20 ms (1 stop); from 1.0 s bright at a level 2 ms.
        let mut frames: Vec<ShowcaseFrame> =
            (0..10).map(|k| frame(k, 0.002, if k % 2 == 0 { 40.0 } else { 20.0 }, 0.0)).collect();
        frames.extend((10..20).map(|k| frame(k, 1.0, 2.0, 0.0)));
        let s = tunnel(frames);
        // Settled after 0.5 s: pairs (5,6) … (8,9) in the dark, 1 stop each; the bright stretch
        // from 1.0 s settles at 1.5 s: pairs (15,16) … (18,19), 0 stops.
        let steps = s.steady_steps_stops(0.5);
        assert_eq!(steps.len(), 8, "{steps:?}");
        assert!(steps[..4].iter().all(|d| (d - 1.0).abs() < 1e-12), "{steps:?}");
        assert!(steps[4..].iter().all(|d| *d == 0.0), "{steps:?}");
        // 6 dB of gain is one stop of light too.
        let gain: Vec<ShowcaseFrame> =
            (0..4).map(|k| frame(k, 1.0, 10.0, if k % 2 == 0 { 0.0 } else { 6.0206 })).collect();
        let g = tunnel(gain);
        assert!(g.steady_steps_stops(0.0).iter().all(|d| (d - 1.0).abs() < 1e-4));
    }
}
