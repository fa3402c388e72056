//! One exposure of a scene through a camera: the frame source renders `I0` over the shutter
//! interval (motion blur, ground truth at the shutter midpoint), then image formation (paper
//! Eq. 2–3) turns it into the sensor's 8-bit frame. Every consumer of formed frames — the joint
//! loop's perturbations, the closed-loop test, pre-training and its evaluation — captures
//! through [`capture`], so the exposure that sets the blur is always the one that sets the
//! brightness.

use crate::{DynamicSettings, ImageFormation};
use joca_core::{Frame, FrameRequest, FrameSource, PinholeCamera, Rgb8Image, SourceError};

/// A captured frame: the render with its ground truth, and the formed 8-bit image.
#[derive(Debug, Clone)]
pub struct Capture {
    /// `I0` blurred over the shutter interval, ground truth and the 180° object count.
    pub frame: Frame,
    /// What the sensor delivers.
    pub image: Rgb8Image,
}

impl ImageFormation {
    /// Renders `request` through `camera` with the shutter interval of `settings` (the
    /// request's own `exposure_s` is replaced by it) and forms the frame on a sensor of pitch
    /// `pixel_pitch_um`, drawing its noise from `noise`.
    pub fn capture(
        &self,
        source: &dyn FrameSource,
        camera: &PinholeCamera,
        request: &FrameRequest,
        settings: DynamicSettings,
        pixel_pitch_um: f64,
        noise: &mut impl rand::Rng,
    ) -> Result<Capture, SourceError> {
        let request = FrameRequest { exposure_s: settings.exposure_s, ..*request };
        let frame = source.render(camera, &request)?;
        let image = self.form(&frame.hdr, settings, pixel_pitch_um, noise);
        Ok(Capture { frame, image })
    }
}
