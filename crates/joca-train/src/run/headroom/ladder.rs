//! The settings ladder of `joca headroom`: rungs of exposure × gain, equally spaced in stops,
//! each split into an exposure and a gain the sensor can apply, and the AverageAE targets the
//! closed-loop rows hold (the `[ladder]` table of a configuration file).

use crate::TrainError;
use joca_camera::{AccRanges, DynamicSettings, MID_GREY_DN};
use joca_core::units::linear_from_db;
use serde::{Deserialize, Serialize};

/// How a rung's exposure × gain is split into an exposure time and a gain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LadderSplit {
    /// The longest exposure first (the least gain, so the least read noise; the most blur),
    /// gain above the lowest only where the exposure is at its cap: a camera's usual program.
    #[default]
    ExposureFirst,
    /// Equal stops of exposure and gain above their minima (AverageAE's √factor to each), the
    /// rest to the other where one reaches its cap.
    Balanced,
}

/// The `[ladder]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LadderConfig {
    /// The highest rung's exposure × linear gain, ms (at most the ACC's 50 ms × 30 dB).
    pub top_exposure_gain_ms: f64,
    /// Rungs below and including the top (1 to 64).
    pub steps: usize,
    /// Stops between rungs (above 0, at most 4).
    pub step_stops: f64,
    /// How each rung is split into exposure and gain.
    pub split: LadderSplit,
    /// The frame means AverageAE holds in the closed-loop rows, DN (each above 0 and below 255;
    /// mid-grey, 127.5, is always added: it is the reference).
    pub targets_dn: Vec<f64>,
    /// Also measure, at every rung and frame, the task loss's slope by the light in stops through
    /// the differentiable formation (the local pull DF-Grad's task gradient puts on the light),
    /// about three times a rung's detection cost.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub slopes: bool,
}

impl Default for LadderConfig {
    fn default() -> Self {
        Self {
            top_exposure_gain_ms: max_exposure_gain_ms(AccRanges::PAPER),
            steps: 14,
            step_stops: 1.0,
            split: LadderSplit::ExposureFirst,
            targets_dn: vec![40.0, 80.0, 170.0, 210.0],
            slopes: false,
        }
    }
}

/// The ACC range's largest exposure × linear gain, ms.
fn max_exposure_gain_ms(r: AccRanges) -> f64 {
    r.exposure_s.max * 1e3 * linear_from_db(r.gain_db.max)
}

/// The ACC range's smallest exposure × linear gain, ms.
fn min_exposure_gain_ms(r: AccRanges) -> f64 {
    r.exposure_s.min * 1e3 * linear_from_db(r.gain_db.min)
}

impl LadderConfig {
    /// Checks every field; errors name the field (`ladder.<field>`), the allowed range and
    /// `file`.
    pub fn validate(&self, ranges: AccRanges, file: &str) -> Result<(), TrainError> {
        let bad = |field: &str, value: String, allowed: String| {
            Err(TrainError::Config {
                field: format!("ladder.{field}"),
                value,
                allowed: format!("{allowed} (the [ladder] table of {file})"),
            })
        };
        let (lo, hi) = (min_exposure_gain_ms(ranges), max_exposure_gain_ms(ranges));
        if !(1..=64).contains(&self.steps) {
            return bad("steps", self.steps.to_string(), "1 to 64 rungs".into());
        }
        if !(self.step_stops > 0.0 && self.step_stops <= 4.0) {
            return bad("step_stops", self.step_stops.to_string(), "above 0, at most 4".into());
        }
        if !(self.top_exposure_gain_ms > lo && self.top_exposure_gain_ms <= hi) {
            return bad(
                "top_exposure_gain_ms",
                self.top_exposure_gain_ms.to_string(),
                format!("{lo:.4} to {hi:.1} ms (the ACC's exposure × gain range)"),
            );
        }
        let bottom = self.bottom_ms();
        if bottom < lo * (1.0 - 1e-9) {
            return bad(
                "steps",
                self.steps.to_string(),
                format!(
                    "at most {} rungs of {} stops below {} ms: the lowest rung, {bottom:.4} ms, \
                     is under the ACC's {lo:.4} ms",
                    1 + ((self.top_exposure_gain_ms / lo).log2() / self.step_stops).floor()
                        as usize,
                    self.step_stops,
                    self.top_exposure_gain_ms
                ),
            );
        }
        if let Some(t) = self.targets_dn.iter().find(|t| !(**t > 0.0 && **t < 255.0)) {
            return bad("targets_dn", t.to_string(), "each above 0 and below 255 DN".into());
        }
        Ok(())
    }

    /// The lowest rung's exposure × gain, ms.
    fn bottom_ms(&self) -> f64 {
        self.top_exposure_gain_ms * (-(self.steps as f64 - 1.0) * self.step_stops).exp2()
    }

    /// The AverageAE targets, mid-grey first, each once, in the order given.
    pub fn targets(&self) -> Vec<f64> {
        let mut t = vec![MID_GREY_DN];
        for &v in &self.targets_dn {
            if !t.iter().any(|x| (x - v).abs() < 1e-9) {
                t.push(v);
            }
        }
        t
    }

    /// The rungs, lowest first, as a sensor whose longest exposure is `max_exposure_s` (the
    /// ACC's, or a shorter frame interval) applies them.
    pub fn rungs(&self, ranges: AccRanges, max_exposure_s: f64) -> Vec<DynamicSettings> {
        (0..self.steps)
            .map(|i| {
                let ms = self.bottom_ms() * (i as f64 * self.step_stops).exp2();
                split(ms, self.split, ranges, max_exposure_s)
            })
            .collect()
    }
}

