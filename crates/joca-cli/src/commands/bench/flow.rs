//! `joca bench flow`: DIS on a pair beside OpenCV's, and the flow-based blur.

use super::{Args, best_of};
use anyhow::Result;
use joca_core::HdrImage;
use std::hint::black_box;

/// A textured 1920×1280 pair with a known motion (zoom 1 % about the centre plus a shift of
/// (3.3, −1.2) px): the flow benchmark's input.
fn flow_pair() -> (joca_data::flow::Gray, joca_data::flow::Gray, joca_data::flow::Flow) {
    use joca_data::flow::{Flow, Gray};
    let (w, h) = (1920usize, 1280usize);
    let texture = |x: f32, y: f32| {
        128.0
            + 40.0 * (0.11 * x + 0.3 * (0.013 * y).sin()).sin()
            + 30.0 * (0.07 * y + 0.2 * (0.021 * x).cos()).cos()
            + 25.0 * (0.031 * (x + y)).sin() * (0.043 * (x - y)).cos()
    };
    let (cx, cy, k, t) = (w as f32 / 2.0, h as f32 / 2.0, 1.01f32, (3.3f32, -1.2f32));
    let forward = |x: f32, y: f32| (cx + k * (x - cx) + t.0, cy + k * (y - cy) + t.1);
    let inverse = |x: f32, y: f32| (cx + (x - t.0 - cx) / k, cy + (y - t.1 - cy) / k);
    let grid = |f: &dyn Fn(f32, f32) -> f32| {
        Gray::new(w, h, (0..w * h).map(|i| f((i % w) as f32, (i / w) as f32)).collect())
    };
    let i0 = grid(&|x, y| texture(x, y));
    let i1 = grid(&|x, y| {
        let (a, b) = inverse(x, y);
        texture(a, b)
    });
    let truth = Flow::new(
        w,
        h,
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let (a, b) = forward(x, y);
                [a - x, b - y]
            })
            .collect(),
    );
    (i0, i1, truth)
}

/// The pair `bench flow` measures, as the 8-bit grey values both joca and OpenCV compute on,
/// with its ground truth if known.
struct FlowBenchPair {
    name: String,
    i0: joca_data::flow::Gray,
    i1: joca_data::flow::Gray,
    truth: Option<joca_data::flow::KnownFlow>,
}

impl FlowBenchPair {
    /// `--pair` (with `--gt`/`--gt-disparity`), or the built-in textured pair quantised to 8 bits.
    fn from_args(args: &Args) -> Result<Self> {
        use joca_data::flow::{Gray, read_disparity, read_flo};
        let quantised = |g: &Gray| {
            let data = g.data().iter().map(|v| v.round().clamp(0.0, 255.0)).collect();
            Gray::new(g.width(), g.height(), data)
        };
        let Some(pair) = &args.pair else {
            let (i0, i1, truth) = flow_pair();
            let known = truth.data().iter().map(|&v| Some(v)).collect();
            return Ok(Self {
                name: "1920×1280 textured pair (zoom 1 % + shift)".into(),
                i0: quantised(&i0),
                i1: quantised(&i1),
                truth: Some((truth.width(), truth.height(), known)),
            });
        };
        let (a, b) = (crate::io::read_rgb8(&pair[0])?, crate::io::read_rgb8(&pair[1])?);
        if (a.width(), a.height()) != (b.width(), b.height()) {
            anyhow::bail!(
                "{} and {} differ in size: flow needs frames of one size",
                pair[0].display(),
                pair[1].display()
            );
        }
        let truth = match (&args.gt, &args.gt_disparity) {
            (Some(p), _) => Some(read_flo(p)?),
            (None, Some(p)) => Some(read_disparity(p)?),
            (None, None) => None,
        };
        if let Some((w, h, _)) = &truth
            && (*w, *h) != (a.width(), a.height())
        {
            anyhow::bail!(
                "the ground truth is {w}×{h} but the frames are {}×{}",
                a.width(),
                a.height()
            );
        }
        Ok(Self {
            name: format!(
                "{} → {} ({}×{})",
                pair[0].display(),
                pair[1].display(),
                a.width(),
                a.height()
            ),
            i0: quantised(&Gray::from_rgb8(&a)),
            i1: quantised(&Gray::from_rgb8(&b)),
            truth,
        })
    }

    /// End-point error and share above 3 px of `flow`, if the truth is known.
    fn score(&self, flow: &joca_data::flow::Flow) -> Result<Option<joca_data::flow::FlowAccuracy>> {
        self.truth
            .as_ref()
            .map(|t| joca_data::flow::accuracy(flow, t).map_err(anyhow::Error::msg))
            .transpose()
    }
}

/// One row of the OpenCV reference: preset, threads, best time (ms), flow.
type PeerFlow = (String, usize, f64, joca_data::flow::Flow);

