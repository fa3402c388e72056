//! Closed-loop driving with the trained controller on the test town: the scored test episodes,
//! and the fixed "showcase" sequences whose frames, settings and boxes the reports draw (the
//! qualitative grid, the exposure/gain traces against illumination, the tunnel animation).
//!
//! In closed loop the controller sets the exposure and gain of frame t from frame t − 1 (its
//! own output), exactly as at training time but without any update. What a run leaves in
//! `test/` (all written atomically):
//! - `trace.jsonl` — one line per scored test frame: episode, time, illumination schedule and
//!   ambient level, the exposure and gain the sensor used, objects and detections;
//! - `showcase.json` — for each showcase sequence its frames with the same fields plus ground
//!   truth and detection boxes and, where saved, the PNG of the 8-bit frame the detector saw;
//! - `<sequence>/NNN.png` — those frames.

use super::context::Context;
pub(super) use super::driver::WARMUP_FRAMES;
use super::light_of;
use crate::TrainError;
use crate::checkpoint::write_atomic;
use joca_camera::CameraDesign;
use joca_core::{FrameSource, PinholeCamera, Rgb8Image};
use joca_metrics::{BandScores, TaskMetrics, TaskScores};
use joca_nn::joint::JointModel;
use joca_record::{ByLight, Light, LightResults, Settings, TraceRecord};
pub use joca_record::{Showcase, ShowcaseFrame};
use joca_sim::{Illumination, Simulator, TUNNEL_PHASE_S, test_map_seed};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;
use std::sync::Arc;

/// Frames of the tunnel showcase (10 Hz): 5 s around an abrupt change of illumination.
const TUNNEL_FRAMES: usize = 50;
/// Frames of the day and night showcases; the last one is saved.
const STEADY_FRAMES: usize = 20;

/// The tunnel showcase's episode and start: with tunnels as places, the first test episode that
/// leaves a tunnel, from its start (it passes the exit 1.3–2.7 s in); with the switch, episode 0
/// from 1.5 s before its first switch after t = 2.5 s, so the controller has settled and the
/// sequence holds one abrupt change (switches are 4 s apart).
fn tunnel_showcase(sim: &Simulator) -> (u64, f64) {
    let exit = (0..64).find(|&e| sim.episode(e).mouth.is_some_and(|m| !m.entering));
    if let Some(episode) = exit {
        return (episode, 0.0);
    }
    let phase = sim.episode(0).phase_s;
    let n = ((2.5 + phase) / TUNNEL_PHASE_S).ceil();
    (0, n * TUNNEL_PHASE_S - phase - 1.5)
}

/// Which town a closed-loop evaluation drives, for how long, with which noise.
#[derive(Debug, Clone, Copy)]
pub(super) struct Plan {
    /// The town's map seed.
    pub(super) town: u64,
    /// Episodes, stratified by illumination.
    pub(super) episodes: u64,
    /// Scored frames per episode.
    pub(super) frames_per_episode: usize,
    /// The noise stream's name.
    pub(super) noise: &'static str,
}

impl Plan {
    /// The test: town `town` of the test family (0: the test town; 1 is the validation's),
    /// `test_episodes` × `test_frames_per_episode`.
    pub(super) fn test(config: &super::RunConfig, town: u64) -> Self {
        Self {
            town: test_map_seed(town),
            episodes: config.test_episodes,
            frames_per_episode: config.test_frames_per_episode,
            noise: "test-noise",
        }
    }

    /// The validation that chooses among the best designs: another town of the test family
    /// (never trained on, never tested on), one episode of each illumination, 10 frames each.
    pub(super) fn validation() -> Self {
        Self { town: test_map_seed(1), episodes: 4, frames_per_episode: 10, noise: "validation" }
    }
}

/// When a test town's scored sequences start, seconds into the episode (before the warm-up).
pub(super) const TOWN_START_S: f64 = 1.0;

/// The towns of `plan`, one per illumination: episode e drives `Illumination::ALL[e % 4]`, so
/// every light gets the same number of episodes (within one). Built once per run.
pub(super) fn towns(cx: &mut Context, plan: Plan) -> Vec<Arc<Simulator>> {
    Illumination::ALL.iter().map(|&il| cx.scenes.town(plan.town, Some(il))).collect()
}

