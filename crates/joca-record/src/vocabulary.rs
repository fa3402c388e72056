//! Where a run's frames came from ([`Source`]), the light they were taken in ([`Light`]) and
//! which controller its test drove the design with ([`TestController`]): named in configuration
//! files, on the command line and in `results.json`, each by one parser and one printer.

use joca_camera::MID_GREY_DN;
use std::path::PathBuf;

/// Where frames come from (`source`, `test_source`): written `sim` (or empty), `folder:DIR` or
/// `waymo:DIR`, parsed once when a file is read.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Source {
    /// The built-in simulator (as `test_source`: the default test frames).
    #[default]
    Sim,
    /// A recording in the folder format (frames and a COCO `annotations.json`).
    Folder(PathBuf),
    /// Waymo Open Dataset v2 parquet files (`DIR/camera_image`, `DIR/camera_box`).
    Waymo(PathBuf),
}

impl Source {
    /// What a configuration file may say.
    pub const ALLOWED: &str = "\"sim\" (the built-in simulator), \"folder:DIR\" (a recording in \
        the folder format) or \"waymo:DIR\" (Waymo Open Dataset v2 parquet: DIR/camera_image, \
        DIR/camera_box)";

    /// Parses a configuration value (empty: the simulator, as older `results.json` say).
    pub fn parse(text: &str) -> Result<Self, String> {
        let dir =
            |prefix: &str| text.strip_prefix(prefix).filter(|d| !d.is_empty()).map(PathBuf::from);
        match text {
            "" | "sim" => Ok(Source::Sim),
            _ => dir("folder:")
                .map(Source::Folder)
                .or_else(|| dir("waymo:").map(Source::Waymo))
                .ok_or_else(|| {
                    format!("unknown frame source {text:?}; allowed: {}", Self::ALLOWED)
                }),
        }
    }

    /// Whether frames come from a recording (the real-image mode).
    pub fn is_recording(&self) -> bool {
        *self != Source::Sim
    }
}

impl std::fmt::Display for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Source::Sim => f.write_str("sim"),
            Source::Folder(dir) => write!(f, "folder:{}", dir.display()),
            Source::Waymo(dir) => write!(f, "waymo:{}", dir.display()),
        }
    }
}

joca_core::serde_as_text!(Source, Source::parse);

joca_core::named_enum! {
    /// The light a frame was taken in, as the records name it: the simulator's illumination
    /// schedules, and `recorded` for frames of a recording. Maps keyed by it are ordered by
    /// name, as the string keys of earlier files were.
    pub enum Light("light") {
        /// Full daylight throughout.
        Day = "day",
        /// Night throughout.
        Night = "night",
        /// Switches between daylight and a dark tunnel.
        Tunnel = "tunnel",
        /// A gradual day → night → day cycle.
        Cycle = "cycle",
        /// A recording's frames (their light is whatever was recorded).
        Recorded = "recorded",
    }
}

impl Ord for Light {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.name().cmp(other.name())
    }
}

impl PartialOrd for Light {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

/// Which controller a re-test (`joca eval --controller`) drives the trained design with: the
/// run's own, or AverageAE at a chosen frame mean — to measure what another exposure policy
/// does to the same trained detector on the same design and test scenes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum TestController {
    /// The run's own controller (NeuralAE, or AverageAE at mid-grey for `tacos-average`).
    #[default]
    Trained,
    /// AverageAE holding the frame mean at this level, DN.
    Average {
        /// Target frame mean, DN.
        target_dn: f64,
    },
}

impl TestController {
    /// Parses `trained`, `average` (mid-grey, 127.5 DN) or `average:DN` (0 < DN < 255); the
    /// file form of [`Self::name`], `average-DN`, too.
    pub fn from_name(name: &str) -> Result<Self, String> {
        let bad = || {
            format!(
                "unknown controller `{name}`: allowed `trained`, `average` or `average:DN` with \
                 0 < DN < 255"
            )
        };
        match name {
            "trained" => Ok(Self::Trained),
            "average" => Ok(Self::Average { target_dn: MID_GREY_DN }),
            _ => {
                let dn: f64 = name
                    .strip_prefix("average:")
                    .or_else(|| name.strip_prefix("average-"))
                    .ok_or_else(bad)?
                    .parse()
                    .map_err(|_| bad())?;
                if dn > 0.0 && dn < 255.0 {
                    Ok(Self::Average { target_dn: dn })
                } else {
                    Err(bad())
                }
            }
        }
    }

    /// A name for files and tables: `trained` or `average-DN`.
    pub fn name(&self) -> String {
        match self {
            Self::Trained => "trained".into(),
            Self::Average { target_dn } => format!("average-{target_dn}"),
        }
    }
}

impl std::fmt::Display for TestController {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

joca_core::serde_as_text!(TestController, TestController::from_name);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_controllers_parse_and_bad_names_say_what_is_allowed() {
        assert_eq!(TestController::from_name("trained"), Ok(TestController::Trained));
        assert_eq!(
            TestController::from_name("average"),
            Ok(TestController::Average { target_dn: 127.5 })
        );
        let dark = TestController::from_name("average:40").unwrap();
        assert_eq!(dark, TestController::Average { target_dn: 40.0 });
        assert_eq!(dark.name(), "average-40");
        for bad in ["average:0", "average:255", "average:x", "neural", "average:"] {
            let e = TestController::from_name(bad).unwrap_err();
            assert!(e.contains(bad) && e.contains("0 < DN < 255"), "{e}");
        }
    }

    #[test]
    fn records_hold_the_names_files_were_written_with() {
        let dark = TestController::Average { target_dn: 40.0 };
        assert_eq!(serde_json::to_string(&dark).unwrap(), "\"average-40\"");
        assert_eq!(serde_json::from_str::<TestController>("\"average-40\"").unwrap(), dark);
        let waymo = Source::Waymo("/data/w".into());
        assert_eq!(serde_json::to_string(&waymo).unwrap(), "\"waymo:/data/w\"");
        assert_eq!(serde_json::from_str::<Source>("\"waymo:/data/w\"").unwrap(), waymo);
        // Older results.json wrote an empty source for the simulator.
        assert_eq!(serde_json::from_str::<Source>("\"\"").unwrap(), Source::Sim);
        for bad in ["folder:", "waymo:", "cam:x", "simulator"] {
            let e = Source::parse(bad).unwrap_err();
            assert!(e.contains(&format!("{bad:?}")) && e.contains("folder:DIR"), "{e}");
        }
    }

    #[test]
    fn maps_keyed_by_light_are_written_as_the_string_keyed_maps_were() {
        use std::collections::BTreeMap;
        let typed: BTreeMap<Light, f64> =
            Light::ALL.iter().zip(1..).map(|(&l, v)| (l, v.into())).collect();
        let named: BTreeMap<String, f64> =
            typed.iter().map(|(l, v)| (l.name().to_owned(), *v)).collect();
        // Same keys in the same (alphabetical) order: files keep their bytes.
        let text = serde_json::to_string(&typed).unwrap();
        assert_eq!(text, serde_json::to_string(&named).unwrap());
        assert!(
            text.starts_with("{\"cycle\":4.0,\"day\":1.0,\"night\":2.0,\"recorded\""),
            "{text}"
        );
        assert_eq!(serde_json::from_str::<BTreeMap<Light, f64>>(&text).unwrap(), typed);
        let e = serde_json::from_str::<BTreeMap<Light, f64>>("{\"dusk\":1}").unwrap_err();
        assert!(e.to_string().contains("unknown variant `dusk`"), "{e}");
    }
}
