//! The configuration guide (`docs/guide/configuration.md`) lists every field the code accepts
//! and no other: its tables are compared with the fields of `RunConfig` and `PretrainConfig`
//! as serde sees them, so a field added, renamed or removed in the code fails here until the
//! guide says so.

use joca_train::{PretrainConfig, RunConfig};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

fn repo() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

/// The field names of each table of the guide, by the heading's code span (`[run]`,
/// `[run.real]`, `detector`, `[pretrain]`, `[pretrain.data]`, …): the first column of every
/// table row.
fn guide_fields() -> BTreeMap<String, BTreeSet<String>> {
    let path = repo().join("docs/guide/configuration.md");
    let text = std::fs::read_to_string(&path).expect("docs/guide/configuration.md is readable");
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut section = None;
    for line in text.lines() {
        if line.starts_with('#') {
            section = line.split('`').nth(1).map(str::to_owned);
            continue;
        }
        let (Some(section), Some(cell)) = (&section, line.strip_prefix("| `")) else { continue };
        if let Some(name) = cell.split('`').next() {
            out.entry(section.clone()).or_default().insert(name.to_owned());
        }
    }
    out
}

/// The keys of a configuration serialised to JSON (where `None` fields stay, as `null`).
fn keys(value: &serde_json::Value) -> BTreeSet<String> {
    value.as_object().expect("a table").keys().cloned().collect()
}

fn preset(name: &str) -> toml::Table {
    let path = repo().join(format!("presets/{name}.toml"));
    toml::from_str(&std::fs::read_to_string(path).expect("preset readable")).expect("valid TOML")
}

#[test]
fn every_run_and_pretrain_field_is_in_the_guide_and_no_other() {
    let guide = guide_fields();
    let table = preset("standard");
    let mut run: RunConfig = table["run"].clone().try_into().expect("the standard [run] parses");
    // Optional fields that serialise only when set.
    run.design = Some(joca_train::DesignSpec {
        sensor: "IMX172".into(),
        focal_length_mm: 3.6,
        x_m: 0.43,
        z_m: 1.65,
        f_number: Some(2.0),
    });
    run.lens = joca_camera::LensModel::Thin;
    run.weather = joca_sim::Weather::Fog { visibility_m: 300.0 };
    run.f_number = joca_train::FNumberRange { min: 1.4, max: 16.0 };
    run.aperture = joca_camera::ApertureControl::Dynamic;
    run.training_scenes = joca_train::TrainingScenes::Fresh;
    run.judge_frames = Some(12);
    run.acc_output = joca_train::AccOutput::parse("relative:3").expect("a valid form");
    run.warm_start = joca_train::WarmStart { frames: 600, lr: 1e-4 };
    run.detector_lr = 1e-5;
    run.step_weight = 0.1;
    run.min_box_px = 4.0;
    run.perturbation_score = joca_train::PerturbationScore::Map;
    run.perturbation_window = 16;
    run.cast_shadows = true;
    run.sun_elevation = joca_sim::SunElevation {
        min_deg: 10.0,
        max_deg: 60.0,
        daylight: joca_core::sun::Daylight::ClearSky,
    };
    run.glare = joca_sim::Glare { fraction: 0.02, scale_deg: 1.0 };
    run.sun_disc = true;
    run.dark_streets = true;
    run.tunnels = joca_sim::Tunnels::places();
    run.device = joca_nn::device::DeviceChoice::Cuda(0);
    let mut pretrain: PretrainConfig =
        table["pretrain"].clone().try_into().expect("the standard [pretrain] parses");
    pretrain.device = joca_nn::device::DeviceChoice::Auto;
    let run = serde_json::to_value(&run).expect("serialisable");
    let pretrain = serde_json::to_value(&pretrain).expect("serialisable");
    let expect = [
        ("[run]", keys(&run)),
        ("[run.real]", keys(&run["real"])),
        ("[run.reference]", keys(&run["reference"])),
        ("detector", keys(&run["detector"])),
        ("input", keys(&run["input"])),
        ("warm_start", keys(&run["warm_start"])),
        ("[pretrain]", keys(&pretrain)),
        ("[pretrain.optimizer]", keys(&pretrain["optimizer"])),
        ("[pretrain.data]", keys(&pretrain["data"])),
        ("[pretrain.eval]", keys(&pretrain["eval"])),
        ("[pretrain.experimental]", keys(&pretrain["experimental"])),
    ];
    for (section, fields) in expect {
        let listed = guide.get(section).cloned().unwrap_or_default();
        let missing: Vec<_> = fields.difference(&listed).collect();
        let extra: Vec<_> = listed.difference(&fields).collect();
        assert!(
            missing.is_empty() && extra.is_empty(),
            "docs/guide/configuration.md, table {section}: fields the code has but the guide \
             lacks: {missing:?}; fields the guide lists but the code lacks: {extra:?}"
        );
    }
    assert_eq!(keys(&pretrain["detector"]), keys(&run["detector"]));
    assert_eq!(keys(&pretrain["input"]), keys(&run["input"]));
}
