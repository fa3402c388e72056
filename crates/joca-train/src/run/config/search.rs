//! The perturbation search's options in `[run]`: its mutation, score, tie-break and steps.

joca_core::named_enum! {
    /// The perturbation GA's mutation.
    #[derive(Default)]
    pub enum PerturbationMutation("perturbation mutation") {
        /// The paper's: each gene × U(0.9, 1.1). Genes are offsets centred on zero, and neither
        /// this, crossover nor clipping changes a sign: once every member pushes exposure the same
        /// way, the GA loss pushes it that way in every light.
        Paper = "paper",
        /// The paper's, then a normal shift of 10 % of each gene's range, so both directions stay
        /// reachable.
        #[default]
        Additive = "additive",
    }
}

joca_core::named_enum! {
    /// How the perturbation search ranks members of equal AP50 or mAP (`perturbation_score`).
    #[derive(Default)]
    pub enum TieBreak("tie-break") {
        /// The share of clipped pixels (at 0 or 255) breaks ties, fewer first: a member's fitness
        /// is AP50 + 0.001 · (1 − clipped share). A single frame's AP50 often ties (0 for every
        /// member of a saturated day frame or a black night one); the task cannot tell the members
        /// apart there, and the one that keeps more of the scene within the sensor's range wins.
        #[default]
        Clipping = "clipping",
        /// AP50 alone; ties go to the GA's first member (the paper says nothing of ties).
        None = "none",
    }
}

joca_core::named_enum! {
    /// What scores a member of the perturbation search.
    #[derive(Default)]
    pub enum PerturbationScore("perturbation score") {
        /// The paper's: the perturbed frame's AP50 (ties ranked by `perturbation_tie_break`). One
        /// frame's AP50 takes few values, so members often tie (about nine searches in ten at
        /// `standard`). What a configuration that does not name the score means: runs made
        /// before the score was selectable scored by AP50, and their saved configurations must
        /// keep saying so.
        #[default]
        Ap50 = "ap50",
        /// The detector's task loss on the perturbed frame (the training loss, normalised by the
        /// frame's objects), lower better: continuous in the frame, so members rarely tie. Every
        /// preset names it: chosen over AP50 on a panel of six designs in calibrated and blur ×4
        /// (docs/results/2026-11-27-perturbation-panel.md).
        Loss = "loss",
        /// The perturbed frame's COCO mAP (AP at IoU 0.50–0.95, what the result tables report),
        /// higher better; with `perturbation_window` above 1 pooled with the frames before it
        /// in one ranking of confidences, as the test pools every frame's.
        Map = "map",
    }
}

/// The most frames `perturbation_window` pools.
pub const MAX_PERTURBATION_WINDOW: usize = 400;

impl super::RunConfig {
    /// The search fields' part of [`super::RunConfig::validate`]: the window's range, and that
    /// it pools a score that pools (a loss is a sum over frames: the frames before a member's
    /// add the same to every member's, so a window would rank them as one frame does).
    pub(super) fn validate_search(&self) -> Result<(), crate::TrainError> {
        let w = self.perturbation_window;
        if !(1..=MAX_PERTURBATION_WINDOW).contains(&w) {
            let allowed = format!("1 (the perturbed frame alone) to {MAX_PERTURBATION_WINDOW}");
            return super::checks::refuse("perturbation_window", w.to_string(), &allowed);
        }
        if w > 1 && self.perturbation_score == PerturbationScore::Loss {
            let allowed = "1 with perturbation_score = \"loss\" (a loss is a sum over frames); \
                           a window pools \"ap50\" or \"map\"";
            return super::checks::refuse("perturbation_window", w.to_string(), allowed);
        }
        match (self.judge_frames, self.training_scenes) {
            (Some(n), TrainingScenes::Fresh) if !(1..=MAX_JUDGE_FRAMES).contains(&n) => {
                let allowed = format!("1 to {MAX_JUDGE_FRAMES}");
                super::checks::refuse("judge_frames", n.to_string(), &allowed)
            }
            (Some(n), TrainingScenes::Shared) => super::checks::refuse(
                "judge_frames",
                n.to_string(),
                "unset with training_scenes = \"shared\" (a candidate is judged on the frames it \
                 trained on); set training_scenes = \"fresh\" to judge on common frames",
            ),
            _ => Ok(()),
        }
    }

