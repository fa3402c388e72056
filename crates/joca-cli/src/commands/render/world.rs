//! The simulator's settings that `joca render`'s flags ask for: the sun, the lens's glare, the
//! tunnels and the street lamps, checked.

use super::Args;
use anyhow::Result;
use joca_sim::{CityConfig, Glare, Illumination, SimConfig, SunElevation, Weather};

/// The simulator's settings of `args`, with the weather `optics` checked.
pub(super) fn sim_config(args: &Args, weather: Weather) -> Result<SimConfig> {
    let sun_elevation = match args.sun_elevation_deg {
        Some(deg) => {
            let sun = SunElevation::at(deg);
            sun.check()
                .map_err(|e| anyhow::anyhow!("--sun-elevation-deg {deg} is invalid: {e}"))?;
            sun
        }
        None => SunElevation::default(),
    };
    let sun_elevation = SunElevation { daylight: args.daylight, ..sun_elevation };
    let glare = Glare { fraction: args.glare, scale_deg: args.glare_scale_deg };
    glare.check().map_err(|(field, allowed)| {
        let flag = if field == "fraction" { "glare" } else { "glare-scale-deg" };
        let value = if field == "fraction" { args.glare } else { args.glare_scale_deg };
        anyhow::anyhow!("--{flag} {value} is invalid: allowed {allowed}")
    })?;
    let tunnels = joca_sim::Tunnels {
        kind: args.tunnels,
        count: args.tunnel_count,
        lamp_level: args.tunnel_lamp_level,
        drives: args.tunnel_drives,
    };
    if tunnels.are_places() || !tunnels.drives.is_both() {
        tunnels.check().map_err(|(field, allowed)| {
            let (flag, value) = match field {
                "count" => ("tunnel-count", args.tunnel_count.to_string()),
                "drives" => ("tunnel-drives", args.tunnel_drives.to_string()),
                _ => ("tunnel-lamp-level", args.tunnel_lamp_level.to_string()),
            };
            anyhow::anyhow!("--{flag} {value} is invalid: allowed {allowed}")
        })?;
    }
    Ok(SimConfig {
        map_seed: args.map_seed,
        city: CityConfig { tunnels, street_lamps: !args.dark_streets, ..CityConfig::default() },
        max_speed_mps: args.max_speed_mps,
        illumination: args.illumination.map(Illumination::from),
        weather,
        cast_shadows: args.shadows,
        sun_elevation,
        glare,
        sun_disc: args.sun,
        ..SimConfig::default()
    })
}
