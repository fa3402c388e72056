//! What a frame source (the built-in simulator, a recorded dataset) gives the training loop.
//!
//! The source does not know about sensors or image formation: it receives a [`PinholeCamera`]
//! (what the camera design implies geometrically) and a [`FrameRequest`] (when, and for how long
//! the shutter is open) and returns the calibrated radiometry `I0`, already motion-blurred over
//! the shutter interval, with ground truth. Exposure scaling, gain, pixel area, noise and
//! clipping are image formation's job (`joca-camera`), so the same formation serves every source.

use crate::optics::Lens;
use crate::{Annotation, HdrImage};
use thiserror::Error;

/// A pinhole camera mounted on the vehicle, looking along the vehicle's heading.
///
/// Vehicle frame: origin at the vehicle centre on the ground, `x` forward, `y` left, `z` up,
/// metres. Image frame: `u` to the right, `v` down, pixels, origin at the top-left corner of the
/// top-left pixel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinholeCamera {
    /// Output width in pixels.
    pub width_px: usize,
    /// Output height in pixels.
    pub height_px: usize,
    /// Focal length in pixels, horizontal.
    pub fx_px: f64,
    /// Focal length in pixels, vertical.
    pub fy_px: f64,
    /// Principal point, pixels from the left edge.
    pub cx_px: f64,
    /// Principal point, pixels from the top edge.
    pub cy_px: f64,
    /// Camera centre in the vehicle frame, metres (`vehicle_from_camera` translation).
    pub mount_m: [f64; 3],
    /// The lens's aperture and focus, for sources that render defocus and diffraction
    /// ([`crate::optics`]); `None`: an ideal pinhole, every depth sharp (the paper's model).
    pub lens: Option<Lens>,
}

impl PinholeCamera {
    /// An ideal pinhole of `width_px × height_px` with focal lengths `(fx_px, fy_px)` and the
    /// principal point at the image centre, mounted at `mount_m`.
    pub fn centred(
        (width_px, height_px): (usize, usize),
        (fx_px, fy_px): (f64, f64),
        mount_m: [f64; 3],
    ) -> Self {
        Self {
            width_px,
            height_px,
            fx_px,
            fy_px,
            cx_px: width_px as f64 / 2.0,
            cy_px: height_px as f64 / 2.0,
            mount_m,
            lens: None,
        }
    }

    /// The same camera with its lens's iris at `f_number` (focus unchanged); `None` keeps the
    /// lens as it is. Refused for a pinhole, which has no iris.
    pub fn stopped_to(&self, f_number: Option<f64>) -> Result<Self, SourceError> {
        match (f_number, self.lens) {
            (None, _) => Ok(*self),
            (Some(f_number), Some(lens)) => {
                Ok(Self { lens: Some(Lens { f_number, ..lens }), ..*self })
            }
            (Some(n), None) => Err(SourceError::OutOfRange {
                reason: format!("f/{n} asked of a pinhole camera, which has no iris"),
            }),
        }
    }

    /// Horizontal field of view, radians.
    pub fn hfov_rad(&self) -> f64 {
        2.0 * (self.width_px as f64 / (2.0 * self.fx_px)).atan()
    }

    /// Vertical field of view, radians.
    pub fn vfov_rad(&self) -> f64 {
        2.0 * (self.height_px as f64 / (2.0 * self.fy_px)).atan()
    }
}

/// When a frame is taken and how.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameRequest {
    /// Episode the frame belongs to (fixes map, start pose, illumination, speed profile).
    pub episode: u64,
    /// The frame's time since the episode start, seconds: the middle of the shutter interval
    /// (the shutter is open over `time_s ± exposure_s · motion_scale / 2`; ground truth is of
    /// this instant, so frames of one instant with different exposures share it).
    pub time_s: f64,
    /// Shutter interval, seconds: motion during it is integrated (motion blur).
    pub exposure_s: f64,
    /// Multiplies all motion during the shutter only ("motion blur ×N" scenario); 1 = physical.
    pub motion_scale: f64,
}

