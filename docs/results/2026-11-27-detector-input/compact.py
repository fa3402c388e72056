#!/usr/bin/env python3
"""Copies a finished grid cell's compact record into docs/results: results.json, best_design.json,
config.toml, cell.toml, report.md, results-town<K>.json (`joca eval --town K`, where run),
results-detector-start*.json (`joca eval --detector start`, where run),
sensors_by_generation.json (each generation's sensors) and training_by_generation.json (each
generation's mean over its candidates of the training frames' mAP, AP50, TP ratio and fitness),
both from events.jsonl, which stays out of the repository. Skips unfinished cells. The cell's
report.md comes without its figures, which stay out too (strip_figures.awk says so in it).
Usage: compact.py GRID_DIR DEST_DIR [CELL ...]"""
import json, shutil, subprocess, sys
from collections import defaultdict
from pathlib import Path

def compact(src, dest):
    if not (src / "results.json").exists():
        return False
    dest.mkdir(parents=True, exist_ok=True)
    names = ["results.json", "best_design.json", "config.toml", "cell.toml"]
    names += sorted(f.name for f in src.glob("results-town*.json"))
    names += sorted(f.name for f in src.glob("results-detector-start*.json"))
    for name in names:
        if (src / name).exists():
            shutil.copyfile(src / name, dest / name)
    if (src / "report.md").exists():
        strip_figures(src / "report.md", dest / "report.md", src)
    gens, scores = defaultdict(list), defaultdict(list)
    # A cell restored from its compact record (restore.sh) has no events.jsonl: its
    # sensors_by_generation.json came with it.
    events = src / "events.jsonl"
    lines = events.read_text().splitlines() if events.exists() else []
    for line in lines:
        e = json.loads(line)
        if "candidate" in e and "design" in e:
            gens[e["generation"]].append(e["design"]["sensor"])
            s = e["scores"]
            scores[e["generation"]].append([s["map"], s["ap50"], s["tp_ratio"], e["fitness"]])
    if gens:
        (dest / "sensors_by_generation.json").write_text(json.dumps(gens, indent=0) + "\n")
        training = {g: dict(zip(["map", "ap50", "tp_ratio", "fitness"],
                                (round(sum(c) / len(c), 6) for c in zip(*rows))))
                    for g, rows in scores.items()}
        (dest / "training_by_generation.json").write_text(json.dumps(training, indent=1) + "\n")
    return True

def strip_figures(report, dest, src):
    """Writes `report` to `dest` without its figure links (uncommitted files) and their captions."""
    awk = Path(__file__).resolve().parent.parent / "2026-11-27-panels" / "strip_figures.awk"
    text = subprocess.run(["awk", "-v", f"src={src}", "-f", str(awk), str(report)],
                          check=True, capture_output=True, text=True).stdout
    dest.write_text(text)

def main(grid, dest, names):
    cells = Path(grid) / "cells"
    for d in sorted(cells.iterdir()):
        if names and d.name not in names:
            continue
        if compact(d, Path(dest) / "cells" / d.name):
            print("copied", d.name)

if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3:])
