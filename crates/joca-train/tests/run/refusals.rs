//! Every numeric field of `[run]` has a finite range, and a value outside it is refused.

use super::tiny;
use joca_camera::LensModel;
use joca_sim::{Glare, SunElevation, Weather};
use joca_train::{DesignSpec, FNumberRange, Method, RunConfig, Source};

/// Every numeric field of `[run]` has a finite range; a value outside it, NaN or infinite, is
/// refused before anything runs, naming the field and the range.
#[test]
fn out_of_range_run_fields_are_refused_naming_the_field_and_the_range() {
    type Edit = fn(&mut RunConfig);
    let cases: [(Edit, &str); 25] = [
        (
            |c| {
                c.design = Some(DesignSpec {
                    sensor: "IMX172".into(),
                    focal_length_mm: 30.0,
                    x_m: 0.4,
                    z_m: 1.6,
                    f_number: None,
                })
            },
            "run.design.focal_length_mm = 30 is invalid: 1 to 10 mm (the paper's design space)",
        ),
        (
            |c| {
                c.design = Some(DesignSpec {
                    sensor: "nope".into(),
                    focal_length_mm: 3.0,
                    x_m: 0.4,
                    z_m: 1.6,
                    f_number: None,
                })
            },
            "run.design.sensor = \"nope\" is invalid: a catalogue sensor: ",
        ),
        (|c| c.max_speed_mps = f64::NAN, "run.max_speed_mps = NaN is invalid: 0 to 40"),
        (
            |c| c.f_number = FNumberRange { min: 2.0, max: 16.0 },
            "run.f_number = { min = 2, max = 16 } is invalid: 16 to 16 with lens = \"pinhole\" \
             (the pinhole has the calibration's light); set lens = \"thin\" to search the \
             aperture",
        ),
        (
            |c| {
                c.lens = LensModel::Thin;
                c.f_number = FNumberRange { min: 0.5, max: 16.0 };
            },
            "run.f_number.min = 0.5 is invalid: 1 to 32, min at most max",
        ),
        (
            |c| {
                c.lens = LensModel::Thin;
                c.f_number = FNumberRange { min: 8.0, max: 4.0 };
            },
            "run.f_number.max = 4 is invalid: 1 to 32, min at most max",
        ),
        (
            |c| c.weather = Weather::Fog { visibility_m: -5.0 },
            "run.weather = \"fog:-5\" is invalid: fog visibility_m = -5: allowed 10 to 100000 m",
        ),
        (
            |c| {
                c.lens = LensModel::Thin;
                c.source = Source::Folder("/data/rec".into());
            },
            "run.lens = \"thin\" is invalid: \"pinhole\" with a recording (recorded frames have \
             no depth to defocus by)",
        ),
        (
            |c| {
                c.cast_shadows = true;
                c.source = Source::Folder("/data/rec".into());
            },
            "run.cast_shadows = true is invalid: false with a recording",
        ),
        (
            |c| c.sun_elevation = SunElevation { min_deg: 1.0, ..SunElevation::at(30.0) },
            "run.sun_elevation = { min_deg = 1, max_deg = 30 } is invalid: 2 to 90 degrees, \
             min_deg at most max_deg",
        ),
        (
            |c| c.sun_elevation = SunElevation { min_deg: 40.0, ..SunElevation::at(20.0) },
            "run.sun_elevation = { min_deg = 40, max_deg = 20 } is invalid: 2 to 90 degrees, \
             min_deg at most max_deg",
        ),
        (|c| c.max_speed_mps = -5.0, "run.max_speed_mps = -5 is invalid: 0 to 40"),
        (|c| c.detector.width = 0, "run.detector.width = 0 is invalid: 4 to 128"),
        (|c| c.detector.width = 100_000, "run.detector.width = 100000 is invalid: 4 to 128"),
        (
            |c| c.detector.classes = 0,
            "run.detector.classes = 0 is invalid: 3 (vehicle, walker, traffic sign)",
        ),
        (|c| c.population = 1_000_000_000, "run.population = 1000000000 is invalid: 2 to 1000"),
        (
            |c| c.perturbation_population = 100_000_000,
            "run.perturbation_population = 100000000 is invalid: 2 to 64",
        ),
        (|c| c.input.short_px = 0, "run.input.short_px = 0 is invalid: 16 to 1024 px"),
        (|c| c.input.short_px = 5000, "run.input.short_px = 5000 is invalid: 16 to 1024 px"),
        (|c| c.input.long_max_px = 60, "run.input.long_max_px = 60 is invalid: 90 to 2048 px"),
        (|c| c.input.long_max_px = 9999, "run.input.long_max_px = 9999 is invalid: 90 to 2048 px"),
        (|c| c.test_frames_per_episode = 0, "run.test_frames_per_episode = 0 is invalid: 1 to 500"),
        (|c| c.test_episodes = 0, "run.test_episodes = 0 is invalid: 1 to 10000"),
        (|c| c.generations = 0, "run.generations = 0 is invalid: 1 to 10000"),
        (|c| c.ga_every = 0, "run.ga_every = 0 is invalid: 1 to 400"),
    ];
    assert_refused(&cases);
}