/// `exposure_gain_ms` as an exposure and a gain within `ranges` (exposure at most
/// `max_exposure_s`), by `how`. Where both settings are at a cap, the product is what the caps
/// allow.
pub fn split(
    exposure_gain_ms: f64,
    how: LadderSplit,
    ranges: AccRanges,
    max_exposure_s: f64,
) -> DynamicSettings {
    let (e_min, e_max) = (ranges.exposure_s.min, ranges.exposure_s.max.min(max_exposure_s));
    let (g_min, g_max) = (ranges.gain_db.min, ranges.gain_db.max);
    let total_s = exposure_gain_ms * 1e-3;
    let exposure_s = match how {
        LadderSplit::ExposureFirst => total_s / linear_from_db(g_min),
        LadderSplit::Balanced => {
            // Half the stops above (e_min, g_min) go to each setting.
            let stops = (total_s / (e_min * linear_from_db(g_min))).log2().max(0.0);
            e_min * (stops / 2.0).exp2()
        }
    }
    .clamp(e_min, e_max);
    let gain_db = (20.0 * (total_s / exposure_s).log10()).clamp(g_min, g_max);
    // Gain capped in the balanced split: the exposure takes the rest.
    let exposure_s = (total_s / linear_from_db(gain_db)).clamp(e_min, e_max);
    DynamicSettings::new(exposure_s, gain_db)
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: AccRanges = AccRanges::PAPER;

    fn product_ms(s: DynamicSettings) -> f64 {
        s.exposure_s * 1e3 * s.gain_linear()
    }

    #[test]
    fn the_default_ladder_spans_the_acc_range_in_whole_stops() {
        let l = LadderConfig::default();
        l.validate(R, "test.toml").unwrap();
        let rungs = l.rungs(R, 0.1);
        assert_eq!(rungs.len(), 14);
        // 50 ms × 10^(30/20) = 1581.1 ms at the top, 13 stops below it at the bottom.
        assert!((product_ms(rungs[13]) - 50.0 * 10f64.powf(1.5)).abs() < 1e-6);
        assert!((product_ms(rungs[0]) - 50.0 * 10f64.powf(1.5) / 8192.0).abs() < 1e-9);
        for w in rungs.windows(2) {
            assert!((product_ms(w[1]) / product_ms(w[0]) - 2.0).abs() < 1e-9);
        }
    }

    #[test]
    fn exposure_first_spends_gain_only_at_the_exposure_cap() {
        // 20 ms × 1 dB fits in the exposure; 200 ms needs the 50 ms cap and 4× (12.04 dB).
        let s = split(20.0 * linear_from_db(1.0), LadderSplit::ExposureFirst, R, 1.0);
        assert!((s.exposure_s - 0.020).abs() < 1e-12 && (s.gain_db - 1.0).abs() < 1e-9);
        let s = split(200.0, LadderSplit::ExposureFirst, R, 1.0);
        assert!((s.exposure_s - 0.050).abs() < 1e-12);
        assert!((s.gain_db - 20.0 * 4f64.log10()).abs() < 1e-9);
        // A frame interval shorter than the ACC's range caps the exposure there.
        let s = split(200.0, LadderSplit::ExposureFirst, R, 0.025);
        assert!((s.exposure_s - 0.025).abs() < 1e-12);
        assert!((s.gain_db - 20.0 * 8f64.log10()).abs() < 1e-9);
    }

    #[test]
    fn balanced_gives_each_setting_half_the_stops() {
        // 8 stops above (0.1 ms, 1 dB): 4 to each, 1.6 ms and 1 dB + 24.08 dB.
        let base = 0.1 * linear_from_db(1.0);
        let s = split(base * 256.0, LadderSplit::Balanced, R, 1.0);
        assert!((s.exposure_s - 1.6e-3).abs() < 1e-12);
        assert!((s.gain_db - (1.0 + 20.0 * 16f64.log10())).abs() < 1e-9);
        // 12 stops: gain would need 1 + 36.1 dB; capped at 30 dB, exposure takes the rest.
        let s = split(base * 4096.0, LadderSplit::Balanced, R, 1.0);
        assert!((s.gain_db - 30.0).abs() < 1e-12);
        assert!((product_ms(s) - base * 4096.0).abs() < 1e-9);
    }

    #[test]
    fn bad_ladders_are_refused_naming_field_range_and_file() {
        let refuse = |l: LadderConfig, field: &str| {
            let e = l.validate(R, "my.toml").unwrap_err().to_string();
            assert!(e.contains(&format!("ladder.{field}")) && e.contains("my.toml"), "{e}");
        };
        refuse(LadderConfig { steps: 0, ..Default::default() }, "steps");
        refuse(LadderConfig { step_stops: 0.0, ..Default::default() }, "step_stops");
        refuse(LadderConfig { step_stops: -1.0, ..Default::default() }, "step_stops");
        refuse(
            LadderConfig { top_exposure_gain_ms: 5000.0, ..Default::default() },
            "top_exposure_gain_ms",
        );
        refuse(LadderConfig { steps: 20, ..Default::default() }, "steps");
        refuse(LadderConfig { targets_dn: vec![300.0], ..Default::default() }, "targets_dn");
    }

    #[test]
    fn mid_grey_is_always_the_first_target() {
        let l = LadderConfig { targets_dn: vec![40.0, 127.5, 170.0], ..Default::default() };
        assert_eq!(l.targets(), vec![127.5, 40.0, 170.0]);
    }
}