/// Closed-loop evaluation of `design` with the trained controller (`plan`: the test, or the
/// validation). With `out`, also writes the per-frame trace and the showcase sequences there.
pub(super) fn test(
    cx: &mut Context,
    model: &mut JointModel,
    design: &CameraDesign,
    plan: Plan,
    out: Option<&Path>,
) -> Result<Tested, TrainError> {
    let c = cx.config.clone();
    let camera = design.view(&c.input, c.lens);
    let mut metrics = TaskMetrics::default();
    // The same frames scored per illumination (the tunnel exit and the day–night cycle are
    // where the paper claims a controller's gain).
    let mut metrics_by_light: BTreeMap<Light, TaskMetrics> = BTreeMap::new();
    let mut sums: BTreeMap<Light, LightSums> = BTreeMap::new();
    let mut trace = String::new();
    let real = cx.scenes.real.clone();
    // The test is stratified by illumination: episode e drives the test town under
    // `Illumination::ALL[e % 4]` (day, night, tunnel, cycle), so every light gets the same
    // number of episodes (within one), whatever the episodes' own draws would have been.
    // Recordings have their own light, and no towns are built for them.
    // Built once per run (the validation re-scores several designs on the same towns).
    let towns: Vec<Arc<Simulator>> = if real.is_some() { Vec::new() } else { towns(cx, plan) };
    // Recorded sequences are played from their start; the test town from TOWN_START_S.
    let start_s = if real.is_some() { 0.0 } else { TOWN_START_S };
    for episode in 0..plan.episodes {
        let town = towns.get(episode as usize % Illumination::ALL.len());
        let source: &dyn FrameSource = match (&real, town) {
            (Some(r), _) => r.test(),
            (None, Some(town)) => &**town,
            (None, None) => unreachable!("the test towns are built above without a recording"),
        };
        let mut driver =
            cx.rigs.driver(model, design, source.frame_interval_s(), cx.test.controller);
        for k in 0..WARMUP_FRAMES + plan.frames_per_episode {
            let time_s = start_s + k as f64 * source.frame_interval_s();
            let mut noise = cx.streams.indexed(plan.noise, episode * 10_000 + k as u64);
            let s = driver.step(model, source, (episode, time_s), &mut noise)?;
            if k < WARMUP_FRAMES {
                continue;
            }
            metrics.update(&s.frame.boxes, &s.frame.ignore, &s.detections, s.frame.visible_180);
            let (light, ambient) = match (&real, town) {
                (None, Some(town)) => (
                    light_of(Some(town.episode(episode).illumination)),
                    Some(town.ambient_at(episode, time_s)),
                ),
                _ => (Light::Recorded, None),
            };
            sums.entry(light).or_default().add(s.settings, s.mean_dn, s.clipped);
            metrics_by_light.entry(light).or_default().update(
                &s.frame.boxes,
                &s.frame.ignore,
                &s.detections,
                s.frame.visible_180,
            );
            let record = TraceRecord {
                episode,
                frame: k - WARMUP_FRAMES,
                time_s,
                illumination: light,
                ambient,
                settings: s.settings,
                objects: s.frame.boxes.len(),
                visible_180: s.frame.visible_180,
                detections: s.detections.len(),
                mean_dn: Some(s.mean_dn),
            };
            if let Ok(line) = serde_json::to_string(&record) {
                let _ = writeln!(trace, "{line}");
            }
        }
    }
    let by_light = ByLight(
        sums.iter()
            .map(|(light, v)| {
                // The f-number's mean is geometric (in stops), where the controller set the iris.
                let f_number =
                    (v.iris_frames > 0.0).then(|| (v.log_f_number / v.iris_frames).exp());
                let settings = Settings {
                    exposure_ms: v.exposure_ms / v.frames,
                    gain_db: v.gain_db / v.frames,
                    f_number,
                };
                let record = LightResults {
                    scores: metrics_by_light.get(light).map(TaskMetrics::compute),
                    settings: Some(settings),
                    exposure_gain_ms: Some(v.exposure_gain_ms / v.frames),
                    mean_dn: Some(v.mean_dn / v.frames),
                    clipped_share: Some(v.clipped / v.frames),
                };
                (*light, record)
            })
            .collect(),
    );
    if let Some(dir) = out {
        std::fs::create_dir_all(dir).map_err(|e| TrainError::io(dir, e))?;
        write_atomic(&dir.join("trace.jsonl"), &trace)?;
        // The showcases drive the test's town (tunnel, day, night): not part of a real-image run.
        let showcases =
            if real.is_some() { Vec::new() } else { showcases(cx, model, design, &camera, dir)? };
        write_atomic(
            &dir.join("showcase.json"),
            &serde_json::to_string(&showcases).unwrap_or_default(),
        )?;
    }
    Ok(Tested { scores: metrics.compute(), bands: metrics.bands(), by_light })
}

