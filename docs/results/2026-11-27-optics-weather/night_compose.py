"""Tiles night_glow.sh's three frames (clear, fog 300 m, fog 100 m) side by side, labelled."""
import json
import sys
from pathlib import Path

from PIL import Image, ImageDraw

out, target = Path(sys.argv[1]), Path(sys.argv[2])
panels = [("clear", "night, clear"), ("fog300", "night, fog 300 m"), ("fog100", "night, fog 100 m")]
frames = []
for name, label in panels:
    last = json.loads((out / name / "annotations.json").read_text())["images"][-1]
    settings = f"E {last['exposure_s'] * 1e3:.0f} ms, G {last['gain_db']:.0f} dB"
    frames.append((Image.open(out / name / last["file_name"]), f"{label}; {settings}"))
w, h = frames[0][0].size
bar = 22
sheet = Image.new("RGB", (w * len(frames), h + bar), "white")
draw = ImageDraw.Draw(sheet)
for k, (img, label) in enumerate(frames):
    sheet.paste(img.convert("RGB"), (k * w, bar))
    draw.text((k * w + 6, 4), label, fill="black")
sheet.save(target, quality=88)
