//! [`Settings`]: a frame's exposure and gain as the records write them (milliseconds and
//! decibels), one shape for the step, trace and showcase records and the test's means.

use crate::Light;
use joca_camera::DynamicSettings;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::collections::BTreeMap;

/// Exposure (ms) and gain (dB), and the f-number where the controller set the iris. Records
/// embed its fields flat (`"exposure_ms": …, "gain_db": …`, `"f_number": …` only where set);
/// the test's means by light write exposure and gain as a pair `[ms, dB]`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Settings {
    /// Exposure, ms.
    pub exposure_ms: f64,
    /// Gain, dB.
    pub gain_db: f64,
    /// The iris's f-number, where the controller set it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub f_number: Option<f64>,
}

impl From<DynamicSettings> for Settings {
    fn from(s: DynamicSettings) -> Self {
        Self { exposure_ms: s.exposure_s * 1e3, gain_db: s.gain_db, f_number: None }
    }
}

impl Settings {
    /// The same settings at the iris's `f_number` (`None`: the lens's own).
    pub fn at(self, f_number: Option<f64>) -> Self {
        Self { f_number, ..self }
    }

    /// Exposure × linear gain (10^(G/20)), ms: the total amplification of the light.
    pub fn exposure_gain_ms(self) -> f64 {
        self.exposure_ms * joca_core::units::linear_from_db(self.gain_db)
    }
}

/// `results.json`'s `settings_by_illumination`: each light's mean settings as `[ms, dB]`.
pub(crate) mod as_pairs {
    use super::*;

    pub(crate) fn serialize<S: Serializer>(
        map: &BTreeMap<Light, Settings>,
        s: S,
    ) -> Result<S::Ok, S::Error> {
        let pairs: BTreeMap<Light, (f64, f64)> =
            map.iter().map(|(l, v)| (*l, (v.exposure_ms, v.gain_db))).collect();
        pairs.serialize(s)
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<BTreeMap<Light, Settings>, D::Error> {
        let pairs = BTreeMap::<Light, (f64, f64)>::deserialize(d)?;
        Ok(pairs
            .into_iter()
            .map(|(l, (e, g))| (l, Settings { exposure_ms: e, gain_db: g, f_number: None }))
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_keep_the_shapes_files_were_written_in() {
        #[derive(Serialize, Deserialize, PartialEq, Debug)]
        struct Line {
            step: u64,
            #[serde(flatten)]
            settings: Settings,
            light: Light,
        }
        let line = Line {
            step: 5,
            settings: Settings { exposure_ms: 2.5, gain_db: 10.0, f_number: None },
            light: Light::Day,
        };
        let text = serde_json::to_string(&line).unwrap();
        assert_eq!(text, r#"{"step":5,"exposure_ms":2.5,"gain_db":10.0,"light":"day"}"#);
        assert_eq!(serde_json::from_str::<Line>(&text).unwrap(), line);
        #[derive(Serialize, Deserialize, PartialEq, Debug)]
        struct Means(#[serde(with = "as_pairs")] BTreeMap<Light, Settings>);
        let means = Means(BTreeMap::from([(
            Light::Night,
            Settings { exposure_ms: 40.0, gain_db: 18.5, f_number: None },
        )]));
        let text = serde_json::to_string(&means).unwrap();
        assert_eq!(text, r#"{"night":[40.0,18.5]}"#);
        assert_eq!(serde_json::from_str::<Means>(&text).unwrap(), means);
        let s: Settings = DynamicSettings::new(0.004, 6.0).into();
        assert_eq!(s, Settings { exposure_ms: 4.0, gain_db: 6.0, f_number: None });
        // Where the controller set the iris the records say its f-number too.
        let line = Line { settings: s.at(Some(5.6)), ..line };
        let text = serde_json::to_string(&line).unwrap();
        assert_eq!(
            text,
            r#"{"step":5,"exposure_ms":4.0,"gain_db":6.0,"f_number":5.6,"light":"day"}"#
        );
        assert_eq!(serde_json::from_str::<Line>(&text).unwrap(), line);
    }
}
