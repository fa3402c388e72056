//! `results.json` and `best_design.json`: what a run's test found.

use crate::{ByLight, Method, Provenance, Scenario, Source, TestController, World, WorldLayout};
use joca_camera::{ApertureControl, DetectorInput, LensModel};
use joca_core::compute::{CpuKernels, Denormals, Precision};
use joca_core::weather::Weather;
use joca_metrics::{BandScores, TaskScores};
use serde::{Deserialize, Serialize};

/// The newest layout version of `results.json` this joca reads and writes; readers refuse a
/// newer one. Files without the field are version 0 (written before it existed): every field
/// added since has a default, so they are read by the same reader (no `input` there means the
/// older `render_scale` protocol, see [`RunResults::input_note`]). Version 2 adds the lens, the
/// weather and the design's f-number; a file that uses none of them is written as version 1,
/// which a reader of version 1 reads correctly ([`RunResults::layout_version`]). Version 3 adds
/// the controller-set aperture (`aperture`, `f_number_by_illumination`); version 4 cast shadows
/// (`cast_shadows`) and the sun's elevation range (`sun_elevation`), which an older reader would
/// otherwise drop in silence; version 5 the lens's veiling glare (`glare`) and the sun's disc
/// (`sun_disc`); version 6 the GPU (`device`); version 7 tunnels as places (`tunnels`); version 8
/// daylight that follows the sun's elevation (`sun_elevation.daylight`); version 9 tunnel drives in
/// one direction (`tunnels.drives`); version 10 streets whose lamps stay dark at night
/// (`dark_streets`).
pub const RESULTS_FORMAT_VERSION: u32 = 10;

/// Test results of a run (`results.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunResults {
    /// Layout version ([`RESULTS_FORMAT_VERSION`] when written; 0 in files older than it).
    #[serde(default)]
    pub format_version: u32,
    /// Method.
    pub method: Method,
    /// Scenario.
    pub scenario: Scenario,
    /// The run's `seed`.
    #[serde(default)]
    pub seed: u64,
    /// The evaluated design.
    pub design: DesignSummary,
    /// Test scores (`test.class_objects`: the reference objects each class's AP rests on).
    pub test: TaskScores,
    /// Test scores per distance band (simulator; empty for recordings without depth).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub test_bands: Vec<BandScores>,
    /// What the test measured under each light (`day`, `night`, `tunnel`, `cycle`; `recorded`
    /// for recordings): scores over the same frames as `test` split by the episode's light, mean
    /// settings (`[ms, dB]`), f-number (where the controller set the iris), exposure × gain and
    /// frame level — written as one map per quantity ([`ByLight`]). Older runs lack some.
    #[serde(flatten)]
    pub by_illumination: ByLight,
    /// Best hardware fitness seen in training.
    #[serde(default)]
    pub best_fitness: f64,
    /// The detector input every design's frames were resized to (absent in runs before it
    /// existed, which rendered each sensor at `render_scale` × its own grid).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub input: Option<DetectorInput>,
    /// Older runs only: the fraction of each sensor's grid they rendered.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub render_scale: Option<f64>,
    /// The test frames' source: `sim` (empty in older runs), `folder:DIR` or `waymo:DIR`.
    #[serde(default)]
    pub source: Source,
    /// What the perturbed frames were scored in during training: `fp32` or `bf16`
    /// (`run.scoring_precision`, float32 on a CPU without native bfloat16). Absent in older runs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scoring_precision: Option<Precision>,
    /// Which of libtorch's CPU kernels ran: `native` (the widest the CPU has) or `avx2`
    /// (`JOCA_CPU_KERNELS`). Absent in older runs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cpu_kernels: Option<CpuKernels>,
    /// How subnormal floats were handled: `flush` (to zero, joca's default) or `keep`
    /// (`JOCA_DENORMALS`; the numbers differ where subnormals occur). Absent in older runs,
    /// which kept them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub denormals: Option<Denormals>,
    /// The CPU the run's results were computed on (model name, family and model numbers where
    /// the CPU reports them, widest vector units): training repeats bit for bit on the same
    /// machine type, not across types. Empty in older runs; without the numbers before 2026-12-07.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub cpu: String,
    /// The GPU the networks ran on (index, name, memory, driver, libtorch's CUDA runtime);
    /// absent where they ran on the CPU.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device: Option<String>,
    /// The controller the test drove the design with when it was not the run's own (`joca eval
    /// --controller average:DN`, written `average-DN`); absent for the run's own test.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_controller: Option<TestController>,
    /// The town of the test family the test drove when it was not the test town (`joca eval
    /// --town K`, K ≥ 2: fresh scenes of the same kind); absent for the run's own test.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_town: Option<u64>,
    /// The detector weights the test used in place of the run's own trained detector (`joca eval
    /// --detector start`: the file its detector started from, as its config names it); absent
    /// for the run's own detector.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_detector: Option<String>,
    /// How training's perturbation searches were decided (absent for methods without them, and
    /// in older runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub perturbation_ties: Option<SearchTies>,
    /// How the designs' lenses imaged the scene (absent: the paper's ideal pinhole).
    #[serde(default, skip_serializing_if = "is_pinhole")]
    pub lens: LensModel,
    /// The weather of training and test (absent: clear air).
    #[serde(default, skip_serializing_if = "is_clear")]
    pub weather: Weather,
    /// The world's light in training and test (each part absent: the default).
    #[serde(flatten)]
    pub world: World,
    /// Who set the aperture frame by frame (absent: `fixed`, the design's f-number).
    #[serde(default, skip_serializing_if = "ApertureControl::is_fixed")]
    pub aperture: ApertureControl,
    /// The best designs of training, re-scored on the validation town; the tested design is the
    /// first (empty when there was only one design to choose, or for recordings).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub validation: Vec<Validated>,
    /// Which joca, commit and configuration computed this record (absent in older runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
}

