#!/usr/bin/env python3
"""Table 1 again from finished cells named METHOD-SCENARIO-sSEED (results.json; results-town2.json
where eval_town.sh made one): per scenario and method the mAP and TP ratio, mean and 95 % Student-t
interval over seeds (scipy), beside the paper's Table 1; each seed's design and daylight exposure;
ours minus every other method paired by seed (same training frames and test scenes per seed, not the
same design); every method's mAP and each GA method's pixel pitch and daylight exposure per scenario
against its calibrated cell, by seed; and per scenario ours' daylight exposure against TaCOS +
AverageAE's, by seed; and ours minus every other method pooled over the scenarios per seed (each
seed's mean over the scenarios both methods ran, then the interval over seeds: the scenarios of one
seed share its training frames and test scenes, so they are not independent). With several
CELLS_DIRs a later one's cells of a scenario and method replace all of an earlier one's (e.g. issue
39's grid, then Table 1's own cells), so no row mixes grids (their machine types differ); every row
names where its cells came from.
Usage: table1.py CELLS_DIR [CELLS_DIR ...]"""
import json, statistics, sys
from pathlib import Path

SCENARIOS = ["calibrated", "noise10", "noise20", "blur2", "blur4"]
METHODS = ["flir", "basler", "tacos", "joca"]
LABEL = {"flir": "FLIR + NeuralAE", "basler": "Basler + NeuralAE", "tacos": "TaCOS + AverageAE",
         "joca": "Ours"}
# The paper's Table 1 (synthetic images): mAP, TP ratio, pixel pitch (µm).
PAPER = {
    "calibrated": {"flir": (0.318, 0.389, 1.55), "basler": (0.289, 0.360, 3.75),
                   "tacos": (0.303, 0.358, 4.5), "joca": (0.325, 0.390, 2.4)},
    "noise10": {"flir": (0.263, 0.382, 1.55), "basler": (0.286, 0.334, 3.75),
                "tacos": (0.288, 0.363, 5.86), "joca": (0.296, 0.377, 5.86)},
    "noise20": {"flir": (0.234, 0.330, 1.55), "basler": (0.276, 0.358, 3.75),
                "tacos": (0.245, 0.371, 7.0), "joca": (0.289, 0.381, 3.45)},
    "blur2": {"flir": (0.297, 0.345, 1.55), "basler": (0.259, 0.358, 3.75),
              "tacos": (0.297, 0.371, 5.5), "joca": (0.300, 0.386, 6.6)},
    "blur4": {"flir": (0.271, 0.367, 1.55), "basler": (0.255, 0.344, 3.75),
              "tacos": (0.271, 0.364, 5.5), "joca": (0.303, 0.384, 6.6)},
}

def interval(xs, sign=False):
    """'mean ± half-width' of a 95 % Student-t interval over xs ('mean (n = 1)' for one value),
    the mean with its sign always where `sign`."""
    from scipy.stats import t as student_t
    m = f"{statistics.mean(xs):{'+' if sign else ''}.3f}"
    if len(xs) < 2:
        return f"{m} (n = 1)"
    h = student_t.ppf(0.975, len(xs) - 1) * statistics.stdev(xs) / len(xs) ** 0.5
    return f"{m} ± {h:.3f}"

def signed(xs):
    return interval(xs, sign=True)

def header(*columns):
    """A markdown table's header row and its separator."""
    print("| " + " | ".join(columns) + " |")
    print("|" + "---|" * len(columns))

def read_cell(d):
    """A cell folder's results and its town-2 mAP (None where eval_town.sh made none)."""
    t2 = d / "results-town2.json"
    return {"r": json.loads((d / "results.json").read_text()),
            "town2": json.loads(t2.read_text())["test"]["map"] if t2.exists() else None}

def load(dirs):
    """{(scenario, method, seed): cell}, a later dir's (scenario, method) replacing an earlier's."""
    cells = {}
    for tag, d in enumerate(dirs):
        found = {}
        for f in sorted(Path(d).glob("*/results.json")):
            name = f.parent.name
            method, rest = name.split("-", 1)
            scenario, seed = rest.rsplit("-s", 1)
            if method not in METHODS or scenario not in SCENARIOS:
                continue
            found[(scenario, method, int(seed))] = {**read_cell(f.parent), "from": tag + 1}
        rows = {(sc, m) for (sc, m, _) in found}
        cells = {k: c for k, c in cells.items() if k[:2] not in rows}
        cells.update(found)
    return cells

def seeds_of(cells, scenario, method):
    return sorted(s for (sc, m, s) in cells if sc == scenario and m == method)

def main_table(cells):
    header("scenario", "method", "seeds", "mAP", "paper mAP", "TP ratio", "paper TP", "mAP, town 2",
           "from")
    for sc in SCENARIOS:
        for m in METHODS:
            seeds = seeds_of(cells, sc, m)
            if not seeds:
                continue
            cs = [cells[(sc, m, s)] for s in seeds]
            t2 = [c["town2"] for c in cs if c["town2"] is not None]
            p = PAPER[sc][m]
            print(f"| {sc} | {LABEL[m]} | {len(seeds)} | "
                  f"{interval([c['r']['test']['map'] for c in cs])} | {p[0]:.3f} | "
                  f"{interval([c['r']['test']['tp_ratio'] for c in cs])} | {p[1]:.3f} | "
                  f"{interval(t2) if t2 else '–'} | "
                  f"{','.join(sorted({str(c['from']) for c in cs}))} |")

