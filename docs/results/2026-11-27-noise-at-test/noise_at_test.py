#!/usr/bin/env python3
"""What noise x20 costs a trained design at test alone: each calibrated fixed-camera cell of the
standard grid tested again under noise x20 with its own trained detector and controller
(`joca eval DIR --scenario noise20` -> results-noise20.json), beside its own calibrated test
(results.json) and the same seed's cell trained under noise x20 (GRID/<camera>-noise20-s<k>).
Prints per cell and per camera the relative mAP change with a Student's t interval over seeds.

Usage: noise_at_test.py EVALS GRID   (EVALS: folders <camera>-calibrated-s<k> holding both
results files; GRID: the grid's cells folder, or the compact copy in docs/results)
"""
import json
import sys
from pathlib import Path
from statistics import mean, stdev
from scipy.stats import t


def interval(xs):
    if len(xs) < 2:
        return mean(xs), float("nan")
    return mean(xs), t.ppf(0.975, len(xs) - 1) * stdev(xs) / len(xs) ** 0.5


def main(evals, grid):
    print("| cell | calibrated test | same model, noise ×20 test | change | trained under noise ×20 | change |")
    print("|---|---|---|---|---|---|")
    by_camera = {}
    for cell in sorted(Path(evals).iterdir()):
        if not (cell / "results-noise20.json").is_file():
            continue
        cal = json.loads((cell / "results.json").read_text())["test"]["map"]
        at_test = json.loads((cell / "results-noise20.json").read_text())["test"]["map"]
        trained_dir = Path(grid) / cell.name.replace("calibrated", "noise20")
        trained = json.loads((trained_dir / "results.json").read_text())["test"]["map"]
        a, b = at_test / cal - 1, trained / cal - 1
        print(f"| {cell.name} | {cal:.4f} | {at_test:.4f} | {100 * a:+.1f} % | {trained:.4f} | {100 * b:+.1f} % |")
        by_camera.setdefault(cell.name.split("-")[0], []).append((a, b))
    print()
    print("| camera | seeds | noise ×20 at test only | trained under noise ×20 |")
    print("|---|---|---|---|")
    for camera, pairs in by_camera.items():
        (ma, ha), (mb, hb) = interval([p[0] for p in pairs]), interval([p[1] for p in pairs])
        print(f"| {camera} | {len(pairs)} | {100 * ma:+.1f} % ± {100 * ha:.1f} % | {100 * mb:+.1f} % ± {100 * hb:.1f} % |")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
