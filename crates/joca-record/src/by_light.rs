//! [`ByLight`]: what the closed-loop test measured under each light, one record per light.
//!
//! `results.json` keeps the layout it has had since these measurements were added: one map per
//! quantity, keyed by light (`test_by_illumination`, `settings_by_illumination` as `[ms, dB]`,
//! `f_number_by_illumination`, `exposure_gain_by_illumination`, `mean_dn_by_illumination`,
//! `clipped_share_by_illumination`), so
//! files written before and after read alike. In memory the maps are one record per light, so
//! no reader pairs up maps by key and no writer can fill one map and forget another.

use crate::{Light, Settings};
use joca_metrics::TaskScores;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::collections::BTreeMap;

/// The closed-loop test's measurements under one light; `None` where a run did not record one
/// (older files lack some).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LightResults {
    /// Scores over the frames of this light.
    pub scores: Option<TaskScores>,
    /// Mean exposure and gain, and the geometric-mean f-number where the controller set the iris.
    pub settings: Option<Settings>,
    /// Mean exposure (ms) × linear gain (10^(G/20)): the amplification applied to the light.
    pub exposure_gain_ms: Option<f64>,
    /// Mean 8-bit value of the formed frames, DN.
    pub mean_dn: Option<f64>,
    /// Mean share of each frame's pixels with a channel at 255 (absent in older runs).
    pub clipped_share: Option<f64>,
}

/// One [`LightResults`] per light, written as `results.json`'s per-quantity maps.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ByLight(pub BTreeMap<Light, LightResults>);

impl std::ops::Deref for ByLight {
    type Target = BTreeMap<Light, LightResults>;
    fn deref(&self) -> &Self::Target {
        &self.0
    }
}

impl std::ops::DerefMut for ByLight {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.0
    }
}

impl ByLight {
    /// Each light's scores.
    pub fn scores(&self) -> impl Iterator<Item = (Light, &TaskScores)> {
        self.0.iter().filter_map(|(l, r)| Some((*l, r.scores.as_ref()?)))
    }

    /// Each light's mean settings.
    pub fn settings(&self) -> impl Iterator<Item = (Light, &Settings)> {
        self.0.iter().filter_map(|(l, r)| Some((*l, r.settings.as_ref()?)))
    }

    /// Each light's geometric-mean f-number, where the controller set the iris.
    pub fn f_numbers(&self) -> impl Iterator<Item = (Light, f64)> + '_ {
        self.settings().filter_map(|(l, s)| Some((l, s.f_number?)))
    }

    /// The record of `light`, if the test saw it.
    pub fn light(&self, light: Light) -> Option<&LightResults> {
        self.0.get(&light)
    }
}

/// The file's layout: one map per quantity.
#[derive(Serialize, Deserialize)]
struct Maps {
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    test_by_illumination: BTreeMap<Light, TaskScores>,
    #[serde(with = "crate::settings::as_pairs")]
    settings_by_illumination: BTreeMap<Light, Settings>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    f_number_by_illumination: BTreeMap<Light, f64>,
    #[serde(default)]
    exposure_gain_by_illumination: BTreeMap<Light, f64>,
    #[serde(default)]
    mean_dn_by_illumination: BTreeMap<Light, f64>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    clipped_share_by_illumination: BTreeMap<Light, f64>,
}

impl Serialize for ByLight {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let pick = |f: fn(&LightResults) -> Option<f64>| -> BTreeMap<Light, f64> {
            self.0.iter().filter_map(|(l, r)| Some((*l, f(r)?))).collect()
        };
        Maps {
            test_by_illumination: self.scores().map(|(l, v)| (l, *v)).collect(),
            settings_by_illumination: self.settings().map(|(l, v)| (l, *v)).collect(),
            f_number_by_illumination: self.f_numbers().collect(),
            exposure_gain_by_illumination: pick(|r| r.exposure_gain_ms),
            mean_dn_by_illumination: pick(|r| r.mean_dn),
            clipped_share_by_illumination: pick(|r| r.clipped_share),
        }
        .serialize(s)
    }
}