fn is_pinhole(lens: &LensModel) -> bool {
    *lens == LensModel::Pinhole
}

fn is_clear(weather: &Weather) -> bool {
    *weather == Weather::Clear
}

/// How many perturbation searches ran in training, and in how many two or more members tied for
/// the best score, so that the tie-break (or the GA's order) chose the target of l_GA.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SearchTies {
    /// Searches run.
    pub searches: u64,
    /// Searches whose best score was shared.
    pub tied: u64,
}

impl SearchTies {
    /// Adds another count.
    pub fn add(&mut self, other: SearchTies) {
        self.searches += other.searches;
        self.tied += other.tied;
    }

    /// The share of searches a tie decided (NaN without searches).
    pub fn share(&self) -> f64 {
        if self.searches == 0 { f64::NAN } else { self.tied as f64 / self.searches as f64 }
    }
}

/// A design as the validation scored it, with its training fitness.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Validated {
    /// The design.
    pub design: DesignSummary,
    /// Its best fitness in training (its own scenes, the model of that time).
    pub training_fitness: f64,
    /// Its scores on the validation town with the final model.
    pub validation: TaskScores,
}

impl RunResults {
    /// The lowest layout version that holds this record: 10 with dark streets, 9 with tunnel
    /// drives in one direction, 8 with a clear sky's daylight, 7 with tunnels as places, 6 with
    /// a GPU, 5 with veiling glare or the sun's disc, 4 with cast shadows or another sun, 3
    /// where the controller set the aperture, 2 where it uses a field of version 2 (a thin lens,
    /// weather, a design's f-number), else 1.
    pub fn layout_version(&self) -> u32 {
        match self.world.layout() {
            WorldLayout::DarkStreets => 10,
            WorldLayout::TunnelDrives => 9,
            WorldLayout::Daylight => 8,
            WorldLayout::TunnelPlaces => 7,
            _ if self.device.is_some() => 6,
            WorldLayout::GlareOrDisc => 5,
            WorldLayout::ShadowsOrSun => 4,
            WorldLayout::Default if !self.aperture.is_fixed() => 3,
            WorldLayout::Default => {
                let v2 = self.lens != LensModel::Pinhole
                    || self.weather != Weather::Clear
                    || self.design.f_number.is_some()
                    || self.validation.iter().any(|v| v.design.f_number.is_some());
                if v2 { 2 } else { 1 }
            }
        }
    }

    /// Refuses a layout newer than this joca reads, naming both versions.
    pub fn check_version(&self) -> Result<(), String> {
        if self.format_version > RESULTS_FORMAT_VERSION {
            return Err(format!(
                "format_version {} is newer than this joca reads (0 to {RESULTS_FORMAT_VERSION}): \
                 read it with the joca that wrote it, or a newer one",
                self.format_version
            ));
        }
        Ok(())
    }

    /// How the frames reached the detector, for a report: the input rule, or an older run's
    /// render scale.
    pub fn input_note(&self) -> String {
        match (self.input, self.render_scale) {
            (Some(i), _) => format!(
                "detector input short side {} px, long side ≤ {} px, {} resize from each sensor's \
                 grid",
                i.short_px, i.long_max_px, i.resampler
            ),
            (None, Some(s)) => format!("render scale {s} of each sensor's grid (an older run)"),
            (None, None) => "input size not recorded".to_owned(),
        }
    }

    /// The optics, air and sunlight beyond the paper's, for a report: `""`, or e.g. ` through a
    /// thin lens, in fog:300, the sun casting shadows`.
    pub fn conditions_note(&self) -> String {
        let mut note = String::new();
        if self.lens == LensModel::Thin {
            note.push_str(" through a thin lens (defocus and diffraction by depth)");
        }
        if self.weather != Weather::Clear {
            note.push_str(&format!(", in {}", self.weather));
        }
        note.push_str(&self.world.note());
        note
    }

    /// Whether the run was tested on recorded frames (the real-image mode).
    pub fn real_images(&self) -> bool {
        self.source.is_recording()
    }
}

/// A design as the result tables show it (`best_design.json`, and in `results.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DesignSummary {
    /// Forward position in the vehicle frame, m.
    pub x_m: f64,
    /// Height, m.
    pub z_m: f64,
    /// Focal length, mm.
    pub focal_length_mm: f64,
    /// Sensor name.
    pub sensor: String,
    /// Sensor width × height, mm.
    pub sensor_mm: (f64, f64),
    /// Pixel pitch, µm.
    pub pixel_pitch_um: f64,
    /// Whether the hardware GA optimised the design (else it was fixed).
    pub optimised: bool,
    /// Lens f-number (absent: the calibration's f/16, as in every run before the aperture gene).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub f_number: Option<f64>,
}

impl DesignSummary {
    /// The focal length with the aperture where it is not the calibration's f/16:
    /// `5.19` or `5.19 f/2.8`.
    pub fn lens_label(&self) -> String {
        match self.f_number {
            Some(n) => format!("{:.2} f/{n:.1}", self.focal_length_mm),
            None => format!("{:.2}", self.focal_length_mm),
        }
    }

    /// Horizontal field of view, radians.
    pub fn hfov_rad(&self) -> f64 {
        2.0 * (self.sensor_mm.0 / (2.0 * self.focal_length_mm)).atan()
    }
}
