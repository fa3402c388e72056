//! Self-contained HTML reports: one file with inline CSS and every figure embedded as a
//! `data:` URI, no scripts and no external resources, so it opens anywhere (and e-mails well).

use crate::table::escape;
use crate::{Figure, ReportError, io_err};
use base64::Engine as _;
use std::path::Path;

const STYLE: &str = "
body { font-family: 'DejaVu Sans', Verdana, sans-serif; margin: 2em auto; max-width: 1200px;
  color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 2em; }
table { border-collapse: collapse; font-size: 0.9em; margin: 1em 0; }
th, td { padding: 4px 8px; text-align: right; border-bottom: 1px solid #ddd; white-space: nowrap; }
td.label { white-space: normal; }
thead th { border-bottom: 2px solid #444; vertical-align: bottom; }
tbody th { text-align: left; vertical-align: top; border-right: 1px solid #ddd; }
tr.first td, tr.first th { border-top: 2px solid #888; }
td.label { text-align: left; }
.opt { color: #1a9a1a; } .fix { color: #777; }
figure { margin: 1.5em 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #444; margin-top: 0.4em; }
.meta { color: #555; font-size: 0.9em; }
";

/// A complete HTML page: `body` (already HTML) followed by `figures`, read from `dir` and
/// embedded.
pub(crate) fn page(
    title: &str,
    body: &str,
    dir: &Path,
    figures: &[Figure],
) -> Result<String, ReportError> {
    let mut html = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{}</h1>\n{body}\n",
        escape(title),
        escape(title)
    );
    let mut section = None;
    for f in figures {
        if section != Some(&f.section) {
            html.push_str(&format!("<h2>{}</h2>\n", escape(&f.section)));
            section = Some(&f.section);
        }
        let path = dir.join(&f.file);
        let bytes = std::fs::read(&path).map_err(|e| io_err(&path, e))?;
        let mime = if f.file.ends_with(".gif") { "image/gif" } else { "image/png" };
        html.push_str(&format!(
            "<figure>\n<img alt=\"{}\" \
                src=\"data:{mime};base64,{}\">\n<figcaption>{}</figcaption>\n</figure>\n",
            escape(&f.file),
            base64::engine::general_purpose::STANDARD.encode(bytes),
            escape(&f.caption)
        ));
    }
    html.push_str("</body>\n</html>\n");
    Ok(html)
}
