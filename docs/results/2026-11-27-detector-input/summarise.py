#!/usr/bin/env python3
"""Summarises an experiment grid's cells (joca experiment --out DIR): per cell the test scores,
the design, the sensors each generation's population held, exposure x gain by light and the
tunnel-exit fall; per method x scenario the mean and a 95 % t interval over seeds; the relative
noise x20 loss per method, paired by seed. Usage: summarise.py GRID_DIR"""
import json, math, re, statistics, sys
from collections import defaultdict
from pathlib import Path

T975 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571}

def interval(xs):
    m = statistics.mean(xs)
    if len(xs) < 2:
        return m, float("nan")
    return m, T975[len(xs) - 1] * statistics.stdev(xs) / math.sqrt(len(xs))

def cell(d):
    r = json.loads((d / "results.json").read_text())
    gens = defaultdict(list)
    if (d / "events.jsonl").exists():
        for line in (d / "events.jsonl").read_text().splitlines():
            e = json.loads(line)
            if "candidate" in e and "design" in e:
                gens[e["generation"]].append(e["design"]["sensor"])
    elif (d / "sensors_by_generation.json").exists():
        # The compact copies under docs/results keep only each generation's sensors.
        for g, sensors in json.loads((d / "sensors_by_generation.json").read_text()).items():
            gens[int(g)] = sensors
    eg = r.get("exposure_gain_by_illumination", {})
    fall = None
    report = (d / "report.md").read_text() if (d / "report.md").exists() else ""
    m = re.search(r"`tunnel` sequence .*? fell ([0-9.]+)×", report)
    if m:
        fall = float(m.group(1))
    return {
        "map": r["test"]["map"], "ap50": r["test"]["ap50"], "tp": r["test"]["tp_ratio"],
        "sensor": r["design"]["sensor"], "pitch": r["design"]["pixel_pitch_um"],
        "f": r["design"]["focal_length_mm"],
        "distinct": [len(set(gens[g])) for g in sorted(gens)],
        "day_night": eg["day"] / eg["night"] if eg.get("night") else None,
        "day_ms": r["settings_by_illumination"].get("day", [None])[0],
        "fall": fall,
    }

def main(grid):
    cells = {}
    for d in sorted((Path(grid) / "cells").iterdir()):
        if (d / "results.json").exists():
            m = re.match(r"(.+)-(\w+)-s(\d+)$", d.name)
            cells[(m.group(1), m.group(2), int(m.group(3)))] = cell(d)
    print("| cell | sensor | p (µm) | f (mm) | mAP | AP50 | TP | distinct sensors per generation | day ms | day/night E×G | tunnel fall |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for (v, s, seed), c in sorted(cells.items()):
        dn = f"{c['day_night']:.3f}" if c["day_night"] is not None else "-"
        fall = f"{c['fall']:.1f}×" if c["fall"] is not None else "-"
        print(f"| {v} {s} s{seed} | {c['sensor']} | {c['pitch']} | {c['f']:.2f} | {c['map']:.3f} | "
              f"{c['ap50']:.3f} | {c['tp']:.3f} | {c['distinct']} | {c['day_ms']:.1f} | {dn} | {fall} |")
    print()
    print("| method | scenario | seeds | mAP mean ± 95 % t | SD |")
    print("|---|---|---|---|---|")
    groups = defaultdict(list)
    for (v, s, seed), c in cells.items():
        groups[(v, s)].append(c["map"])
    for (v, s), xs in sorted(groups.items()):
        m, h = interval(xs)
        sd = statistics.stdev(xs) if len(xs) > 1 else float("nan")
        print(f"| {v} | {s} | {len(xs)} | {m:.3f} ± {h:.3f} | {sd:.3f} |")
    print()
    print("| method | noise ×20 vs calibrated, relative mAP change per seed | mean ± 95 % t |")
    print("|---|---|---|")
    for v in sorted({k[0] for k in cells}):
        seeds = sorted({k[2] for k in cells if k[0] == v})
        rel = [cells[(v, "noise20", s)]["map"] / cells[(v, "calibrated", s)]["map"] - 1
               for s in seeds if (v, "noise20", s) in cells and (v, "calibrated", s) in cells]
        if rel:
            m, h = interval(rel)
            print(f"| {v} | {', '.join(f'{x:+.1%}' for x in rel)} | {m:+.1%} ± {h:.1%} |")

if __name__ == "__main__":
    main(sys.argv[1])
