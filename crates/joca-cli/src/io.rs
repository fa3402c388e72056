//! Reading and writing images and small config files for the command line.

use anyhow::{Context, Result, bail};
use joca_camera::Calibration;
use joca_core::output::{self, OutputKind};
use joca_core::{HdrImage, Rgb8Image};
use std::path::{Path, PathBuf};

/// Reads a PNG (or any format `image` decodes) as linear `I0` in DN: 8-bit values are taken as
/// they are, 16-bit values are divided by 257 so that full scale is 255 DN with sub-DN precision.
pub fn read_linear(path: &Path) -> Result<HdrImage> {
    let img = image::open(path).with_context(|| format!("cannot read image {}", path.display()))?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let data: Vec<f32> = match img {
        image::DynamicImage::ImageRgb16(_)
        | image::DynamicImage::ImageRgba16(_)
        | image::DynamicImage::ImageLuma16(_)
        | image::DynamicImage::ImageLumaA16(_) => {
            img.to_rgb16().into_raw().into_iter().map(|v| f32::from(v) / 257.0).collect()
        }
        _ => img.to_rgb8().into_raw().into_iter().map(f32::from).collect(),
    };
    Ok(HdrImage::from_vec(w, h, data)?)
}

/// Reads an 8-bit RGB frame.
pub fn read_rgb8(path: &Path) -> Result<Rgb8Image> {
    let img = image::open(path).with_context(|| format!("cannot read image {}", path.display()))?;
    if !matches!(
        img,
        image::DynamicImage::ImageRgb8(_)
            | image::DynamicImage::ImageRgba8(_)
            | image::DynamicImage::ImageLuma8(_)
            | image::DynamicImage::ImageLumaA8(_)
    ) {
        bail!(
            "{} is not an 8-bit image: noise calibration needs the camera's raw 8-bit frames",
            path.display()
        );
    }
    let rgb = img.to_rgb8();
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    Ok(Rgb8Image::from_vec(w, h, rgb.into_raw())?)
}

/// Writes `bytes` to `path` through a temporary sibling and a rename
/// (`joca_core::fs::write_atomic`), creating the parent directory: a failure (a full disk, a
/// kill) leaves no file, or a truncated one, under `path`.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create directory {}", parent.display()))?;
    }
    joca_core::fs::write_atomic(path, bytes)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Writes an 8-bit RGB frame as PNG (atomically, see [`write_atomic`]).
pub fn write_png(path: &Path, frame: &Rgb8Image) -> Result<()> {
    write_atomic(path, &png_bytes(frame)?)
}

/// An 8-bit RGB frame encoded as PNG.
pub fn png_bytes(frame: &Rgb8Image) -> Result<Vec<u8>> {
    let (w, h) = (u32::try_from(frame.width())?, u32::try_from(frame.height())?);
    let mut bytes = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut bytes),
        frame.data(),
        w,
        h,
        image::ExtendedColorType::Rgb8,
    )
    .context("cannot encode a PNG")?;
    Ok(bytes)
}

/// Writes every file of `files` or none: each goes to a temporary sibling first, and only when
/// all are written are they renamed into place; a failure removes the temporaries and leaves
/// every path as it was. A path that is a folder is refused before anything is written.
pub fn write_all_or_none(files: &[(&Path, Vec<u8>)]) -> Result<()> {
    if let Some((path, _)) = files.iter().find(|(p, _)| p.is_dir()) {
        bail!("{} is a folder: give a file path for this output", path.display());
    }
    let mut written: Vec<PathBuf> = Vec::new();
    let mut result = Ok(());
    for (path, bytes) in files {
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let temp = path.with_file_name(format!(".{name}.joca-partial"));
        result = write_atomic(&temp, bytes);
        if result.is_err() {
            break;
        }
        written.push(temp);
    }
    if result.is_ok() {
        for ((path, _), temp) in files.iter().zip(&written) {
            std::fs::rename(temp, path)
                .with_context(|| format!("cannot write {}", path.display()))?;
        }
        return Ok(());
    }
    for temp in written {
        let _ = std::fs::remove_file(temp);
    }
    result
}

/// An output folder written in full or not at all: everything goes into a temporary sibling
/// `.NAME.partial`, which replaces the folder on [`StagedDir::finish`] and is removed if the
/// command fails first (dropped unfinished). The folder must be new, empty, or an earlier output
/// of the same command, recognised by its marker (`joca_core::output`), so neither a user's
/// folder nor stale files from a larger earlier output survive next to the new ones; a sibling
/// joca did not make is never deleted. Each output lists the files it wrote ([`INVENTORY`]): an
/// earlier output holding any other file (a user's notes beside the frames) is not replaced —
/// refused before anything is written and again before the swap, naming the files.
#[derive(Debug)]
pub struct StagedDir {
    target: PathBuf,
    staging: PathBuf,
    kind: OutputKind,
    finished: bool,
}

