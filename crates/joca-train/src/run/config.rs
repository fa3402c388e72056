//! The `[run]` table: every field of a joint run, checked once by [`RunConfig::validate`].

pub use super::aperture::FNumberRange;
use super::hardware::HardwareMutation;
use super::method::{DesignSpec, FixedCamera};
pub use super::reference::{MAX_REFERENCE_RANGE_M, ReferenceConfig};
pub use super::source::{RealConfig, Source};
use crate::TrainError;
use checks::range_error;
pub(crate) use checks::{check_detector, check_input};
use joca_camera::{ApertureControl, CameraDesign, CameraError, DetectorInput, LensModel};
use joca_core::optics::F_NUMBER_RANGE;
use joca_nn::detector::{DetectorConfig, Precision};
use joca_nn::device::DeviceChoice;
use joca_nn::formation::ClipGradient;
use joca_record::{Method, Scenario};
use joca_sim::{Glare, SunElevation, Tunnels, Weather};
use serde::{Deserialize, Deserializer, Serialize};

pub use learning::{AccOutput, WarmStart};
use learning::{
    bf16_where_native, is_paper_detector_lr, is_training_min_box_px, is_zero, paper_acc_lr,
    paper_detector_lr, training_min_box_px,
};
pub use search::{
    PERTURBATION_HALF_RANGE, PerturbationMutation, PerturbationScore, PerturbationSteps, TieBreak,
    TrainingScenes,
};
use std::path::PathBuf;

/// The highest ego top speed, m/s (144 km/h).
pub const MAX_SPEED_MPS: f64 = 40.0;