/// Sums over the test frames of one illumination, for their means.
#[derive(Default)]
struct LightSums {
    exposure_ms: f64,
    gain_db: f64,
    /// Exposure (ms) × linear gain.
    exposure_gain_ms: f64,
    mean_dn: f64,
    /// Share of clipped pixels.
    clipped: f64,
    frames: f64,
    /// Sum of ln f-number over the frames whose iris the controller set, and their count.
    log_f_number: f64,
    iris_frames: f64,
}

impl LightSums {
    fn add(&mut self, settings: Settings, mean_dn: f64, clipped: f64) {
        if let Some(n) = settings.f_number {
            self.log_f_number += n.ln();
            self.iris_frames += 1.0;
        }
        self.exposure_ms += settings.exposure_ms;
        self.gain_db += settings.gain_db;
        self.exposure_gain_ms += settings.exposure_gain_ms();
        self.mean_dn += mean_dn;
        self.clipped += clipped;
        self.frames += 1.0;
    }
}

/// What a closed-loop evaluation found.
pub(super) struct Tested {
    /// Scores over every frame.
    pub(super) scores: TaskScores,
    /// Scores per distance band.
    pub(super) bands: Vec<BandScores>,
    /// Scores, settings and frame levels by illumination.
    pub(super) by_light: ByLight,
}

/// The showcase sequences: a tunnel transition (every frame saved), a day and a night drive
/// (last frame saved). Same town (the test's: the test town, or `joca eval --town`'s), episodes
/// and times for every run, so different methods are compared on the same scenes.
fn showcases(
    cx: &mut Context,
    model: &mut JointModel,
    design: &CameraDesign,
    camera: &PinholeCamera,
    dir: &Path,
) -> Result<Vec<Showcase>, TrainError> {
    let mut out = Vec::new();
    for (index, (name, illumination)) in [
        ("tunnel", Illumination::Tunnel),
        ("day", Illumination::Day),
        ("night", Illumination::Night),
    ]
    .into_iter()
    .enumerate()
    {
        // The test has built these towns already: the run's simulator cache holds them.
        let sim = cx.scenes.town(test_map_seed(cx.test.town), Some(illumination));
        let dt = sim.frame_interval_s();
        let (episode, start_s, frames) = if illumination == Illumination::Tunnel {
            let (episode, start_s) = tunnel_showcase(&sim);
            (episode, start_s, TUNNEL_FRAMES)
        } else {
            (0, 1.0, STEADY_FRAMES)
        };
        let frame_dir = dir.join(name);
        std::fs::create_dir_all(&frame_dir).map_err(|e| TrainError::io(&frame_dir, e))?;
        let mut driver = cx.rigs.driver(model, design, dt, cx.test.controller);
        let mut sequence = Showcase {
            name: name.to_owned(),
            illumination: light_of(Some(illumination)),
            size_px: (camera.width_px, camera.height_px),
            frames: Vec::with_capacity(frames),
        };
        for k in 0..frames {
            let time_s = start_s + k as f64 * dt;
            let mut noise = cx.streams.indexed("showcase-noise", index as u64 * 10_000 + k as u64);
            let s = driver.step(model, &*sim, (episode, time_s), &mut noise)?;
            let save = illumination == Illumination::Tunnel || k + 1 == frames;
            let image = if save {
                let rel = format!("{name}/{k:03}.png");
                if let Some(image) = driver.last_image() {
                    write_png(&dir.join(&rel), image)?;
                }
                Some(rel)
            } else {
                None
            };
            sequence.frames.push(ShowcaseFrame {
                frame: k,
                time_s,
                ambient: sim.ambient_at(episode, time_s),
                settings: s.settings,
                boxes: s.frame.boxes,
                detections: s.detections,
                image,
            });
        }
        out.push(sequence);
    }
    Ok(out)
}

/// Writes an 8-bit RGB frame as PNG (temporary file, then rename).
fn write_png(path: &Path, image: &Rgb8Image) -> Result<(), TrainError> {
    let mut bytes = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new(&mut bytes);
    image::ImageEncoder::write_image(
        encoder,
        image.data(),
        image.width() as u32,
        image.height() as u32,
        image::ExtendedColorType::Rgb8,
    )
    .map_err(|e| TrainError::io(path, std::io::Error::other(e)))?;
    joca_core::fs::write_atomic(path, &bytes).map_err(|e| TrainError::io(path, e))
}