impl<'de> Deserialize<'de> for ByLight {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let maps = Maps::deserialize(d)?;
        let mut by: BTreeMap<Light, LightResults> = BTreeMap::new();
        for (l, v) in maps.test_by_illumination {
            by.entry(l).or_default().scores = Some(v);
        }
        for (l, v) in maps.settings_by_illumination {
            let f_number = maps.f_number_by_illumination.get(&l).copied();
            by.entry(l).or_default().settings = Some(v.at(f_number));
        }
        for (l, v) in maps.exposure_gain_by_illumination {
            by.entry(l).or_default().exposure_gain_ms = Some(v);
        }
        for (l, v) in maps.mean_dn_by_illumination {
            by.entry(l).or_default().mean_dn = Some(v);
        }
        for (l, v) in maps.clipped_share_by_illumination {
            by.entry(l).or_default().clipped_share = Some(v);
        }
        Ok(Self(by))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize, Deserialize, PartialEq, Debug)]
    struct Record {
        before: u8,
        #[serde(flatten)]
        by_illumination: ByLight,
        after: u8,
    }

    /// One record per light in memory, the per-quantity maps of `results.json` on disk, in the
    /// order the file has always had them; read back, the same records.
    #[test]
    fn one_record_per_light_is_written_as_the_files_maps() {
        let scores = TaskScores { map: 0.25, ..joca_metrics::TaskMetrics::default().compute() };
        let settings = |e, g, f| Some(Settings { exposure_ms: e, gain_db: g, f_number: f });
        let light = |s, f| LightResults {
            scores: Some(TaskScores { frames: 5, ..scores }),
            settings: settings(s, 10.0, f),
            exposure_gain_ms: Some(s * 3.0),
            mean_dn: Some(100.0),
            clipped_share: Some(0.25),
        };
        let mut by = ByLight::default();
        by.insert(Light::Night, light(40.0, None));
        by.insert(Light::Day, light(2.0, None));
        let record = Record { before: 1, by_illumination: by.clone(), after: 2 };
        let text = serde_json::to_string(&record).unwrap();
        let keys: Vec<&str> = text
            .match_indices("\"")
            .map(|(i, _)| i)
            .collect::<Vec<_>>()
            .chunks(2)
            .map(|q| &text[q[0] + 1..q[1]])
            .filter(|k| k.ends_with("_illumination") || *k == "before" || *k == "after")
            .collect();
        assert_eq!(
            keys,
            [
                "before",
                "test_by_illumination",
                "settings_by_illumination",
                "exposure_gain_by_illumination",
                "mean_dn_by_illumination",
                "clipped_share_by_illumination",
                "after"
            ],
            "{text}"
        );
        assert!(
            text.contains(r#""settings_by_illumination":{"day":[2.0,10.0],"night":[40.0,10.0]}"#)
        );
        assert!(text.contains(r#""exposure_gain_by_illumination":{"day":6.0,"night":120.0}"#));
        assert_eq!(serde_json::from_str::<Record>(&text).unwrap(), record);
        // Where the controller set the iris its f-number joins as a fifth map, and reads back
        // into the light's settings.
        by.insert(Light::Day, light(2.0, Some(8.0)));
        let record = Record { before: 1, by_illumination: by, after: 2 };
        let text = serde_json::to_string(&record).unwrap();
        assert!(text.contains(r#""f_number_by_illumination":{"day":8.0}"#), "{text}");
        assert_eq!(serde_json::from_str::<Record>(&text).unwrap(), record);
        // An older file without the optional maps: only what it has.
        let old = r#"{"before":1,"settings_by_illumination":{"day":[2.0,10.0]},"after":2}"#;
        let read = serde_json::from_str::<Record>(old).unwrap();
        let day = read.by_illumination.light(Light::Day).unwrap();
        assert_eq!((day.scores.is_none(), day.exposure_gain_ms, day.mean_dn), (true, None, None));
        assert_eq!(day.settings, settings(2.0, 10.0, None));
    }
}
