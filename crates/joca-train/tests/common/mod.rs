//! Helpers shared by the integration tests.
#![allow(clippy::unwrap_used)]

/// Overwrites every value of the first F32 tensor of a safetensors file with the largest finite
/// f32 (the format: an 8-byte little-endian header length, a JSON header with each tensor's
/// byte range, the data). The file still loads — a NaN would be refused when it is read — and
/// the first forward pass overflows, so the loss is NaN: a divergence as training meets one.
pub fn poison_first_tensor(path: &std::path::Path) {
    let mut bytes = std::fs::read(path).unwrap();
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    let header: serde_json::Value = serde_json::from_slice(&bytes[8..8 + n]).unwrap();
    let (_, info) = header
        .as_object()
        .unwrap()
        .iter()
        .find(|(k, v)| *k != "__metadata__" && v["dtype"] == "F32")
        .unwrap();
    let (a, b) = (
        info["data_offsets"][0].as_u64().unwrap() as usize,
        info["data_offsets"][1].as_u64().unwrap() as usize,
    );
    for chunk in bytes[8 + n + a..8 + n + b].chunks_exact_mut(4) {
        chunk.copy_from_slice(&f32::MAX.to_le_bytes());
    }
    std::fs::write(path, bytes).unwrap();
}

/// Every file of a directory with its bytes, by name (`read_dir` promises no order), to check
/// later that nothing was written over it.
pub fn snapshot(dir: &std::path::Path) -> Vec<(std::ffi::OsString, Vec<u8>)> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (e.file_name(), std::fs::read(e.path()).unwrap())
        })
        .collect();
    files.sort();
    files
}