impl StagedDir {
    /// Starts writing `target` as `kind`'s output.
    pub fn create(target: &Path, kind: OutputKind) -> Result<Self> {
        output::check(target, kind)?;
        refuse_foreign_files(target)?;
        let name = target.file_name().map(|n| n.to_string_lossy().into_owned());
        let name = name.filter(|n| !n.is_empty() && n != "." && n != "..").with_context(|| {
            format!("--out {} must name a folder (not `.` or `..`)", target.display())
        })?;
        let staging = target.with_file_name(format!(".{name}.partial"));
        remove_own(&staging, kind)?;
        output::mark(&staging, kind)?;
        Ok(Self { target: target.to_owned(), staging, kind, finished: false })
    }

    /// Where to write the output's files.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// Puts the written folder in place of the target (and of any earlier output there).
    pub fn finish(mut self) -> Result<()> {
        refuse_foreign_files(&self.target)?;
        let listing = files_below(&self.staging)?.join("\n");
        write_atomic(&self.staging.join(INVENTORY), format!("{listing}\n").as_bytes())?;
        let old = self.staging.with_extension("old");
        remove_own(&old, self.kind)?;
        if output::check(&self.target, self.kind)?.is_some() {
            std::fs::rename(&self.target, &old)
                .with_context(|| format!("cannot replace {}", self.target.display()))?;
        } else if self.target.exists() {
            // An empty folder: the rename below needs its place.
            std::fs::remove_dir(&self.target)
                .with_context(|| format!("cannot replace {}", self.target.display()))?;
        }
        std::fs::rename(&self.staging, &self.target)
            .with_context(|| format!("cannot write {}", self.target.display()))?;
        self.finished = true;
        let _ = std::fs::remove_dir_all(&old);
        Ok(())
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.finished {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

/// The file in a staged output that lists every file the command wrote, one relative path a
/// line.
pub const INVENTORY: &str = ".joca-files";

/// Every file below `dir`, as relative paths with `/`, sorted; the marker, the lock and the
/// inventory left out.
fn files_below(dir: &Path) -> Result<Vec<String>> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) -> Result<()> {
        for entry in
            std::fs::read_dir(dir).with_context(|| format!("cannot list {}", dir.display()))?
        {
            let entry = entry?;
            let path = entry.path();
            if entry.file_type()?.is_dir() {
                walk(root, &path, out)?;
            } else {
                let rel = path.strip_prefix(root).unwrap_or(&path);
                out.push(
                    rel.components()
                        .map(|c| c.as_os_str().to_string_lossy())
                        .collect::<Vec<_>>()
                        .join("/"),
                );
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out)?;
    out.retain(|f| ![output::MARKER, output::LOCK_FILE, INVENTORY].contains(&f.as_str()));
    out.sort();
    Ok(out)
}

/// Adds to `dir`'s [`INVENTORY`] (where it has one: a staged output) the files another joca
/// command wrote into it — `entries`, relative paths of files or folders — so that the next
/// staged write does not take them for a user's.
pub fn extend_inventory(dir: &Path, entries: &[&str]) -> Result<()> {
    let path = dir.join(INVENTORY);
    let Ok(text) = std::fs::read_to_string(&path) else { return Ok(()) };
    let mut listed: std::collections::BTreeSet<String> = text.lines().map(str::to_owned).collect();
    for file in files_below(dir)? {
        if entries.iter().any(|e| file == *e || file.starts_with(&format!("{e}/"))) {
            listed.insert(file);
        }
    }
    let text: String = listed.into_iter().flat_map(|l| [l, "\n".to_owned()]).collect();
    write_atomic(&path, text.as_bytes())
}

/// Refuses an earlier output at `target` that holds files its [`INVENTORY`] does not list (all
/// of them, where an older joca kept no inventory), naming them: replacing it would lose them.
fn refuse_foreign_files(target: &Path) -> Result<()> {
    if !target.is_dir() {
        return Ok(());
    }
    let listed: std::collections::HashSet<String> = std::fs::read_to_string(target.join(INVENTORY))
        .map(|t| t.lines().map(str::to_owned).collect())
        .unwrap_or_default();
    let foreign: Vec<String> =
        files_below(target)?.into_iter().filter(|f| !listed.contains(f)).collect();
    if foreign.is_empty() {
        return Ok(());
    }
    let more = foreign.len().saturating_sub(5);
    let mut names = foreign[..foreign.len().min(5)].join(", ");
    if more > 0 {
        names.push_str(&format!(" and {more} more"));
    }
    let why = if target.join(INVENTORY).is_file() {
        "files joca did not write"
    } else {
        "files an older joca wrote without listing them, or you added"
    };
    bail!(
        "{} holds {why} ({names}); writing the output again replaces the folder whole and would \
         lose them: move them away, or choose another folder",
        target.display()
    )
}

/// Removes `dir` if it is absent, empty, or marked as `kind`'s (a staging folder joca left);
/// refuses anything else, so a user's folder of that name is never deleted.
fn remove_own(dir: &Path, kind: OutputKind) -> Result<()> {
    if output::check(dir, kind)
        .with_context(|| format!("{} is in the way of the output", dir.display()))?
        .is_some()
        || dir.is_dir()
    {
        std::fs::remove_dir_all(dir).with_context(|| format!("cannot remove {}", dir.display()))?;
    }
    Ok(())
}

/// The PNG files of a directory, sorted by name.
pub fn png_files(dir: &Path) -> Result<Vec<PathBuf>> {
    files_with_extension(dir, "png")
}

/// The files of a directory whose extension is `ext` (any case), sorted by name.
pub fn files_with_extension(dir: &Path, ext: &str) -> Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot list directory {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case(ext)))
        .collect();
    files.sort();
    Ok(files)
}

/// The `[calibration]` table of a TOML file, as `joca calibrate-noise` prints it.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct CalibrationFile {
    calibration: Calibration,
}