/// OpenCV's DIS on `pair`, per `(preset, threads)`: best time (ms) and its flow, from
/// `scripts/bench_flow_opencv.py` run by `python`; `Err` says why it was not run.
fn opencv_flows(
    pair: &FlowBenchPair,
    python: &str,
    repeats: usize,
    dir: &std::path::Path,
) -> std::result::Result<(String, Vec<PeerFlow>), String> {
    let grey = |g: &joca_data::flow::Gray| -> Result<joca_core::Rgb8Image> {
        let rgb = g.data().iter().flat_map(|&v| [v as u8; 3]).collect();
        Ok(joca_core::Rgb8Image::from_vec(g.width(), g.height(), rgb)?)
    };
    let (p0, p1) = (dir.join("first.png"), dir.join("second.png"));
    for (path, g) in [(&p0, &pair.i0), (&p1, &pair.i1)] {
        grey(g)
            .and_then(|img| crate::io::write_png(path, &img))
            .map_err(|e| format!("cannot write the pair for OpenCV: {e:#}"))?;
    }
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scripts/bench_flow_opencv.py");
    let out = std::process::Command::new(python)
        .arg(script)
        .args([&p0, &p1, &dir.to_path_buf()])
        .args(["--threads", "1", "2", "--repeats", &repeats.to_string()])
        .output()
        .map_err(|e| format!("cannot start {python}: {e}"))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return Err(format!(
            "`{python} {script}` failed ({}); install opencv-python-headless or pass --python",
            err.lines().last().unwrap_or("no message")
        ));
    }
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).map_err(|e| format!("unreadable output: {e}"))?;
    let version = v["version"].as_str().unwrap_or("?").to_owned();
    let rows = v["rows"]
        .as_array()
        .ok_or("no rows in the output")?
        .iter()
        .map(|r| {
            let flo = std::path::Path::new(r["flo"].as_str().ok_or("row without flo")?);
            let (w, h, known) = joca_data::flow::read_flo(flo).map_err(|e| e.to_string())?;
            let data = known.into_iter().map(|v| v.unwrap_or([f32::NAN; 2])).collect();
            Ok((
                r["preset"].as_str().ok_or("row without preset")?.to_owned(),
                r["threads"].as_u64().ok_or("row without threads")? as usize,
                r["ms"].as_f64().ok_or("row without ms")?,
                joca_data::flow::Flow::new(w, h, data),
            ))
        })
        .collect::<std::result::Result<Vec<_>, String>>()?;
    Ok((version, rows))
}

pub(super) fn bench_flow(args: &Args) -> Result<()> {
    use joca_data::flow::{DisParams, DisPreset, dis};
    let repeats = args.repeats.clamp(1, 5);
    let pair = FlowBenchPair::from_args(args)?;
    let dir = std::env::temp_dir().join(format!("joca-bench-flow-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let reference = opencv_flows(&pair, &args.python, repeats, &dir);
    std::fs::remove_dir_all(&dir).ok();
    println!("DIS optical flow on {}, 8-bit grey, best of {repeats} warm calls", pair.name);
    match &reference {
        Ok((version, _)) => println!("beside OpenCV {version}'s DIS on the same pair and threads"),
        Err(why) => println!("(OpenCV reference not run: {why})"),
    }
    let fmt_acc = |a: &Option<joca_data::flow::FlowAccuracy>| {
        a.as_ref().map_or("-".to_owned(), |a| format!("{:.3} / {:.1}%", a.epe, 100.0 * a.above_3px))
    };
    println!(
        "{:<10} {:>7} {:>10} {:>10} {:>9} {:>18} {:>18}",
        "preset",
        "threads",
        "joca ms",
        "OpenCV ms",
        "ratio",
        "joca EPE / >3px",
        "OpenCV EPE / >3px"
    );
    for (name, preset) in [
        ("ultrafast", DisPreset::UltraFast),
        ("fast", DisPreset::Fast),
        ("medium", DisPreset::Medium),
    ] {
        let params = DisParams::preset(preset);
        let ours = pair.score(&dis(&pair.i0, &pair.i1, &params))?;
        for threads in [1usize, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
            let t = pool.install(|| {
                best_of(repeats, || {
                    black_box(dis(&pair.i0, &pair.i1, &params));
                })
            }) * 1e3;
            let peer = reference.as_ref().ok().and_then(|(_, rows)| {
                rows.iter().find(|r| r.0 == name && r.1 == threads).map(|r| (r.2, &r.3))
            });
            let (peer_ms, ratio, peer_acc) = match peer {
                Some((ms, flow)) => {
                    (format!("{ms:.1}"), format!("{:.2}×", t / ms), fmt_acc(&pair.score(flow)?))
                }
                None => ("-".into(), "-".into(), "-".into()),
            };
            println!(
                "{name:<10} {threads:>7} {t:>10.1} {peer_ms:>10} {ratio:>9} {:>18} {peer_acc:>18}",
                fmt_acc(&ours)
            );
        }
    }
    if pair.truth.is_none() {
        println!("(no ground truth given: pass --gt or --gt-disparity for the error columns)");
    }
    if args.pair.is_some() {
        return Ok(());
    }
    let (i0, _, truth) = flow_pair();
    // Blur: the true flow scaled to a 6-pixel mean smear (13 sub-samples per pixel).
    let (w, h) = (i0.width(), i0.height());
    let rgb: Vec<f32> = i0.data().iter().flat_map(|&v| [v, v * 0.8, v * 0.6]).collect();
    let image = HdrImage::from_vec(w, h, rgb)?;
    let travel = 6.0 / truth.mean_magnitude() as f32;
    println!("\nflow-based motion blur, 1920×1280 RGB, mean smear 6 px");
    println!("{:<8} {:>10} {:>12}", "threads", "ms", "Mpixel/s");
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
        let t = pool.install(|| {
            best_of(repeats, || {
                black_box(joca_data::blur::motion_blur(&image, &truth, travel));
            })
        });
        println!("{threads:<8} {:>10.1} {:>12.1}", t * 1e3, (w * h) as f64 / t / 1e6);
    }
    Ok(())
}
