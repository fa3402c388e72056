#!/usr/bin/env python3
"""Markdown table of a panel's finished cells, paired rows together: per scenario and design each
variant's mAP, AP50, share of perturbation searches a tie decided, test exposure and gain by day
and night, day / night exposure x gain and day's mean frame level. Reads the compact cells
(results.json) that land.sh copies. Usage: cells_table.py CELLS_DIR"""
import json, sys
from pathlib import Path

def main(cells):
    rows = []
    for f in sorted(Path(cells).glob("*/results.json")):
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
    main(sys.argv[1])
