#!/usr/bin/env python3
"""Markdown table of a panel's finished cells, paired rows together: per scenario and design each
variant's mAP, AP50, share of perturbation searches a tie decided, test exposure and gain by day
and night, day / night exposure x gain and day's mean frame level. With --by-light, each cell's
mAP by illumination instead, and each design's difference of every variant from the first
(alphabetically) on the row below it. Reads the compact cells (results.json) that land.sh copies;
with --results NAME, each cell's NAME instead (e.g. results-town2.json from eval_town.sh).
Usage: cells_table.py [--by-light] [--results NAME] CELLS_DIR"""
import argparse, json
from pathlib import Path

LIGHTS = ["day", "night", "tunnel", "cycle"]

def by_light(cells, name):
    """Per scenario and design, each variant's mAP by light and its difference from the first."""
    groups = {}
    for f in sorted(Path(cells).glob(f"*/{name}")):
        r = json.loads(f.read_text())
        t = r["test_by_illumination"]
        maps = [t[l]["map"] if isinstance(t[l], dict) else t[l] for l in LIGHTS]
        variant = f.parent.name.split("-" + r["scenario"] + "-")[0]
        design = f.parent.name.split("-" + r["scenario"] + "-")[1]
        groups.setdefault((r["scenario"], design), []).append((variant, maps))
    print("| scenario | design | variant | " + " | ".join(f"mAP {l}" for l in LIGHTS) + " |")
    print("|---|---|---|" + "---|" * len(LIGHTS))
    for (scenario, design), rows in sorted(groups.items()):
        rows.sort()
        for variant, maps in rows:
            print(f"| {scenario} | {design} | {variant} | "
                  + " | ".join(f"{m:.4f}" for m in maps) + " |")
        base_variant, base = rows[0]
        for variant, maps in rows[1:]:
            print(f"| {scenario} | {design} | {variant} − {base_variant} | "
                  + " | ".join(f"{m - b:+.4f}" for m, b in zip(maps, base)) + " |")

def table(cells, name):
    rows = []
    for f in sorted(Path(cells).glob(f"*/{name}")):
        r = json.loads(f.read_text())
        cell = f.parent.name
        s, eg = r["settings_by_illumination"], r["exposure_gain_by_illumination"]
        t = r.get("perturbation_ties")
        ties = f"{100 * t['tied'] / t['searches']:.1f} %" if t and t["searches"] else "–"
        d = r["design"]
        design = f"{d['sensor']} {d['pixel_pitch_um']} µm, {d['focal_length_mm']:.2f} mm"
        variant = cell.split("-" + r["scenario"] + "-")[0]
        rows.append(((r["scenario"], design), variant, [
            f"{r['test']['map']:.4f}", f"{r['test']['ap50']:.3f}", ties,
            f"{s['day'][0]:.1f}, {s['day'][1]:.1f}", f"{s['night'][0]:.1f}, {s['night'][1]:.1f}",
            f"{eg['day'] / eg['night']:.3f}", f"{r['mean_dn_by_illumination']['day']:.0f}"]))
    print("| scenario | design | search | mAP | AP50 | searches a tie decided "
          "| day E (ms), G (dB) | night E, G | day / night E × G | day frame (DN) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for (scenario, design), variant, vals in sorted(rows, key=lambda x: (x[0], x[1])):
        print(f"| {scenario} | {design} | {variant} | " + " | ".join(vals) + " |")

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--by-light", action="store_true")
    ap.add_argument("--results", default="results.json")
    ap.add_argument("cells")
    a = ap.parse_args()
    (by_light if a.by_light else table)(a.cells, a.results)
