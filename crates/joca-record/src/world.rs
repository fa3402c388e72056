//! The world's light beyond the paper's (cast shadows, another sun, its disc, veiling glare,
//! tunnels as places, dark streets), as `results.json` and `headroom.json` record it: one set of
//! fields flattened into each record, so that both name and describe the world alike.

use joca_core::glare::Glare;
use joca_core::sun::SunElevation;
use joca_core::tunnels::Tunnels;
use serde::{Deserialize, Serialize};

/// The world a record's frames were rendered in; every field absent means the default light.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct World {
    /// Whether the sun cast shadows (absent: no).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub cast_shadows: bool,
    /// The sun's elevation range, degrees (absent: 45 to 55).
    #[serde(default, skip_serializing_if = "SunElevation::is_default")]
    pub sun_elevation: SunElevation,
    /// The lens's veiling glare (absent: none).
    #[serde(default, skip_serializing_if = "Glare::is_default")]
    pub glare: Glare,
    /// Whether the sky showed the sun's disc (absent: no).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub sun_disc: bool,
    /// What the `tunnel` light was (absent: the switch of the whole frame's light).
    #[serde(default, skip_serializing_if = "Tunnels::is_default")]
    pub tunnels: Tunnels,
    /// Whether the street lamps stayed dark at night (absent: no, they lit).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub dark_streets: bool,
}

/// The newest part of the world a record holds, in the order the record layouts added them:
/// a record's layout version follows from it (each record numbers them its own way).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum WorldLayout {
    /// The default light.
    Default,
    /// Cast shadows or another sun elevation.
    ShadowsOrSun,
    /// Veiling glare or the sun's disc.
    GlareOrDisc,
    /// Tunnels as places.
    TunnelPlaces,
    /// Daylight that follows the sun's elevation.
    Daylight,
    /// Tunnel drives in one direction.
    TunnelDrives,
    /// Street lamps dark at night.
    DarkStreets,
}

impl World {
    /// The newest part of the world present, for a record's layout version.
    pub fn layout(&self) -> WorldLayout {
        if self.dark_streets {
            WorldLayout::DarkStreets
        } else if !self.tunnels.drives.is_both() {
            WorldLayout::TunnelDrives
        } else if !self.sun_elevation.daylight.is_constant() {
            WorldLayout::Daylight
        } else if !self.tunnels.is_default() {
            WorldLayout::TunnelPlaces
        } else if !self.glare.is_default() || self.sun_disc {
            WorldLayout::GlareOrDisc
        } else if self.cast_shadows || !self.sun_elevation.is_default() {
            WorldLayout::ShadowsOrSun
        } else {
            WorldLayout::Default
        }
    }

