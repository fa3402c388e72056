#!/usr/bin/env python3
"""Markdown table of a panel's finished cells, paired rows together: per scenario and design each
variant's mAP, AP50, share of perturbation searches a tie decided, test exposure and gain by day
and night, day / night exposure x gain and day's mean frame level. With --by-light, each cell's
mAP by illumination instead, and each design's difference of every variant from the first
(alphabetically, or the one --base names) on the row below it. Reads the compact cells
(results.json) that land.sh copies; with --results NAME, each cell's NAME instead (e.g.
results-town2.json from eval_town.sh). With --towns NAME,NAME[,...], each design's paired
difference (every variant − the first, or − --base) per results file and averaged over them (mAP
overall and by light), its mean and 95 % Student-t interval over the designs (scipy), and the
correlation of the per-design differences between the first two files. With --training, each
cell's mAP on its own training frames (training_by_generation.json, from compact.py: the mean
over the generations, and over the last four) beside its test mAP on the test town and on town 2,
and each design's difference of every variant from the first (or --base) on the rows below.
With --swap, per scenario and design, ours (joca) against its own controller driving the detector
it started from (results-detector-start*.json, detector_swap.sh) and the frozen-detector cell, on
the test town and town 2: "frozen − ours" split into the detector's part (start − trained
detector, ours' controller) and the controller's part (frozen's − ours' controller, both on the
starting detector), with means and 95 % Student-t intervals over the designs.
With several CELLS_DIRs, a cell of a later one replaces the same-named cell of an earlier one (e.g.
a panel's cells, then repeats of some of them on another machine type).
Usage: cells_table.py [--by-light | --towns NAME,NAME[,...] | --training | --swap]
       [--results NAME] [--base VARIANT] CELLS_DIR [CELLS_DIR ...]"""
import argparse, json, statistics
from pathlib import Path

LIGHTS = ["day", "night", "tunnel", "cycle"]
BASE = None  # the variant every other is compared with (--base); None: the first alphabetically

def cell_files(cells, name):
    """Each cell's file NAME, sorted by cell, from the last of the CELLS_DIRs that has it."""
    files = {}
    for d in cells:
        for f in Path(d).glob(f"*/{name}"):
            files[f.parent.name] = f
    return [files[c] for c in sorted(files)]

def groups(cells, name):
    """{(scenario, design): [(variant, [mAP overall, mAP by light ...])]}, variants sorted."""
    out = {}
    for f in cell_files(cells, name):
        r = json.loads(f.read_text())
        t = r["test_by_illumination"]
        maps = [r["test"]["map"]] + [t[l]["map"] if isinstance(t[l], dict) else t[l]
                                     for l in LIGHTS]
        variant, design = f.parent.name.split("-" + r["scenario"] + "-")
        out.setdefault((r["scenario"], design), []).append((variant, maps))
    return {k: ordered(v) for k, v in out.items()}

def ordered(rows):
    """[(variant, values)] with the base variant (--base, else the first alphabetically) first."""
    return sorted(rows, key=lambda r: (r[0] != BASE, r[0]))

def print_group(scenario, design, rows):
    """Each variant's values, then each variant's difference from the first, one row each."""
    for variant, vals in rows:
        print(f"| {scenario} | {design} | {variant} | " + " | ".join(f"{v:.4f}" for v in vals)
              + " |")
    base_variant, base = rows[0]
    for variant, vals in rows[1:]:
        print(f"| {scenario} | {design} | {variant} − {base_variant} | "
              + " | ".join(f"{v - b:+.4f}" for v, b in zip(vals, base)) + " |")

def by_light(cells, name):
    """Per scenario and design, each variant's mAP by light and its difference from the first."""
    print("| scenario | design | variant | " + " | ".join(f"mAP {l}" for l in LIGHTS) + " |")
    print("|---|---|---|" + "---|" * len(LIGHTS))
    for (scenario, design), rows in sorted(groups(cells, name).items()):
        print_group(scenario, design, [(variant, maps[1:]) for variant, maps in rows])

def paired(cells, name):
    """{(scenario, variant − base): {design: [Δ mAP overall, Δ by light ...]}} from one file."""
    out = {}
    for (scenario, design), rows in groups(cells, name).items():
        base_variant, base = rows[0]
        for variant, maps in rows[1:]:
            key = (scenario, f"{variant} − {base_variant}")
            out.setdefault(key, {})[design] = [m - b for m, b in zip(maps, base)]
    return out

