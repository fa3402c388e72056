//! The name of a re-test's records: `joca eval` writes `results-<tag>.json` and `test-<tag>/`
//! beside a run's own test, one tag part per thing it changed. Written by `joca eval` and a grid's
//! follow-up tests and read by the reports, from this one definition.

use crate::{Scenario, TestController};
use std::fmt;

/// What a re-test of a finished run changed; [`fmt::Display`] gives its tag: the parts joined by
/// `-` in the order `<scenario>`, `<controller>`, `detector-start`, `frames<N>`,
/// `episodes<N>`, `town<K>` (`eval` when nothing changed).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Retest {
    /// Another scenario than the run's.
    pub scenario: Option<Scenario>,
    /// Another controller than the run's own ([`TestController::Trained`]: unchanged).
    pub controller: TestController,
    /// The detector weights the run started from in place of its trained detector.
    pub start_detector: bool,
    /// Another number of scored frames per episode.
    pub frames_per_episode: Option<usize>,
    /// Another number of test episodes.
    pub episodes: Option<u64>,
    /// Another town of the test family (0: the test town, unchanged).
    pub town: u64,
}

impl Retest {
    /// The run's own controller on town `town`.
    pub fn town(town: u64) -> Self {
        Self { town, ..Self::default() }
    }

    /// `controller` in place of the run's own, on town `town`.
    pub fn controller(controller: TestController, town: u64) -> Self {
        Self { controller, town, ..Self::default() }
    }

    /// AverageAE at mid-grey in place of the run's own controller, on town `town`: the swap a
    /// NeuralAE run ends with (on the test town) and a grid's follow-up repeats on other towns.
    pub fn average_swap(town: u64) -> Self {
        Self::controller(TestController::Average { target_dn: joca_camera::MID_GREY_DN }, town)
    }

    /// The detector the run started from in place of its trained one, on town `town`.
    pub fn start_detector(town: u64) -> Self {
        Self { start_detector: true, town, ..Self::default() }
    }

    /// The record's file name, `results-<tag>.json`.
    pub fn results_file(&self) -> String {
        format!("results-{self}.json")
    }
}

impl fmt::Display for Retest {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts: Vec<String> = Vec::new();
        if let Some(s) = self.scenario {
            parts.push(s.name().to_owned());
        }
        if self.controller != TestController::Trained {
            parts.push(self.controller.name());
        }
        if self.start_detector {
            parts.push("detector-start".to_owned());
        }
        if let Some(n) = self.frames_per_episode {
            parts.push(format!("frames{n}"));
        }
        if let Some(n) = self.episodes {
            parts.push(format!("episodes{n}"));
        }
        if self.town != 0 {
            parts.push(format!("town{}", self.town));
        }
        if parts.is_empty() {
            parts.push("eval".to_owned());
        }
        f.write_str(&parts.join("-"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tags_name_each_change_in_a_fixed_order() {
        let average = TestController::Average { target_dn: 127.5 };
        assert_eq!(Retest::default().to_string(), "eval");
        assert_eq!(Retest::town(2).to_string(), "town2");
        assert_eq!(Retest::controller(average, 0).to_string(), "average-127.5");
        assert_eq!(
            Retest::controller(average, 3).results_file(),
            "results-average-127.5-town3.json"
        );
        assert_eq!(Retest::start_detector(0).to_string(), "detector-start");
        let all = Retest {
            scenario: Some(Scenario::Blur4),
            controller: TestController::Average { target_dn: 60.0 },
            start_detector: true,
            frames_per_episode: Some(5),
            episodes: Some(8),
            town: 2,
        };
        assert_eq!(all.to_string(), "blur4-average-60-detector-start-frames5-episodes8-town2");
    }
}
