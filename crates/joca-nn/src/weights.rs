//! Weight files: safetensors, written atomically, read with a check of every tensor's name,
//! shape, element type and values, so that a file for another architecture — or one whose
//! header claims another type, or whose values are NaN or infinite — is refused naming the
//! tensor, instead of loading and detecting nothing.

use crate::NnError;
use std::collections::HashMap;
use std::path::Path;
use tch::Tensor;
use tch::nn::VarStore;

/// The largest weights or optimiser file read (1 GiB; the shipped detector is 12 MB).
pub const MAX_WEIGHTS_BYTES: u64 = 1 << 30;

/// Refuses a stored tensor of another element type than the variable it loads into (a header
/// that says I32 or F16 for an F32 weight would otherwise be converted silently), or holding
/// NaN or infinite values (a network with them detects nothing, with no other sign).
pub(crate) fn check_tensor(name: &str, stored: &Tensor, var: &Tensor) -> Result<(), String> {
    if stored.kind() != var.kind() {
        return Err(format!(
            "tensor `{name}` is stored as {:?} but this model needs {:?}",
            stored.kind(),
            var.kind()
        ));
    }
    if stored.numel() > 0 && stored.isfinite().all().int64_value(&[]) == 0 {
        return Err(format!("tensor `{name}` holds NaN or infinite values"));
    }
    Ok(())
}

/// Writes every variable of `vs` to `path` (through a temporary file and a rename, so a crash
/// never leaves a half-written file under the final name).
pub fn save_weights(vs: &VarStore, path: &Path) -> Result<(), NnError> {
    // VarStore::save picks the format from the extension, so the temporary name keeps it.
    let tmp = path.with_extension("partial.safetensors");
    vs.save(&tmp)?;
    std::fs::rename(&tmp, path)
        .map_err(|e| NnError::Weights { path: path.display().to_string(), reason: e.to_string() })
}