/// Settings of a run (the `[run]` table of a preset).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// Run seed.
    pub seed: u64,
    /// libtorch and rayon threads.
    pub threads: usize,
    /// What the networks compute on: `cpu` (the default), `cuda` (the first GPU), `cuda:N` or
    /// `auto` (the first GPU where one is usable, else the CPU). The renderer and the 8-bit
    /// formation run on the CPU's threads either way.
    #[serde(default, skip_serializing_if = "DeviceChoice::is_cpu")]
    pub device: DeviceChoice,
    /// Method.
    pub method: Method,
    /// Scenario.
    pub scenario: Scenario,
    /// Camera of `fixed-neural`.
    pub camera: FixedCamera,
    /// A fixed design for any method (`design = { sensor, focal_length_mm, x_m, z_m }`): the
    /// hardware GA is off and every candidate drives this design, so methods can be compared on
    /// identical hardware (a design panel). `fixed-neural` drives it in place of `camera`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub design: Option<DesignSpec>,
    /// Hardware GA generations.
    pub generations: usize,
    /// Hardware GA population.
    pub population: usize,
    /// Steps (frames) per hardware candidate, k.
    pub steps_per_candidate: usize,
    /// Perturbation GA population, n.
    pub perturbation_population: usize,
    /// The perturbation GA's mutation: `additive` (default) or `paper`.
    #[serde(default)]
    pub perturbation_mutation: PerturbationMutation,
    /// How perturbation members whose AP50 or mAP ties are ranked: `clipping` (fewer clipped
    /// pixels first) or `none` (the GA's order).
    #[serde(default)]
    pub perturbation_tie_break: TieBreak,
    /// What scores a perturbation member: `loss` (the presets': the detector's task loss on the
    /// perturbed frame, lower better), `ap50` (the paper's: the perturbed frame's AP50; what
    /// a configuration without this field, written before it existed, ran) or `map`.
    #[serde(default)]
    pub perturbation_score: PerturbationScore,
    /// Frames an `ap50` or `map` score pools (1 to 400; default 1, the perturbed frame alone):
    /// each member's detections are ranked with those of the W − 1 frames the controller
    /// captured before it in the candidate's sequence, as the test ranks every frame's.
    #[serde(default = "search::one_frame", skip_serializing_if = "search::is_one_frame")]
    pub perturbation_window: usize,
    /// How a perturbation offsets the exposure: `linear` (the paper's: a share of the range in
    /// milliseconds) or `relative` (a share of the log-exposure range: a factor).
    #[serde(default)]
    pub perturbation_steps: PerturbationSteps,
    /// Which scenes a candidate learns from and is judged on: `shared` (default: the
    /// generation's, for training and fitness alike) or `fresh` (its own training scenes, and a
    /// fitness from the generation's common scenes, inference only).
    #[serde(default, skip_serializing_if = "TrainingScenes::is_shared")]
    pub training_scenes: TrainingScenes,
    /// With `fresh` scenes, the common frames each candidate is judged on (1 to 400; default
    /// `steps_per_candidate`), split over the four lights as training's are.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub judge_frames: Option<usize>,
    /// The gradient of the differentiable formation's clip: `clamp` (none where a pixel
    /// saturates) or `straight-through`.
    #[serde(default)]
    pub clip_gradient: ClipGradient,
    /// What the perturbation search runs the detector in when it scores the perturbed frames:
    /// `bf16` (default: bfloat16 convolutions, float32 weights and outputs) or `fp32`. `bf16`
    /// applies only on a CPU with native bfloat16 (AVX-512 BF16) and is float32 elsewhere; the
    /// run's header and `results.json` (`scoring_precision`) say which ran. Training and the
    /// test always run in float32. The scores only rank the members, and both precisions pick
    /// the same member in nearly every search (`joca bench step` counts it).
    #[serde(default = "bf16_where_native")]
    pub scoring_precision: Precision,
    /// NeuralAE's Adam learning rate (paper: 1e-5).
    #[serde(default = "paper_acc_lr")]
    pub acc_lr: f64,
    /// How NeuralAE outputs exposure and gain: `absolute` (the paper's) or `relative:S`.
    #[serde(default, skip_serializing_if = "AccOutput::is_absolute")]
    pub acc_output: AccOutput,
    /// NeuralAE's warm start before DF-Grad (`warm_start = { frames, lr }`; default none).
    #[serde(default, skip_serializing_if = "WarmStart::is_off")]
    pub warm_start: WarmStart,
    /// The detector's AdamW learning rate in joint training (paper: 1e-4).
    #[serde(default = "paper_detector_lr", skip_serializing_if = "is_paper_detector_lr")]
    pub detector_lr: f64,
    /// GA loss applied every i steps.
    pub ga_every: usize,
    /// Task-loss weight of the ACC loss (GA loss weight 1).
    pub task_weight: f64,
    /// Weight of NeuralAE's step cost (the mean square stops it moves exposure and gain a
    /// frame; beyond the paper, default 0: none).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub step_weight: f64,
    /// Smallest box side, px, that the joint loop trains on (the detector's loss and the
    /// loss-scored perturbation search): smaller reference objects are ignore regions there, but
    /// every evaluation counts them. 1 trains on every reference object.
    #[serde(default = "training_min_box_px", skip_serializing_if = "is_training_min_box_px")]
    pub min_box_px: f64,
    /// The detector's input (`input = { short_px, long_max_px, resampler }`): every design's
    /// frames are rendered at this size with the design's own field of view, and carry the
    /// noise of the sensor's native grid through the resize.
    pub input: DetectorInput,
    /// The hardware GA's mutation: `tacos` (default: ×U(0.8, 1.2) plus an additive U(−3, 3) in
    /// gene units, mount genes a third of their range, 3 elites in 10) or `paper` (×U(0.8, 1.2)
    /// only, the best half kept: offspring cannot leave a sensor their parents share).
    #[serde(default)]
    pub hardware_mutation: HardwareMutation,
    /// How every design's lens images the scene: `pinhole` (default: the paper's ideal pinhole
    /// at f/16's light) or `thin` (a thin lens at the design's f-number, focused at its
    /// hyperfocal distance: defocus and diffraction by depth, light ∝ 1/N²).
    #[serde(default, skip_serializing_if = "is_pinhole")]
    pub lens: LensModel,
    /// The f-numbers the hardware GA may choose (`f_number = { min, max }`, f/1 to f/32;
    /// default f/16 to f/16: the calibration's aperture, no gene). A range needs `lens = "thin"`.
    /// Fixed cameras and panel designs keep their own (f/16 unless stated).
    #[serde(default, skip_serializing_if = "FNumberRange::is_calibration")]
    pub f_number: FNumberRange,
    /// Who sets the aperture frame by frame: `fixed` (default: the design's f-number) or
    /// `dynamic` (NeuralAE also sets the iris, from the design's f-number to f/16, trained by
    /// the same DF-Grad; needs `lens = "thin"` and a NeuralAE method).
    #[serde(default, skip_serializing_if = "ApertureControl::is_fixed")]
    pub aperture: ApertureControl,
    /// The air of every training and test episode: `clear` (default), `fog:V` (Koschmieder
    /// fog of visibility V metres, 10 to 100000) or `rain:R` (R mm/h, 0.1 to 200: Marshall–Palmer
    /// drops' extinction and streaks); the reference objects are unchanged, so a fogged-out
    /// object is a miss.
    #[serde(default, skip_serializing_if = "is_clear")]
    pub weather: Weather,
    /// Let the sun cast shadows in every training and test town (`true` or `false`, default
    /// false): buildings, vehicles, walkers, signs and posts shadow the ground, facades and each
    /// other by day, the shadowed surface keeping the sky's share. Simulator only.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub cast_shadows: bool,
    /// The sun's elevation in every training and test episode, drawn uniformly per episode
    /// (`sun_elevation = { min_deg, max_deg }`, 2 to 90 degrees; default 45 to 55, where daylight
    /// white reads 203–225 DN). Simulator only.
    #[serde(default, skip_serializing_if = "SunElevation::is_default")]
    pub sun_elevation: SunElevation,
    /// Every lens's veiling glare in training and test (`glare = { fraction, scale_deg }`:
    /// the share of the light spread, 0 to below 1, default 0 = none; the spread's angular
    /// scale, 0.1 to 20 degrees, default 1). Simulator only.
    #[serde(default, skip_serializing_if = "Glare::is_default")]
    pub glare: Glare,
    /// The sun in the sky by day (`true` or `false`, default false): the sky brightens towards
    /// it (the CIE clear sky's indicatrix) and its disc is drawn where a camera sees it, about
    /// 46,000 times as bright as white paper in its light, so it clips any camera and, with
    /// `glare`, veils the frame. In view only where the sun stands low (`sun_elevation`).
    /// Simulator only.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub sun_disc: bool,
    /// What the `tunnel` light is in every training and test town (`tunnels = { kind, count,
    /// lamp_level }`): `kind = "switch"` (default: the whole frame's ambient light switches
    /// every 4 s) or `"places"` (`count` road blocks a town covered by a tunnel, 1 to 16,
    /// default 6, lit by lamps at `lamp_level` of daylight, above 0 to 0.1, default 0.01; a
    /// `tunnel` episode drives through one in daylight, passing a mouth 1.3–2.7 s in).
    /// Simulator only.
    #[serde(default, skip_serializing_if = "Tunnels::is_default")]
    pub tunnels: Tunnels,
    /// Streets whose lamps stay dark at night (`true` or `false`, default false): the posts
    /// stand where they would (the same towns and draws), but at night the street has only the
    /// cars' head and tail lights, the lit windows and the night sky, so oncoming head lights
    /// are the brightest things in a dark frame. Tunnel lamps stay lit, and so do the `tunnel`
    /// switch's (its dark phases are lit by the street lamps, standing in for a tunnel's): only
    /// night and the cycle's dark hours change. Simulator only.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub dark_streets: bool,
    /// Training towns.
    pub train_maps: u64,
    /// Ego top speed, m/s.
    pub max_speed_mps: f64,
    /// Detector size.
    pub detector: DetectorConfig,
    /// Detector weights to start from (relative paths are relative to the working directory);
    /// absent: train from scratch. `frozen-detector` requires them. Older files wrote "none" as
    /// `detector_weights = ""`, which still reads as absent.
    #[serde(default, deserialize_with = "empty_is_none", skip_serializing_if = "Option::is_none")]
    pub detector_weights: Option<PathBuf>,
    /// Test episodes on the test town, stratified by illumination (episode e: day, night,
    /// tunnel, cycle for e mod 4).
    pub test_episodes: u64,
    /// Scored frames per test episode.
    pub test_frames_per_episode: usize,
    /// Frame source for training: the built-in simulator (`sim`, or empty), or a recording for
    /// the real-image mode (`folder:DIR`, `waymo:DIR`).
    #[serde(default)]
    pub source: Source,
    /// Frame source for testing; `sim` (or empty): the test town, or in real-image mode the
    /// training recording itself (say so when you report it).
    #[serde(default)]
    pub test_source: Source,
    /// How recorded frames are read (real-image mode only).
    #[serde(default)]
    pub real: RealConfig,
    /// Which simulated objects every design is scored against (`[run.reference]`).
    #[serde(default)]
    pub reference: ReferenceConfig,
}

