"""Tiles the frames make_figure.sh rendered into one labelled sheet (and a 2x crop row)."""
import json
import sys
from pathlib import Path

from PIL import Image, ImageDraw

out, target = Path(sys.argv[1]), Path(sys.argv[2])
panels = [
    ("pinhole", "ideal pinhole (the paper's model)"),
    ("f16", "f/16 focused at 5 m"),
    ("f1.4-5m", "f/1.4 focused at 5 m"),
    ("f1.4-1.5m", "f/1.4 focused at 1.5 m"),
    ("fog300", "fog, visibility 300 m"),
    ("fog100", "fog, visibility 100 m"),
    ("rain-5ms", "rain 25 mm/h, 5 ms"),
    ("rain-40ms", "rain 25 mm/h, 40 ms"),
]
frames = []
for name, label in panels:
    coco = json.loads((out / name / "annotations.json").read_text())
    last = coco["images"][-1]
    settings = f"E {last['exposure_s'] * 1e3:.1f} ms, G {last['gain_db']:.1f} dB"
    frames.append((Image.open(out / name / last["file_name"]), f"{label}; {settings}"))
w, h = frames[0][0].size
cols, bar = 4, 22
sheet = Image.new("RGB", (w * cols, (h + bar) * 2), "white")
draw = ImageDraw.Draw(sheet)
for k, (img, label) in enumerate(frames):
    x, y = (k % cols) * w, (k // cols) * (h + bar)
    sheet.paste(img, (x, y + bar))
    draw.text((x + 4, y + 5), label, fill="black")
sheet.resize((sheet.width * 3 // 4, sheet.height * 3 // 4), Image.LANCZOS).save(target, quality=85)
print(f"wrote {target} ({sheet.size[0]}x{sheet.size[1]})")