def designs(cells):
    header("scenario", "method", "seed", "design", "x, z (m)", "mAP", "day E (ms), G (dB)",
           "day frame (DN)")
    for sc in SCENARIOS:
        for m in METHODS:
            for s in seeds_of(cells, sc, m):
                r = cells[(sc, m, s)]["r"]
                d, day = r["design"], r["settings_by_illumination"]["day"]
                print(f"| {sc} | {LABEL[m]} | {s} | {d['sensor']} {d['pixel_pitch_um']} µm, "
                      f"{d['focal_length_mm']:.2f} mm | {d['x_m']:.2f}, {d['z_m']:.2f} | "
                      f"{r['test']['map']:.4f} | {day[0]:.1f}, {day[1]:.1f} | "
                      f"{r['mean_dn_by_illumination']['day']:.0f} |")

def paired(cells):
    header("scenario", "ours −", "seeds", "Δ mAP, test town", "ahead", "Δ mAP, town 2", "ahead")
    for sc in SCENARIOS:
        for m in METHODS[:-1]:
            seeds = [s for s in seeds_of(cells, sc, m) if (sc, "joca", s) in cells]
            if not seeds:
                continue
            pairs = [(cells[(sc, "joca", s)], cells[(sc, m, s)]) for s in seeds]
            d1 = [o["r"]["test"]["map"] - b["r"]["test"]["map"] for o, b in pairs]
            d2 = [o["town2"] - b["town2"] for o, b in pairs
                  if o["town2"] is not None and b["town2"] is not None]
            town2 = f"{signed(d2)} | {sum(x > 0 for x in d2)} of {len(d2)}" if d2 else "– | –"
            print(f"| {sc} | {LABEL[m]} | {len(seeds)} | {signed(d1)} | "
                  f"{sum(x > 0 for x in d1)} of {len(d1)} | {town2} |")

def against_calibrated(cells, method, what, value):
    """Per scenario, METHOD's VALUE per seed against its calibrated cell of the same seed."""
    for sc in SCENARIOS[1:]:
        seeds = [s for s in seeds_of(cells, sc, method) if ("calibrated", method, s) in cells]
        if not seeds:
            continue
        pairs = [(value(cells[("calibrated", method, s)]["r"]), value(cells[(sc, method, s)]["r"]))
                 for s in seeds]
        per = ", ".join(f"{a:.3g} → {b:.3g}" for a, b in pairs)
        print(f"| {LABEL[method]} | {what} | {sc} | {per} | {signed([b - a for a, b in pairs])} |")

def mechanisms(cells):
    header("method", "quantity", "scenario", "calibrated → scenario, by seed", "change")
    for m in ["tacos", "joca"]:
        against_calibrated(cells, m, "pixel pitch (µm)", lambda r: r["design"]["pixel_pitch_um"])
    for m in METHODS:
        against_calibrated(cells, m, "mAP", lambda r: r["test"]["map"])
    for m in ["tacos", "joca"]:
        against_calibrated(cells, m, "day exposure (ms)",
                           lambda r: r["settings_by_illumination"]["day"][0])
    print()
    header("scenario", "seeds", "ours day E (ms)", "TaCOS + AverageAE day E (ms)", "ours − TaCOS")
    for sc in SCENARIOS:
        seeds = [s for s in seeds_of(cells, sc, "joca") if (sc, "tacos", s) in cells]
        if not seeds:
            continue
        day = lambda m, s: cells[(sc, m, s)]["r"]["settings_by_illumination"]["day"][0]
        o, t = [day("joca", s) for s in seeds], [day("tacos", s) for s in seeds]
        print(f"| {sc} | {len(seeds)} | {', '.join(f'{x:.1f}' for x in o)} | "
              f"{', '.join(f'{x:.1f}' for x in t)} | {signed([a - b for a, b in zip(o, t)])} |")

def pooled(cells):
    """Ours − each method, per seed the mean over the scenarios where both have the value, on the
    test town, town 2 and their mean; the interval is over seeds; [n, n, n]: scenarios per seed."""
    header("ours −", "seeds", "test town", "town 2", "mean of both towns", "per seed (test town)")
    both = lambda c: (c["r"]["test"]["map"] + c["town2"]) / 2 if c["town2"] is not None else None
    for m in METHODS[:-1]:
        cols, first = [], None
        for value in (lambda c: c["r"]["test"]["map"], lambda c: c["town2"], both):
            by_seed = {}
            for (sc, mm, s), c in cells.items():
                o = cells.get((sc, "joca", s))
                if mm == m and o is not None and value(c) is not None and value(o) is not None:
                    by_seed.setdefault(s, []).append(value(o) - value(c))
            if not by_seed:
                cols.append("–")
                continue
            means = [statistics.mean(by_seed[s]) for s in sorted(by_seed)]
            counts = ", ".join(str(len(by_seed[s])) for s in sorted(by_seed))
            cols.append(f"{signed(means)} [{counts}]")
            first = first or means
        print(f"| {LABEL[m]} | {len(first)} | {' | '.join(cols)} | "
              f"{', '.join(f'{x:+.3f}' for x in first)} |")

if __name__ == "__main__":
    if len(sys.argv) < 2 or sys.argv[1].startswith("-"):
        sys.exit(__doc__)
    cells = load(sys.argv[1:])
    print("Cells from: " + "; ".join(f"{i + 1} = {d}" for i, d in enumerate(sys.argv[1:])))
    for part in (main_table, paired, pooled, designs, mechanisms):
        print()
        part(cells)