def towns(cells, names):
    from scipy.stats import t as student_t
    per = [paired(cells, n) for n in names]
    cols = ["mAP"] + LIGHTS
    print("| scenario | difference | results | designs | " + " | ".join(cols) + " | ahead |")
    print("|---|---|---|---|" + "---|" * len(cols) + "---|")
    for key in sorted(per[0]):
        designs = sorted(set.intersection(*(set(p.get(key, {})) for p in per)))
        if len(designs) < 2:
            continue
        mean_of = {d: [statistics.mean(p[key][d][i] for p in per) for i in range(len(cols))]
                   for d in designs}
        for label, diffs in [(n, {d: per[k][key][d] for d in designs}) for k, n in
                             enumerate(names)] + [("mean of " + " and ".join(names), mean_of)]:
            cells_ = []
            for i in range(len(cols)):
                x = [diffs[d][i] for d in designs]
                h = student_t.ppf(0.975, len(x) - 1) * statistics.stdev(x) / len(x) ** 0.5
                cells_.append(f"{statistics.mean(x):+.3f} ± {h:.3f}")
            ahead = sum(diffs[d][0] > 0 for d in designs)
            print(f"| {key[0]} | {key[1]} | {label} | {len(designs)} | " + " | ".join(cells_)
                  + f" | {ahead} of {len(designs)} |")
        r = statistics.correlation([per[0][key][d][0] for d in designs],
                                   [per[1][key][d][0] for d in designs])
        print(f"| {key[0]} | {key[1]} | r(Δ mAP, {names[0]} vs {names[1]}) | {len(designs)} | "
              f"{r:.3f} |" + " |" * (len(cols) - 1) + " |")

def training(cells):
    """Per scenario and design, each variant's training-frame mAP beside its test mAP."""
    rows = {}
    for f in cell_files(cells, "training_by_generation.json"):
        gens = json.loads(f.read_text())
        train = [gens[g]["map"] for g in sorted(gens, key=int)]
        r = json.loads((f.parent / "results.json").read_text())
        town2 = f.parent / "results-town2.json"
        t2 = json.loads(town2.read_text())["test"]["map"] if town2.exists() else float("nan")
        variant, design = f.parent.name.split("-" + r["scenario"] + "-")
        vals = [statistics.mean(train), statistics.mean(train[-4:]), r["test"]["map"], t2]
        rows.setdefault((r["scenario"], design), []).append((variant, vals))
    print("| scenario | design | variant | training mAP, all generations | training mAP, last four "
          "| test mAP, test town | test mAP, town 2 |")
    print("|---|---|---|---|---|---|---|")
    for (scenario, design), group in sorted(rows.items()):
        print_group(scenario, design, ordered(group))

def swap(cells):
    """Frozen − ours split into the detector's and the controller's part, per design and town."""
    from scipy.stats import t as student_t
    towns = [("test town", "results.json", "results-detector-start.json"),
             ("town 2", "results-town2.json", "results-detector-start-town2.json")]
    ours = {f.parent.name: f.parent for f in cell_files(cells, "results-detector-start.json")}
    frozen = {f.parent.name: f.parent for f in cell_files(cells, "results.json")
              if f.parent.name.startswith("frozen-detector-")}
    mp = lambda d, n: json.loads((d / n).read_text())["test"]["map"]
    print("| scenario | design | town | ours | ours' controller, starting detector | frozen "
          "| frozen − ours | detector part (start − trained) | controller part (frozen − ours') |")
    print("|---|---|---|---|---|---|---|---|---|")
    parts = {}
    for name, d in sorted(ours.items()):
        scenario, design = name.removeprefix("joca-").split("-", 1)
        fz = frozen.get(f"frozen-detector-{scenario}-{design}")
        for town, res, swp in towns:
            if fz is None or not (d / swp).exists() or not (fz / res).exists():
                continue
            o, w, f = mp(d, res), mp(d, swp), mp(fz, res)
            row = [f - o, w - o, f - w]
            parts.setdefault((scenario, town), []).append(row)
            print(f"| {scenario} | {design} | {town} | {o:.4f} | {w:.4f} | {f:.4f} | "
                  + " | ".join(f"{x:+.4f}" for x in row) + " |")
    for (scenario, town), rows in sorted(parts.items()):
        if len(rows) < 2:
            continue
        out = []
        for i in range(3):
            x = [r[i] for r in rows]
            h = student_t.ppf(0.975, len(x) - 1) * statistics.stdev(x) / len(x) ** 0.5
            out.append(f"{statistics.mean(x):+.3f} ± {h:.3f}")
        print(f"| {scenario} | mean of {len(rows)} designs | {town} | | | | " + " | ".join(out)
              + " |")

def table(cells, name):
    rows = []
    for f in cell_files(cells, name):
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
    ap.add_argument("--towns", metavar="NAME,NAME[,...]")
    ap.add_argument("--training", action="store_true")
    ap.add_argument("--swap", action="store_true")
    ap.add_argument("--results", default="results.json")
    ap.add_argument("--base", metavar="VARIANT")
    ap.add_argument("cells", nargs="+")
    a = ap.parse_args()
    BASE = a.base
    if a.towns:
        towns(a.cells, a.towns.split(","))
    elif a.training:
        training(a.cells)
    elif a.swap:
        swap(a.cells)
    else:
        (by_light if a.by_light else table)(a.cells, a.results)