/// Loads `path` into `vs`: every variable must be present with its shape, and the file must hold
/// nothing else.
pub fn load_weights(vs: &mut VarStore, path: &Path) -> Result<(), NnError> {
    let err = |reason: String| NnError::Weights { path: path.display().to_string(), reason };
    // The cause as the OS gives it: not found, permission denied, not a directory, …
    let size = std::fs::metadata(path).map_err(|e| err(format!("cannot read: {e}")))?.len();
    // The whole file is read into memory; no joca model comes near this size.
    if size > MAX_WEIGHTS_BYTES {
        return Err(err(format!(
            "{size} bytes: larger than any joca model ({MAX_WEIGHTS_BYTES} bytes at most)"
        )));
    }
    let file: HashMap<String, Tensor> = Tensor::read_safetensors(path)
        .map_err(|e| err(format!("not a readable safetensors file ({e})")))?
        .into_iter()
        .collect();
    let mut vars: Vec<(String, Tensor)> = vs.variables().into_iter().collect();
    vars.sort_by(|a, b| a.0.cmp(&b.0));
    for (name, var) in &vars {
        let t = file.get(name).ok_or_else(|| {
            err(format!(
                "missing tensor `{name}` (is it a weights file of another model or width?)"
            ))
        })?;
        check_tensor(name, t, var).map_err(err)?;
        if t.size() != var.size() {
            return Err(err(format!(
                "tensor `{name}` has shape {:?} but this model needs {:?} (another width or class \
                    count?)",
                t.size(),
                var.size()
            )));
        }
    }
    if let Some(extra) = file.keys().filter(|k| !vars.iter().any(|(n, _)| n == *k)).min() {
        return Err(err(format!(
            "unexpected tensor `{extra}`: the file is for another architecture"
        )));
    }
    let _guard = tch::no_grad_guard();
    for (name, var) in &mut vars {
        if let Some(t) = file.get(name) {
            var.copy_(t);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use tch::{Device, Kind};

    /// A file whose tensor has the right name and shape but another element type, or NaN or
    /// infinite values, is refused naming the tensor; the variable keeps its values.
    #[test]
    fn wrong_element_types_and_non_finite_values_are_refused_naming_the_tensor() {
        let dir = std::env::temp_dir().join(format!("joca-nn-check-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("w.safetensors");
        let mut vs = VarStore::new(Device::Cpu);
        let w = (vs.root() / "layer").var("weight", &[2, 3], tch::nn::Init::Const(0.5));
        let good = Tensor::ones([2, 3], (Kind::Float, Device::Cpu));
        for (stored, why) in [
            (good.to_kind(Kind::Int), "stored as Int"),
            (good.to_kind(Kind::Half), "stored as Half"),
            (good.to_kind(Kind::BFloat16), "stored as BFloat16"),
            (good.to_kind(Kind::Double), "stored as Double"),
            (&good * f64::NAN, "NaN or infinite"),
            (&good * f64::INFINITY, "NaN or infinite"),
        ] {
            Tensor::write_safetensors(&[("layer.weight", &stored)], &path).unwrap();
            let e = load_weights(&mut vs, &path).unwrap_err().to_string();
            assert!(e.contains("w.safetensors") && e.contains("`layer.weight`"), "{e}");
            assert!(e.contains(why), "{why}: {e}");
            assert_eq!(w.mean(Kind::Float).double_value(&[]), 0.5);
        }
        Tensor::write_safetensors(&[("layer.weight", &good)], &path).unwrap();
        load_weights(&mut vs, &path).unwrap();
        assert_eq!(w.mean(Kind::Float).double_value(&[]), 1.0);
    }

    /// A path that cannot be read is named with the OS's reason, not always "not found".
    #[test]
    fn an_unreadable_path_is_named_with_its_cause() {
        let mut vs = VarStore::new(Device::Cpu);
        let missing = std::env::temp_dir().join("joca-nn-no-such-dir/w.safetensors");
        let e = load_weights(&mut vs, &missing).unwrap_err().to_string();
        assert!(e.contains("w.safetensors") && e.contains("No such file"), "{e}");
        // A path through a file: "Not a directory", which "file not found" used to hide.
        let file = std::env::temp_dir().join(format!("joca-nn-plain-{}", std::process::id()));
        std::fs::write(&file, b"x").unwrap();
        let e = load_weights(&mut vs, &file.join("w.safetensors")).unwrap_err().to_string();
        assert!(e.contains("Not a directory"), "{e}");
        std::fs::remove_file(&file).unwrap();
    }

    /// A safetensors header as the format lays it out: an 8-byte little-endian length, then
    /// JSON naming each tensor's dtype, shape and byte range in the data that follows.
    fn safetensors(header: &str, data: &[u8]) -> Vec<u8> {
        let mut bytes = (header.len() as u64).to_le_bytes().to_vec();
        bytes.extend_from_slice(header.as_bytes());
        bytes.extend_from_slice(data);
        bytes
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            cases: 500, ..proptest::prelude::ProptestConfig::default()
        })]

        /// Whatever a weights file holds — random bytes, or a header with any dtype, shape and
        /// offsets — loading returns an error (or, for a well-formed file, the weights) and
        /// never panics, nor allocates beyond the file's own size.
        #[test]
        fn any_weights_file_loads_or_fails_without_panic(
            raw in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..200),
            dtype in proptest::sample::select(vec!["F32", "F16", "BF16", "F64", "I32", "I64",
                "U8", "BOOL", "F8_E4M3", "X"]),
            shape in proptest::collection::vec(0u64..8, 0..4),
            start in 0u64..64,
            len in 0u64..200,
            name in proptest::sample::select(vec!["layer.weight", "other", ""]),
            structured in proptest::prelude::any::<bool>(),
        ) {
            let _serial = crate::torch_serial();
            let dir = std::env::temp_dir().join(format!("joca-nn-fuzz-{}", std::process::id()));
            std::fs::create_dir_all(&dir).unwrap();
            let path = dir.join("w.safetensors");
            let bytes = if structured {
                let end = start + len;
                let tensor = format!(
                    r#"{{"dtype":"{dtype}","shape":{shape:?},"data_offsets":[{start},{end}]}}"#
                );
                let header = format!(r#"{{"{name}":{tensor}}}"#);
                safetensors(&header, &raw)
            } else {
                raw
            };
            std::fs::write(&path, &bytes).unwrap();
            let mut vs = VarStore::new(Device::Cpu);
            let _ = (vs.root() / "layer").var("weight", &[2, 3], tch::nn::Init::Const(0.5));
            let _ = load_weights(&mut vs, &path);
        }
    }
}
