//! A recording as a [`FrameSource`]: the frame nearest the requested time, in calibrated units,
//! with the requested exposure's motion blur along the flow to the next frame.

use super::{Recording, bad};
use crate::blur::motion_blur;
use joca_core::{Frame, FrameRequest, FrameSource, HdrImage, PinholeCamera, SourceError};
use std::path::Path;

impl FrameSource for Recording {
    /// Episode e is sequence e mod the number of sequences; the frame is the one nearest to
    /// `time_s` after the sequence's start (the last frame has no successor for the flow, so
    /// requests beyond it get the one before).
    fn render(&self, camera: &PinholeCamera, request: &FrameRequest) -> Result<Frame, SourceError> {
        let s = (request.episode % self.sequences.len() as u64) as usize;
        let seq = &self.sequences[s];
        let t0 = seq[0].timestamp_s;
        let k = seq
            .iter()
            .enumerate()
            .min_by(|a, b| {
                (a.1.timestamp_s - t0 - request.time_s)
                    .abs()
                    .total_cmp(&(b.1.timestamp_s - t0 - request.time_s).abs())
            })
            .map_or(0, |(i, _)| i)
            .min(seq.len() - 2);
        let (w, h) = (camera.width_px, camera.height_px);
        let frame = self.resized(s, k, w, h)?;
        let rec = &seq[k];
        let cal_gain = joca_core::units::linear_from_db(self.config.calibration_gain_db);
        let rec_gain = joca_core::units::linear_from_db(rec.gain_db);
        let to_calibrated =
            (self.config.calibration_exposure_s * cal_gain / (rec.exposure_s * rec_gain)) as f32;
        let data: Vec<f32> = frame
            .image
            .as_raw()
            .iter()
            .map(|&v| self.linear[usize::from(v)] * to_calibrated)
            .collect();
        let sharp = HdrImage::from_vec(w, h, data)
            .map_err(|e| bad(Path::new(&rec.origin.label()), e.to_string()))?;
        let dt = seq[k + 1].timestamp_s - rec.timestamp_s;
        let travel = (request.exposure_s / dt.max(1e-6) * request.motion_scale) as f32;
        let (hdr, subframes) = if travel > 0.0 {
            let flow = self.flow(s, k, w, h)?;
            let longest =
                flow.data().iter().map(|v| v[0].hypot(v[1])).fold(0.0f32, f32::max) * travel;
            (motion_blur(&sharp, &flow, travel), crate::blur::samples_for(longest) as u32)
        } else {
            (sharp, 1)
        };
        Ok(Frame {
            hdr,
            boxes: frame.boxes.clone(),
            ignore: frame.ignore.clone(),
            visible_180: frame.visible,
            subframes,
        })
    }

    fn frame_interval_s(&self) -> f64 {
        self.frame_interval_s
    }
}
