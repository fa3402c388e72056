//! Property tests of the configuration layer: whatever a `[run]` or `[pretrain]` table holds —
//! wrong types, NaN, infinities, huge or negative numbers, unknown values — parsing and
//! validation return a value or an error and never panic; and whatever validation accepts lies
//! within the documented ranges, so nothing downstream allocates on a user's say-so.
#![allow(clippy::unwrap_used)]

use joca_train::{PretrainConfig, RunConfig};
use proptest::prelude::*;
use toml::Value;

fn preset_table(section: &str) -> toml::Table {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../presets/standard.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let mut t: toml::Table = toml::from_str(&text).unwrap();
    t.remove(section).unwrap().try_into().unwrap()
}

/// Every key path of a table (`detector.width`, …), to pick fields to corrupt.
fn paths(t: &toml::Table, prefix: &str, out: &mut Vec<String>) {
    for (k, v) in t {
        let p = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
        if let Value::Table(sub) = v {
            paths(sub, &p, out);
        }
        out.push(p);
    }
}

fn set(t: &mut toml::Table, path: &str, value: Value) {
    match path.split_once('.') {
        Some((head, rest)) => {
            if let Some(Value::Table(sub)) = t.get_mut(head) {
                set(sub, rest, value);
            }
        }
        None => {
            t.insert(path.to_owned(), value);
        }
    }
}

fn value() -> impl Strategy<Value = Value> {
    prop_oneof![
        any::<i64>().prop_map(Value::Integer),
        prop_oneof![Just(0i64), Just(-1), Just(1), Just(i64::MAX), Just(1_000_000_000)]
            .prop_map(Value::Integer),
        any::<f64>().prop_map(Value::Float),
        prop_oneof![
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(-f64::INFINITY),
            Just(1e-9),
            Just(-5.0),
            Just(1e308)
        ]
        .prop_map(Value::Float),
        "[a-z0-9:/._-]{0,16}".prop_map(Value::String),
        any::<bool>().prop_map(Value::Boolean),
        Just(Value::Array(vec![Value::Integer(9), Value::Float(f64::NAN)])),
    ]
}

fn corrupted(section: &'static str) -> impl Strategy<Value = toml::Table> {
    let base = preset_table(section);
    let mut keys = Vec::new();
    paths(&base, "", &mut keys);
    prop::collection::vec((prop::sample::select(keys), value()), 1..4).prop_map(move |edits| {
        let mut t = base.clone();
        for (path, v) in edits {
            set(&mut t, &path, v);
        }
        t
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn any_run_table_parses_or_fails_without_panic(t in corrupted("run")) {
        if let Ok(c) = Value::Table(t).try_into::<RunConfig>()
            && c.validate().is_ok()
        {
            prop_assert!(c.population <= 1000 && c.perturbation_population <= 64);
            prop_assert!(c.generations <= 10_000 && c.test_episodes <= 10_000);
            prop_assert!(c.input.short_px >= 16 && c.input.long_max_px <= 2048);
            prop_assert!(c.task_weight.is_finite() && c.max_speed_mps.is_finite());
            prop_assert!((4..=128).contains(&c.detector.width));
        }
    }

    #[test]
    fn any_pretrain_table_parses_or_fails_without_panic(t in corrupted("pretrain")) {
        if let Ok(c) = Value::Table(t).try_into::<PretrainConfig>()
            && c.validate().is_ok()
        {
            prop_assert!(c.input.short_px >= 16 && c.data.max_speed_mps.is_finite());
            prop_assert!((4..=128).contains(&c.detector.width) && c.threads <= 64);
        }
    }

    #[test]
    fn any_text_parses_or_fails_without_panic(text in "\\PC{0,200}") {
        if let Ok(t) = toml::from_str::<toml::Table>(&text) {
            let _ = Value::Table(t.clone()).try_into::<RunConfig>().map(|c| c.validate());
            let _ = Value::Table(t).try_into::<PretrainConfig>().map(|c| c.validate());
        }
    }
}
