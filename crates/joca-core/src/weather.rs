//! The weather a frame is taken in: what the air between the camera and the scene does. Named
//! in configurations and `results.json` (`clear`, `fog:V`, `rain:R`); the simulator renders it.

/// The weather of every episode: what the air between the camera and the scene does.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Weather {
    /// Clear air (the paper's).
    #[default]
    Clear,
    /// Fog of this meteorological visibility, metres (Koschmieder: β = ln 20 / V).
    Fog {
        /// Distance at which a black object keeps 5 % of its contrast, metres.
        visibility_m: f64,
    },
    /// Rain of this rate: Marshall–Palmer drops, their extinction and their streaks (the
    /// simulator's `render::rain`).
    Rain {
        /// Rain rate, mm/h.
        rate_mm_h: f64,
    },
}

impl Weather {
    /// What a configuration may say.
    pub const ALLOWED: &str = "\"clear\", \"fog:V\" (fog of visibility V metres, 10 to 100000) \
        or \"rain:R\" (rain of R mm/h, 0.1 to 200)";

    /// Parses `clear`, `fog:V` or `rain:R`, checking V and R.
    pub fn parse(text: &str) -> Result<Self, String> {
        let value = |prefix: &str| text.strip_prefix(prefix).and_then(|v| v.parse::<f64>().ok());
        let weather = if text == "clear" {
            Weather::Clear
        } else if let Some(visibility_m) = value("fog:") {
            Weather::Fog { visibility_m }
        } else if let Some(rate_mm_h) = value("rain:") {
            Weather::Rain { rate_mm_h }
        } else {
            return Err(format!("unknown weather {text:?}; allowed: {}", Self::ALLOWED));
        };
        weather.check()?;
        Ok(weather)
    }

    /// Allowed fog visibility, metres: 10 m (dense fog) to 100 km (clear air's haze).
    pub const VISIBILITY_RANGE_M: (f64, f64) = (10.0, 100_000.0);

    /// Checks the visibility against [`Self::VISIBILITY_RANGE_M`], naming the field.
    pub fn check(&self) -> Result<(), String> {
        let (lo, hi) = Self::VISIBILITY_RANGE_M;
        match *self {
            Weather::Fog { visibility_m } if !(visibility_m >= lo && visibility_m <= hi) => {
                Err(format!("fog visibility_m = {visibility_m}: allowed {lo} to {hi} m"))
            }
            Weather::Rain { rate_mm_h } if !(0.1..=200.0).contains(&rate_mm_h) => {
                Err(format!("rain rate_mm_h = {rate_mm_h}: allowed 0.1 to 200 mm/h"))
            }
            _ => Ok(()),
        }
    }
}

impl std::fmt::Display for Weather {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Weather::Clear => f.write_str("clear"),
            Weather::Fog { visibility_m } => write!(f, "fog:{visibility_m}"),
            Weather::Rain { rate_mm_h } => write!(f, "rain:{rate_mm_h}"),
        }
    }
}

crate::serde_as_text!(Weather, Weather::parse);