/// One frame of an instant: its shutter, and the lens's f-number where the iris moves from frame
/// to frame (`None`: the camera's lens as it is).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shot {
    /// Shutter interval, seconds.
    pub exposure_s: f64,
    /// The iris's f-number for this frame (`None`: the lens's own).
    pub f_number: Option<f64>,
}

impl Shot {
    /// A shot at `exposure_s` through the lens as it is.
    pub fn exposure(exposure_s: f64) -> Self {
        Self { exposure_s, f_number: None }
    }
}

/// A rendered or loaded frame before image formation.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Calibrated radiometry `I0` in DN, motion-blurred over the shutter interval.
    pub hdr: HdrImage,
    /// Ground truth boxes of visible objects, at the shutter midpoint.
    pub boxes: Vec<Annotation>,
    /// Ignore regions: tight boxes of classed objects that are in view but outside the
    /// annotation rules (too small, too far, mostly occluded). A detection on one is neither a
    /// true nor a false positive (COCO's `iscrowd`, KITTI's "DontCare"), and training does not
    /// punish the detector for firing there: a 7-px-wide walker looks like an 8-px-wide one.
    pub ignore: Vec<Annotation>,
    /// Objects visible within a 180° horizontal field of view around the heading (the
    /// denominator of the TP-ratio metric); independent of the camera's own field of view.
    pub visible_180: u32,
    /// Instants averaged over the shutter interval to make the blur (1: a sharp frame).
    pub subframes: u32,
}

/// Why a source could not deliver a frame.
#[derive(Debug, Error)]
pub enum SourceError {
    /// The request is outside what the source holds (an episode or time that does not exist).
    #[error("frame request out of range: {reason}")]
    OutOfRange {
        /// What was out of range.
        reason: String,
    },
    /// Reading or decoding recorded data failed: the reader's error (it names the file), with
    /// its causes.
    #[error(transparent)]
    Recorded(Box<dyn std::error::Error + Send + Sync + 'static>),
}

/// Something that produces calibrated frames for a camera: the built-in simulator or a recorded
/// dataset. Implementations must be deterministic in (camera, request) and usable from several
/// threads at once (the training loop renders 1 + 4 images per step).
pub trait FrameSource: Send + Sync {
    /// Renders or loads the frame seen by `camera` for `request`.
    fn render(&self, camera: &PinholeCamera, request: &FrameRequest) -> Result<Frame, SourceError>;

    /// The frames of one instant for several exposures (`request.exposure_s` is replaced by each
    /// of `exposures_s` in turn), in that order. A source that can share work between them (the
    /// simulator renders every shutter from one grid of sub-frames) overrides this; the default
    /// renders each on its own.
    fn render_exposures(
        &self,
        camera: &PinholeCamera,
        request: &FrameRequest,
        exposures_s: &[f64],
    ) -> Result<Vec<Frame>, SourceError> {
        let shots: Vec<Shot> = exposures_s.iter().map(|&e| Shot::exposure(e)).collect();
        self.render_shots(camera, request, &shots)
    }

    /// The frames of one instant for several shots, each with its own shutter and iris, in that
    /// order (what [`Self::render_exposures`] does where the iris moves too). The default renders
    /// each on its own with [`PinholeCamera::stopped_to`].
    fn render_shots(
        &self,
        camera: &PinholeCamera,
        request: &FrameRequest,
        shots: &[Shot],
    ) -> Result<Vec<Frame>, SourceError> {
        shots
            .iter()
            .map(|shot| {
                let request = FrameRequest { exposure_s: shot.exposure_s, ..*request };
                self.render(&camera.stopped_to(shot.f_number)?, &request)
            })
            .collect()
    }

    /// Time between consecutive frames of an episode, seconds.
    fn frame_interval_s(&self) -> f64;
}