fn is_clear(weather: &Weather) -> bool {
    *weather == Weather::Clear
}

fn is_pinhole(model: &LensModel) -> bool {
    *model == LensModel::Pinhole
}

impl RunConfig {
    /// Checks every field against a finite range that fits a workstation (docs/design.md: a user's
    /// mistake is refused naming the field and the range); the error names the field and what
    /// is allowed.
    pub fn validate(&self) -> Result<(), TrainError> {
        let bad = checks::refuse;
        let counts: [(&str, u64, u64, u64); 9] = [
            ("threads", self.threads as u64, 1, 64),
            ("generations", self.generations as u64, 1, 10_000),
            ("population", self.population as u64, 2, 1_000),
            ("steps_per_candidate", self.steps_per_candidate as u64, 2, 400),
            ("perturbation_population", self.perturbation_population as u64, 2, 64),
            ("ga_every", self.ga_every as u64, 1, 400),
            ("train_maps", self.train_maps, 1, 1_000),
            ("test_episodes", self.test_episodes, 1, 10_000),
            // Episodes last 60 s at 10 frames/s; the test starts at 1 s after 3 warm-up frames.
            ("test_frames_per_episode", self.test_frames_per_episode as u64, 1, 500),
        ];
        for (field, value, min, max) in counts {
            if !(min..=max).contains(&value) {
                return bad(field, value.to_string(), &format!("{min} to {max}"));
            }
        }
        self.validate_learning()?;
        self.validate_search()?;
        check_input(&self.input, "run")?;
        if !(0.0..=MAX_SPEED_MPS).contains(&self.max_speed_mps) {
            return bad(
                "max_speed_mps",
                self.max_speed_mps.to_string(),
                &format!("0 to {MAX_SPEED_MPS}"),
            );
        }
        for (field, v) in [
            ("reference.vehicle_m", self.reference.vehicle_m),
            ("reference.walker_m", self.reference.walker_m),
            ("reference.traffic_sign_m", self.reference.traffic_sign_m),
        ] {
            if !(v > 0.0 && v <= MAX_REFERENCE_RANGE_M) {
                return bad(
                    field,
                    v.to_string(),
                    &format!("above 0 m, at most {MAX_REFERENCE_RANGE_M} m"),
                );
            }
        }
        check_detector(&self.detector, "run")?;
        let (lo, hi) = F_NUMBER_RANGE;
        let range = &format!("{lo} to {hi}, min at most max");
        let f = self.f_number;
        if !(f.min >= lo && f.min <= hi) {
            return bad("f_number.min", f.min.to_string(), range);
        }
        if !(f.max >= f.min && f.max <= hi) {
            return bad("f_number.max", f.max.to_string(), range);
        }
        self.validate_world()?;
        if self.lens == LensModel::Thin && self.source.is_recording() {
            return bad(
                "lens",
                "\"thin\"".into(),
                "\"pinhole\" with a recording (recorded frames have no depth to defocus by)",
            );
        }
        if self.aperture == ApertureControl::Dynamic
            && (self.lens != LensModel::Thin || !self.method.neural())
        {
            return bad(
                "aperture",
                "\"dynamic\"".into(),
                "\"fixed\" unless lens = \"thin\" and the method's controller is NeuralAE (a \
                 pinhole has no iris; AverageAE sets exposure and gain only)",
            );
        }
        if self.lens == LensModel::Pinhole && !f.is_calibration() {
            return bad(
                "f_number",
                format!("{{ min = {}, max = {} }}", f.min, f.max),
                "16 to 16 with lens = \"pinhole\" (the pinhole has the calibration's light); set \
                 lens = \"thin\" to search the aperture",
            );
        }
        if self.method == Method::FrozenDetector && self.detector_weights.is_none() {
            return bad(
                "detector_weights",
                "none".into(),
                "a weights file from `joca train-detector` (frozen-detector freezes it)",
            );
        }
        if let Some(d) = &self.design {
            d.design().map_err(|e| design_error(e, d))?;
            if let Some(n) = d.f_number.filter(|&n| {
                self.lens == LensModel::Pinhole && n != joca_core::optics::CALIBRATION_F_NUMBER
            }) {
                return bad(
                    "design.f_number",
                    n.to_string(),
                    "16 or absent with lens = \"pinhole\" (the pinhole has the calibration's \
                     light); set lens = \"thin\" for a design behind another f-number",
                );
            }
        }
        self.real.folder_config()?;
        Ok(())
    }