/// Loads and validates a calibration TOML file; errors name the file and the field.
pub fn read_calibration(path: &Path) -> Result<Calibration> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read calibration file {}", path.display()))?;
    let file: CalibrationFile = toml::from_str(&text)
        .with_context(|| format!("invalid calibration file {}", path.display()))?;
    file.calibration
        .validate()
        .with_context(|| format!("invalid calibration file {}", path.display()))?;
    Ok(file.calibration)
}

/// Writes an animated GIF of `frames`, `delay_cs` hundredths of a second apart, looping.
pub fn write_gif(path: &Path, frames: &[Rgb8Image], delay_cs: u16) -> Result<()> {
    use image::codecs::gif::{GifEncoder, Repeat};
    let mut bytes = Vec::new();
    let mut encoder = GifEncoder::new_with_speed(&mut bytes, 10);
    encoder.set_repeat(Repeat::Infinite)?;
    for f in frames {
        let rgba: Vec<u8> =
            f.data().chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect();
        let buffer =
            image::RgbaImage::from_raw(u32::try_from(f.width())?, u32::try_from(f.height())?, rgba)
                .context("frame buffer size")?;
        let delay = image::Delay::from_numer_denom_ms(u32::from(delay_cs) * 10, 1);
        encoder
            .encode_frame(image::Frame::from_parts(buffer, 0, 0, delay))
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    drop(encoder);
    write_atomic(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_staged_folder_replaces_only_its_own_kind_and_a_failed_one_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out");
        // Dropped unfinished (the command failed): no staging, no target.
        let staged = StagedDir::create(&target, OutputKind::Render).unwrap();
        std::fs::write(staged.path().join("frame.png"), "x").unwrap();
        drop(staged);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        // Finished: the target holds the files and the marker; a second output replaces it.
        for file in ["a.png", "b.png"] {
            let staged = StagedDir::create(&target, OutputKind::Render).unwrap();
            std::fs::write(staged.path().join(file), "x").unwrap();
            staged.finish().unwrap();
        }
        let mut names: Vec<String> = std::fs::read_dir(&target)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, [INVENTORY, output::MARKER, "b.png"]);
        assert_eq!(std::fs::read_to_string(target.join(INVENTORY)).unwrap(), "b.png\n");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        // A file the output did not write is named, and stays, before anything is staged.
        std::fs::write(target.join("notes.txt"), "mine").unwrap();
        let e = StagedDir::create(&target, OutputKind::Render).unwrap_err().to_string();
        assert!(e.contains("files joca did not write (notes.txt)"), "{e}");
        assert!(target.join("notes.txt").is_file() && !dir.path().join(".out.partial").exists());
        std::fs::remove_file(target.join("notes.txt")).unwrap();
        // Another command's output is not replaced.
        let e = StagedDir::create(&target, OutputKind::Import).unwrap_err().to_string();
        assert!(e.contains("holds joca render output, not import"), "{e}");
    }
}