    /// The first field in which `other` differs, by its record name (`None`: the same world).
    pub fn differs(&self, other: &World) -> Option<&'static str> {
        [
            ("cast_shadows", self.cast_shadows != other.cast_shadows),
            ("sun_elevation", self.sun_elevation != other.sun_elevation),
            ("glare", self.glare != other.glare),
            ("sun_disc", self.sun_disc != other.sun_disc),
            ("dark_streets", self.dark_streets != other.dark_streets),
            ("tunnels", self.tunnels != other.tunnels),
        ]
        .into_iter()
        .find(|(_, differs)| *differs)
        .map(|(name, _)| name)
    }

    /// The world in a few words for a table's heading: `default light`, or what differs
    /// (`cast shadows, sun 10–30°`).
    pub fn summary(&self) -> String {
        let mut parts = Vec::new();
        if self.cast_shadows {
            parts.push("cast shadows".to_owned());
        }
        if !self.sun_elevation.is_default() {
            let e = self.sun_elevation;
            parts.push(format!("sun {}–{}°", e.min_deg, e.max_deg));
            if !e.daylight.is_constant() {
                parts.push(format!("{} daylight", e.daylight));
            }
        }
        if self.sun_disc {
            parts.push("sun's disc".to_owned());
        }
        if self.tunnels.are_places() {
            let t = self.tunnels;
            let drives = if t.drives.is_both() { String::new() } else { format!(", {}", t.drives) };
            parts.push(format!("{} tunnels (lamps {}{drives})", t.count, t.lamp_level));
        }
        if self.dark_streets {
            parts.push("dark streets".to_owned());
        }
        if !self.glare.is_off() {
            let g = self.glare;
            parts.push(format!("glare {} % ({}°)", g.fraction * 100.0, g.scale_deg));
        }
        if parts.is_empty() { "default light".into() } else { parts.join(", ") }
    }

    /// The world in a report's sentence: `""` in the default light, else each part after a
    /// comma (`, the sun casting shadows, the sun at 10–20° elevation`).
    pub fn note(&self) -> String {
        let mut note = String::new();
        if self.cast_shadows {
            note.push_str(", the sun casting shadows");
        }
        if !self.sun_elevation.is_default() {
            let e = self.sun_elevation;
            note.push_str(&format!(", the sun at {}–{}° elevation", e.min_deg, e.max_deg));
            if !e.daylight.is_constant() {
                note.push_str(&format!(" ({} daylight)", e.daylight));
            }
        }
        if self.sun_disc {
            note.push_str(", the sun's disc in the sky");
        }
        if self.tunnels.are_places() {
            let t = self.tunnels;
            note.push_str(&format!(
                ", tunnels as places ({} covered blocks a town, lamps at {} of daylight{})",
                t.count,
                t.lamp_level,
                if t.drives.is_both() { String::new() } else { format!(", drives {}", t.drives) }
            ));
        }
        if self.dark_streets {
            note.push_str(", the street lamps dark at night");
        }
        if !self.glare.is_off() {
            let g = self.glare;
            note.push_str(&format!(
                ", veiling glare {} % (scale {}°)",
                g.fraction * 100.0,
                g.scale_deg
            ));
        }
        note
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use joca_core::tunnels::TunnelDrives;

    #[test]
    fn the_newest_part_decides_the_layout_and_the_default_world_says_so() {
        let plain = World::default();
        assert_eq!(
            (plain.layout(), plain.summary(), plain.note()),
            (WorldLayout::Default, "default light".to_owned(), String::new())
        );
        let shadows = World { cast_shadows: true, ..plain };
        assert_eq!(shadows.layout(), WorldLayout::ShadowsOrSun);
        let dark = World { dark_streets: true, ..shadows };
        assert_eq!(dark.layout(), WorldLayout::DarkStreets);
        assert_eq!(dark.summary(), "cast shadows, dark streets");
        assert_eq!(dark.note(), ", the sun casting shadows, the street lamps dark at night");
        assert_eq!(dark.differs(&shadows), Some("dark_streets"));
        assert_eq!(dark.differs(&plain), Some("cast_shadows"));
        assert_eq!(dark.differs(&dark), None);
        let places = World { tunnels: Tunnels::places(), ..plain };
        assert_eq!(places.layout(), WorldLayout::TunnelPlaces);
        assert_eq!(places.summary(), "6 tunnels (lamps 0.01)");
        let leaving = Tunnels { drives: TunnelDrives::Leaving, ..Tunnels::places() };
        let leaving = World { tunnels: leaving, ..plain };
        assert_eq!(leaving.layout(), WorldLayout::TunnelDrives);
        assert_eq!(leaving.summary(), "6 tunnels (lamps 0.01, leaving)");
        assert_eq!(leaving.differs(&places), Some("tunnels"));
    }

    #[test]
    fn a_default_world_writes_no_field() {
        let json = serde_json::to_string(&World::default()).unwrap();
        assert_eq!(json, "{}");
        let back: World = serde_json::from_str("{}").unwrap();
        assert_eq!(back, World::default());
    }
}
