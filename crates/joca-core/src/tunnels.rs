//! What the `tunnel` light is: a switch of the whole world's light, or places in the town.
//!
//! - **switch** (the default): every few seconds the ambient light of the whole frame drops to a
//!   tunnel's level and comes back; there is no tunnel to see.
//! - **places**: some road blocks of the town are covered (walls, a ceiling, lamps along it), so
//!   a frame can hold the dark mouth ahead in daylight or the bright exit seen from inside. A
//!   `tunnel` episode then drives through one in daylight within its first seconds; every other
//!   episode meets them where its route leads.

crate::named_enum! {
    /// How the `tunnel` light is made.
    pub enum TunnelKind("tunnel kind") {
        /// The ambient light of the whole frame switches between daylight and a tunnel's level.
        Switch = "switch",
        /// Covered road blocks of the town, driven through in daylight.
        Places = "places",
    }
}

crate::named_enum! {
    /// Which way a `tunnel` episode drives through its tunnel (places only).
    pub enum TunnelDrives("tunnel drives") {
        /// Entering or leaving, one chance in two.
        Both = "both",
        /// Every drive enters: the dark mouth ahead in daylight.
        Entering = "entering",
        /// Every drive leaves: the bright exit seen from inside.
        Leaving = "leaving",
    }
}

impl TunnelDrives {
    /// Whether drives enter or leave at random (the default).
    pub fn is_both(&self) -> bool {
        *self == Self::Both
    }

    /// Whether a drive enters, given the draw `entering` made for it.
    pub fn entering(self, drawn: bool) -> bool {
        match self {
            Self::Both => drawn,
            Self::Entering => true,
            Self::Leaving => false,
        }
    }
}

/// The town's tunnels (`tunnels = { kind = "places", count = 6, lamp_level = 0.01 }`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tunnels {
    /// Switch (no tunnel in the town) or places.
    #[serde(default = "default_kind")]
    pub kind: TunnelKind,
    /// Covered road blocks per town (places only).
    #[serde(default = "default_count")]
    pub count: u32,
    /// Irradiance of the tunnel lamps on the roadway, relative to daylight's unit (the sun alone
    /// on a horizontal surface; daylight on the ground is 1.1–1.2 of it at the default sun).
    #[serde(default = "default_lamp_level")]
    pub lamp_level: f32,
    /// Which way the `tunnel` light's episodes drive through (absent: both ways).
    #[serde(default = "default_drives", skip_serializing_if = "TunnelDrives::is_both")]
    pub drives: TunnelDrives,
}

fn default_kind() -> TunnelKind {
    TunnelKind::Switch
}

fn default_count() -> u32 {
    Tunnels::DEFAULT_COUNT
}

fn default_lamp_level() -> f32 {
    Tunnels::DEFAULT_LAMP_LEVEL
}

fn default_drives() -> TunnelDrives {
    TunnelDrives::Both
}

impl Default for Tunnels {
    fn default() -> Self {
        Self {
            kind: TunnelKind::Switch,
            count: Self::DEFAULT_COUNT,
            lamp_level: Self::DEFAULT_LAMP_LEVEL,
            drives: TunnelDrives::Both,
        }
    }
}

impl Tunnels {
    /// Covered blocks per town by default.
    pub const DEFAULT_COUNT: u32 = 6;
    /// The lamps' level by default: 1 % of daylight, a short tunnel's threshold zone (CIE 88
    /// asks for 5–10 % of the access zone's luminance at the entrance of a long tunnel, and well
    /// under 1 % in its interior).
    pub const DEFAULT_LAMP_LEVEL: f32 = 0.01;
    /// Most covered blocks: the blocks between the intersections a route can reach (two
    /// blocks inside the map's edge) number 40 in the smallest town.
    pub const MAX_COUNT: u32 = 16;
    /// The lamps' levels allowed: above 0 (a tunnel without lamps is a black hole by night) to
    /// 10 % of daylight (beyond that the mouth is no longer dark).
    pub const LAMP_LEVEL_RANGE: (f32, f32) = (0.0, 0.1);

    /// Tunnels as places with the default count and lamps.
    pub fn places() -> Self {
        Self { kind: TunnelKind::Places, ..Self::default() }
    }

    /// Whether this is the default (the switch).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// Whether the town has tunnels.
    pub fn are_places(&self) -> bool {
        self.kind == TunnelKind::Places
    }

    /// Refuses a count outside 1 to [`Tunnels::MAX_COUNT`], a lamp level outside (0, 0.1] or
    /// one direction of drives with the switch, naming the field and what is allowed.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        if !self.drives.is_both() && !self.are_places() {
            return Err(("drives", "both with the switch (a direction needs places)".into()));
        }
        if !(1..=Self::MAX_COUNT).contains(&self.count) {
            return Err(("count", format!("1 to {} covered blocks", Self::MAX_COUNT)));
        }
        let (lo, hi) = Self::LAMP_LEVEL_RANGE;
        if !(self.lamp_level > lo && self.lamp_level <= hi) {
            return Err(("lamp_level", format!("above {lo} to {hi} of daylight")));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_is_the_switch_and_reads_from_a_partial_table() {
        assert!(Tunnels::default().is_default() && !Tunnels::default().are_places());
        let t: Tunnels = serde_json::from_str(r#"{"kind": "places"}"#).unwrap();
        assert_eq!(t, Tunnels::places());
        assert!(t.check().is_ok());
        let e = serde_json::from_str::<Tunnels>(r#"{"kind": "roofs"}"#).unwrap_err();
        assert!(e.to_string().contains("switch, places") || e.to_string().contains("places"));
    }

    #[test]
    fn out_of_range_fields_are_named() {
        let bad = |t: Tunnels| t.check().unwrap_err().0;
        assert_eq!(bad(Tunnels { count: 0, ..Tunnels::places() }), "count");
        assert_eq!(bad(Tunnels { count: 17, ..Tunnels::places() }), "count");
        assert_eq!(bad(Tunnels { lamp_level: 0.0, ..Tunnels::places() }), "lamp_level");
        assert_eq!(bad(Tunnels { lamp_level: 0.2, ..Tunnels::places() }), "lamp_level");
        assert_eq!(bad(Tunnels { lamp_level: f32::NAN, ..Tunnels::places() }), "lamp_level");
        let entering = TunnelDrives::Entering;
        assert_eq!(bad(Tunnels { drives: entering, ..Tunnels::default() }), "drives");
        assert!(Tunnels { drives: entering, ..Tunnels::places() }.check().is_ok());
    }

    #[test]
    fn a_direction_reads_and_is_written_only_where_it_is_not_both() {
        let t: Tunnels =
            serde_json::from_str(r#"{"kind": "places", "drives": "leaving"}"#).unwrap();
        assert_eq!(t.drives, TunnelDrives::Leaving);
        assert!(serde_json::to_string(&t).unwrap().contains(r#""drives":"leaving""#));
        assert!(!serde_json::to_string(&Tunnels::places()).unwrap().contains("drives"));
        let e = serde_json::from_str::<Tunnels>(r#"{"kind": "places", "drives": "out"}"#);
        assert!(e.unwrap_err().to_string().contains("`both`, `entering`, `leaving`"));
        let drawn = [true, false];
        assert_eq!(drawn.map(|d| TunnelDrives::Both.entering(d)), [true, false]);
        assert_eq!(drawn.map(|d| TunnelDrives::Entering.entering(d)), [true, true]);
        assert_eq!(drawn.map(|d| TunnelDrives::Leaving.entering(d)), [false, false]);
    }
}