    /// The common frames a candidate is judged on with `fresh` scenes: `judge_frames`, or as
    /// many as it trains on.
    pub fn judge_frames(&self) -> usize {
        self.judge_frames.unwrap_or(self.steps_per_candidate)
    }
}

/// The most frames `judge_frames` asks for.
pub const MAX_JUDGE_FRAMES: usize = 400;

/// Whether `perturbation_window` is 1 (the field is then left out of saved configurations).
pub(super) fn is_one_frame(w: &usize) -> bool {
    *w == 1
}

pub(super) fn one_frame() -> usize {
    1
}

/// The widest `perturbation_steps = "stops:S"` allows, stops on each of exposure and gain.
pub const MAX_PERTURBATION_STOPS: f64 = 4.0;

/// The perturbation genes' half-range in normalised units (the GA's bounds, ±5 %): what
/// `stops:S` maps to ±S stops.
pub const PERTURBATION_HALF_RANGE: f64 = 0.05;

/// How a perturbation offsets NeuralAE's exposure and gain (`perturbation_steps`): `"linear"`,
/// `"relative"` or `"stops:S"`, S in (0, 4].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum PerturbationSteps {
    /// The paper's: `E + p·(E_max − E_min)`, a share of the range in linear units (±5 % of
    /// 0.1–50 ms is ±2.5 ms, whatever E is); the gain (dB) by a share of its range.
    #[default]
    Linear,
    /// `E · (E_max/E_min)^p`, a share of the log-exposure range (±5 % is ×0.73–×1.36): the same
    /// relative reach at 1 ms and at 50 ms; the gain (dB) by a share of its range.
    Relative,
    /// Each of exposure and gain by up to ±S stops: a gene at the edge of its ±5 % range is a
    /// factor 2^±S on the exposure and ±6.02·S dB on the gain, so a member changes the frame's
    /// light by up to ±2S stops, whatever the settings — visibly, where ±5 % of the linear range
    /// is a twentieth of a stop at the 50 ms cap.
    Stops(f64),
}

impl PerturbationSteps {
    /// Reads `linear`, `relative` or `stops:S`, naming what is allowed.
    pub fn parse(text: &str) -> Result<Self, String> {
        match text {
            "linear" => return Ok(Self::Linear),
            "relative" => return Ok(Self::Relative),
            _ => {}
        }
        text.strip_prefix("stops:")
            .and_then(|s| s.parse::<f64>().ok())
            .filter(|s| *s > 0.0 && *s <= MAX_PERTURBATION_STOPS)
            .map(Self::Stops)
            .ok_or_else(|| {
                format!(
                    "\"{text}\": expected \"linear\", \"relative\" or \"stops:S\" with S the \
                     widest offset of each of exposure and gain, above 0 and at most \
                     {MAX_PERTURBATION_STOPS} stops"
                )
            })
    }
}

impl std::fmt::Display for PerturbationSteps {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Linear => f.write_str("linear"),
            Self::Relative => f.write_str("relative"),
            Self::Stops(s) => write!(f, "stops:{s}"),
        }
    }
}

joca_core::serde_as_text!(PerturbationSteps, PerturbationSteps::parse);

joca_core::named_enum! {
    /// Which scenes a hardware candidate learns from and is judged on.
    #[derive(Default)]
    pub enum TrainingScenes("training scenes") {
        /// Every candidate of a generation trains on the generation's scenes and is scored on the
        /// frames it trained on (common random numbers): with population P the detector and
        /// NeuralAE see each instant P times. What a configuration without the field ran.
        #[default]
        Shared = "shared",
        /// Each candidate trains on scenes no other candidate trains on (as in the paper's loop,
        /// where every training frame is new); its fitness comes from the generation's common
        /// scenes driven in closed loop after its training, inference only, so designs are still
        /// compared on identical scenes.
        Fresh = "fresh",
    }
}

impl TrainingScenes {
    /// Whether this is the default (the field is then left out of saved configurations).
    pub fn is_shared(&self) -> bool {
        *self == Self::Shared
    }
}
