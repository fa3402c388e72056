//! Weight files: safetensors, written atomically, read with a check of every tensor's name and
//! shape so that a file for another architecture is refused with the tensor that does not fit.

use crate::NnError;
use std::collections::HashMap;
use std::path::Path;
use tch::Tensor;
use tch::nn::VarStore;

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
    if !path.exists() {
        return Err(err("file not found".into()));
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
