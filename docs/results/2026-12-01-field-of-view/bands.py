#!/usr/bin/env python3
"""Field of view against the detector input, per cell: each design's horizontal field, the
detector input it is resized to, the width in input pixels of a 1.8 m wide car at 85 m (pinhole,
on the optical axis) at that input and at the paper's (short side 800, long side <= 1333), and
the cell's test mAP overall and per distance band (objects per band in brackets).

Usage: bands.py CELLS_DIR [CELLS_DIR ...] [--filter SUBSTRING] [--town2]
Reads each cell's results.json (results-town2.json with --town2); prints a markdown table.
"""
import argparse
import json
import math
import os


def input_size(w_mm, h_mm, short_px, long_max_px):
    """The detector input (width, height) in pixels: short side short_px, long side at most
    long_max_px, aspect kept (DESIGN.md, "Detector input"; joca's own is `DetectorInput::size_for`
    in crates/joca-camera/src/input.rs, which also rounds to whole pixels of the native grid)."""
    scale = short_px / min(w_mm, h_mm)
    if max(w_mm, h_mm) * scale > long_max_px:
        scale = long_max_px / max(w_mm, h_mm)
    return w_mm * scale, h_mm * scale


def car_px(design, width_px, distance_m=85.0, car_m=1.8):
    """Image width of a car on the axis at distance_m, in pixels of an input width_px wide."""
    w_mm = design["sensor_mm"][0]
    return car_m * design["focal_length_mm"] / distance_m / w_mm * width_px


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cells", nargs="+", help="folders of cell directories")
    ap.add_argument("--filter", default="", help="only cells whose name contains this")
    ap.add_argument("--town2", action="store_true", help="results-town2.json")
    args = ap.parse_args()
    name = "results-town2.json" if args.town2 else "results.json"
    rows, edges = [], []
    for cells in args.cells:
        for cell in sorted(os.listdir(cells)):
            path = os.path.join(cells, cell, name)
            if args.filter not in cell or not os.path.exists(path):
                continue
            r = json.load(open(path))
            edges = r["test_bands"]
            d = r["design"]
            w_mm, h_mm = d["sensor_mm"]
            inp = r["input"]
            w_px, h_px = input_size(w_mm, h_mm, inp["short_px"], inp["long_max_px"])
            w800, _ = input_size(w_mm, h_mm, 800, 1333)
            fov = 2 * math.degrees(math.atan(w_mm / 2 / d["focal_length_mm"]))
            bands = " | ".join(
                "%.3f (%d)" % (b["map"], sum(b["class_objects"])) for b in r["test_bands"]
            )
            rows.append(
                (fov, "| %s | %s %.2f mm, %.2f µm | %.0f° | %.0f×%.0f | %.1f | %.1f | %.3f | %s |"
                 % (cell, d["sensor"], d["focal_length_mm"], d["pixel_pitch_um"], fov,
                    w_px, h_px, car_px(d, w_px), car_px(d, w800), r["test"]["map"], bands))
            )
    head = " | ".join("%g–%g m" % (b["from_m"], b["to_m"]) for b in edges)
    print("| cell | design | field | input | car px @85 m | at 800 px | mAP | %s |" % head)
    print("|---" * (7 + len(edges)) + "|")
    for _, row in sorted(rows, key=lambda t: -t[0]):
        print(row)


if __name__ == "__main__":
    main()