    /// Whether the hardware GA designs the camera: the method searches and no `design` is
    /// fixed.
    pub fn hardware_search(&self) -> bool {
        self.method.hardware_ga() && self.design.is_none()
    }

    /// The design every candidate drives when the hardware is not searched: `design`, else
    /// `camera`'s.
    pub fn fixed_design(&self) -> Result<CameraDesign, TrainError> {
        match &self.design {
            Some(d) => d.design().map_err(|e| design_error(e, d)),
            None => Ok(self.camera.design()),
        }
    }
}

/// A `[run] design` error, naming the field.
fn design_error(e: CameraError, d: &DesignSpec) -> TrainError {
    match e {
        CameraError::UnknownSensor { valid, .. } => TrainError::Config {
            field: "run.design.sensor".into(),
            value: format!("{:?}", d.sensor),
            allowed: format!("a catalogue sensor: {valid}"),
        },
        other => range_error(other, "run.design.", " (the paper's design space)"),
    }
}

/// `config.toml` of a run directory: the resolved `[run]` table.
#[derive(Serialize, Deserialize)]
pub(super) struct ConfigFile {
    pub(super) run: RunConfig,
}

/// Reads an optional path where older files wrote an empty string for "none".
fn empty_is_none<'de, D: Deserializer<'de>>(d: D) -> Result<Option<PathBuf>, D::Error> {
    let text = Option::<String>::deserialize(d)?;
    Ok(text.filter(|t| !t.is_empty()).map(PathBuf::from))
}

mod checks;
mod learning;
mod reading;
mod search;
mod world;

#[cfg(test)]
mod tests;
