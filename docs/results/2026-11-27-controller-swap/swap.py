#!/usr/bin/env python3
"""NeuralAE against AverageAE on the same trained design: each fixed-camera cell of the standard
grid tested again with `joca eval` (its own controller -> results-eval.json) and with
`joca eval --controller average` (AverageAE at mid-grey, same detector, same test frames ->
results-average-127.5.json). Prints the per-cell numbers and the paired differences with
Student's t intervals (scipy's quantile), overall and by illumination.

Usage: swap.py DIR  (DIR holds one folder per cell, named <camera>-calibrated-s<k>)
"""
import json
import sys
from pathlib import Path
from statistics import mean, stdev
from scipy.stats import t

LIGHTS = ["day", "night", "tunnel", "cycle"]


def interval(values):
    n = len(values)
    if n < 2:
        return mean(values), float("nan")
    return mean(values), t.ppf(0.975, n - 1) * stdev(values) / n ** 0.5


def load(cell, name):
    return json.loads((cell / name).read_text())


def main(root):
    cells = sorted(p for p in Path(root).iterdir() if (p / "results-eval.json").is_file())
    print("| cell | controller | mAP | AP50 | " + " | ".join(f"mAP {l}" for l in LIGHTS)
          + " | day/night E×G | day mean DN |")
    print("|---|---|---|---|" + "---|" * len(LIGHTS) + "---|---|")
    pairs = []
    for cell in cells:
        runs = {"NeuralAE": load(cell, "results-eval.json"),
                "AverageAE": load(cell, "results-average-127.5.json")}
        for name, r in runs.items():
            eg = r["exposure_gain_by_illumination"]
            by = r.get("test_by_illumination", {})
            lights = " | ".join(f"{by[l]['map']:.4f}" if l in by else "–" for l in LIGHTS)
            print(f"| {cell.name} | {name} | {r['test']['map']:.4f} | {r['test']['ap50']:.4f} | "
                  f"{lights} | {eg['day'] / eg['night']:.3f} | "
                  f"{r['mean_dn_by_illumination']['day']:.0f} |")
        pairs.append((cell.name, runs["NeuralAE"], runs["AverageAE"]))
    print()
    print("| pairs | Δ mAP (NeuralAE − AverageAE) | Δ AP50 | "
          + " | ".join(f"Δ mAP {l}" for l in LIGHTS) + " |")
    print("|---|---|---|" + "---|" * len(LIGHTS))
    for label, keep in [("all", lambda n: True), ("FLIR", lambda n: n.startswith("flir")),
                        ("Basler", lambda n: n.startswith("basler"))]:
        sel = [(a, b) for n, a, b in pairs if keep(n)]
        cells_ = [f"{m:+.4f} ± {h:.4f}" for m, h in [
            interval([a["test"]["map"] - b["test"]["map"] for a, b in sel]),
            interval([a["test"]["ap50"] - b["test"]["ap50"] for a, b in sel])]]
        for l in LIGHTS:
            d = [a["test_by_illumination"][l]["map"] - b["test_by_illumination"][l]["map"]
                 for a, b in sel
                 if l in a.get("test_by_illumination", {}) and l in b.get("test_by_illumination", {})]
            cells_.append("–" if not d else "%+.4f ± %.4f" % interval(d))
        print(f"| {label} ({len(sel)}) | " + " | ".join(cells_) + " |")


if __name__ == "__main__":
    main(sys.argv[1])