/// The joint loop's loss fields: the task and step weights and the smallest training box.
#[test]
fn out_of_range_loss_fields_are_refused_naming_the_field_and_the_range() {
    type Edit = fn(&mut RunConfig);
    let cases: [(Edit, &str); 6] = [
        (
            |c| c.task_weight = f64::INFINITY,
            "run.task_weight = inf is invalid: above 0, at most 1000",
        ),
        (|c| c.task_weight = f64::NAN, "run.task_weight = NaN is invalid: above 0, at most 1000"),
        (
            |c| c.step_weight = -0.1,
            "run.step_weight = -0.1 is invalid: 0 (no step cost, the paper's) to 1000",
        ),
        (
            |c| c.step_weight = f64::NAN,
            "run.step_weight = NaN is invalid: 0 (no step cost, the paper's) to 1000",
        ),
        (
            |c| c.min_box_px = 0.5,
            "run.min_box_px = 0.5 is invalid: 1 (every reference object) to 64",
        ),
        (
            |c| c.min_box_px = f64::NAN,
            "run.min_box_px = NaN is invalid: 1 (every reference object) to 64",
        ),
    ];
    assert_refused(&cases);
}

/// An edit of a valid configuration and the refusal it must get.
type Case = (fn(&mut RunConfig), &'static str);

/// Each edit of `tiny`'s valid configuration is refused with its message (a message ending in
/// ": " is a prefix).
fn assert_refused(cases: &[Case]) {
    for (edit, message) in cases {
        let mut c = tiny(Method::Joca);
        edit(&mut c);
        let e = c.validate().unwrap_err().to_string();
        assert!(e == *message || (message.ends_with(": ") && e.starts_with(message)), "{e}");
    }
    assert!(tiny(Method::Joca).validate().is_ok());
}

/// The lens's veiling glare, the sun's disc and dark streets: a fraction outside [0, 1), a scale
/// outside 0.1–20°, or any of them on a recording is refused naming the field and the range.
#[test]
fn bad_glare_is_refused_naming_the_field_and_the_range() {
    type Edit = fn(&mut RunConfig);
    let cases: [(Edit, &str); 6] = [
        (
            |c| c.glare = Glare { fraction: 1.0, scale_deg: 1.0 },
            "run.glare.fraction = 1 is invalid: 0 (none) to below 1",
        ),
        (
            |c| c.glare = Glare { fraction: -0.1, scale_deg: 1.0 },
            "run.glare.fraction = -0.1 is invalid: 0 (none) to below 1",
        ),
        (
            |c| c.glare = Glare { fraction: 0.02, scale_deg: 45.0 },
            "run.glare.scale_deg = 45 is invalid: 0.1 to 20 degrees",
        ),
        (
            |c| {
                c.glare = Glare { fraction: 0.02, scale_deg: 1.0 };
                c.source = Source::Folder("/data/rec".into());
            },
            "run.glare = a fraction above 0 is invalid: none with a recording",
        ),
        (
            |c| {
                c.sun_disc = true;
                c.source = Source::Folder("/data/rec".into());
            },
            "run.sun_disc = true is invalid: false with a recording",
        ),
        (
            |c| {
                c.dark_streets = true;
                c.source = Source::Folder("/data/rec".into());
            },
            "run.dark_streets = true is invalid: false with a recording",
        ),
    ];
    for (edit, message) in cases {
        let mut c = tiny(Method::Joca);
        edit(&mut c);
        assert_eq!(c.validate().unwrap_err().to_string(), message);
    }
}

/// Tunnels as places: a count outside 1–16, a lamp level outside (0, 0.1], one direction of
/// drives with the switch, or places on a recording is refused naming the field and the range;
/// an unknown kind or direction is refused by the reader, naming the allowed ones.
#[test]
fn bad_tunnels_are_refused_naming_the_field_and_the_range() {
    use joca_sim::{TunnelDrives, Tunnels};
    type Edit = fn(&mut RunConfig);
    let cases: [(Edit, &str); 5] = [
        (
            |c| c.tunnels = Tunnels { drives: TunnelDrives::Entering, ..Tunnels::default() },
            "run.tunnels.drives = entering is invalid: both with the switch (a direction needs \
             places)",
        ),
        (
            |c| c.tunnels = Tunnels { count: 0, ..Tunnels::places() },
            "run.tunnels.count = 0 is invalid: 1 to 16 covered blocks",
        ),
        (
            |c| c.tunnels = Tunnels { count: 40, ..Tunnels::places() },
            "run.tunnels.count = 40 is invalid: 1 to 16 covered blocks",
        ),
        (
            |c| c.tunnels = Tunnels { lamp_level: 0.5, ..Tunnels::places() },
            "run.tunnels.lamp_level = 0.5 is invalid: above 0 to 0.1 of daylight",
        ),
        (
            |c| {
                c.tunnels = Tunnels::places();
                c.source = Source::Folder("/data/rec".into());
            },
            "run.tunnels = places is invalid: the switch with a recording",
        ),
    ];
    for (edit, message) in cases {
        let mut c = tiny(Method::Joca);
        edit(&mut c);
        assert_eq!(c.validate().unwrap_err().to_string(), message);
    }
    let unknown = toml::from_str::<Tunnels>("kind = \"roofs\"").unwrap_err().to_string();
    assert!(unknown.contains("switch") && unknown.contains("places"), "{unknown}");
    let unknown = toml::from_str::<Tunnels>("kind = \"places\"\ndrives = \"out\"").unwrap_err();
    let unknown = unknown.to_string();
    assert!(unknown.contains("entering") && unknown.contains("leaving"), "{unknown}");
}
