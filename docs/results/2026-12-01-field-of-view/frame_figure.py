#!/usr/bin/env python3
"""One frame of `joca render` per design, each with its reference boxes drawn, scaled by nearest
neighbour to one display width and stacked into one PNG, captioned with what the detector gets.

Usage: frame_figure.py OUT.{png,jpg} FRAME_INDEX RENDER_DIR:CAPTION [RENDER_DIR:CAPTION ...]
Each RENDER_DIR is a `joca render --out` folder (frames/, annotations.json). Needs Pillow.
"""
import json
import os
import sys

from PIL import Image, ImageDraw

WIDTH = 640


def panel(render_dir, index, caption):
    ann = json.load(open(os.path.join(render_dir, "annotations.json")))
    image = ann["images"][index]
    frame = Image.open(os.path.join(render_dir, image["file_name"])).convert("RGB")
    scale = WIDTH / frame.width
    big = frame.resize((WIDTH, round(frame.height * scale)), Image.NEAREST)
    draw = ImageDraw.Draw(big)
    widths = []
    for a in ann["annotations"]:
        if a["image_id"] != image["id"]:
            continue
        x, y, w, h = (v * scale for v in a["bbox"])
        draw.rectangle([x, y, x + w, y + h], outline=(255, 40, 40))
        widths.append(a["bbox"][2])
    small = sum(1 for w in widths if w < 8)
    text = "%s: %dx%d px input; %d of %d reference boxes under 8 px wide" % (
        caption, frame.width, frame.height, small, len(widths))
    out = Image.new("RGB", (WIDTH, big.height + 18), (255, 255, 255))
    out.paste(big, (0, 18))
    ImageDraw.Draw(out).text((4, 3), text, fill=(0, 0, 0))
    return out


def main(argv):
    out, index = argv[0], int(argv[1])
    panels = []
    for spec in argv[2:]:
        render_dir, caption = spec.split(":", 1)
        panels.append(panel(render_dir, index, caption))
    sheet = Image.new("RGB", (WIDTH, sum(p.height for p in panels)), (255, 255, 255))
    y = 0
    for p in panels:
        sheet.paste(p, (0, y))
        y += p.height
    # JPEG for the committed figure: sensor noise compresses poorly as PNG.
    sheet.save(out, quality=80, optimize=True)


if __name__ == "__main__":
    main(sys.argv[1:])
