#!/usr/bin/env python3
"""Same-design comparisons across machine types: for each cell of REPEATS_DIR (a panel cell run
again, same cell.toml, on another machine type) its mAP, AP50, tie share and day exposure beside
the original in CELLS_DIR, and beside each other variant of CELLS_DIR on the same scenario and
design that ran on the repeat's machine type (a same-machine pair). Where both the repeat and the
original were also tested on town 2 (results-town2.json), their difference there too.
Usage: machine_pairs.py CELLS_DIR REPEATS_DIR"""
import json, sys
from pathlib import Path


def load(d, name="results.json"):
    r = json.loads((d / name).read_text())
    t = r.get("perturbation_ties")
    return {
        "map": r["test"]["map"],
        "ap50": r["test"]["ap50"],
        # No perturbation search (no GA loss): no tie share.
        "ties": f"{100 * t['tied'] / t['searches']:.1f} %" if t and t["searches"] else "—",
        "day_e": r["settings_by_illumination"]["day"][0],
        "machine": f"{r.get('cpu', '?')}, scoring {r.get('scoring_precision', '?')}",
        "scenario": r["scenario"],
    }


def main(cells, repeats):
    cells, repeats = Path(cells), Path(repeats)
    print("| cell | machine | mAP | AP50 | ties | day E (ms) |")
    print("|---|---|---|---|---|---|")
    pairs = []
    for rep in sorted(repeats.glob("*/results.json")):
        name = rep.parent.name
        orig = cells / name
        a, b = load(orig), load(rep.parent)
        for tag, x in [("original", a), ("repeat", b)]:
            print(f"| {name} ({tag}) | {x['machine']} | {x['map']:.4f} | {x['ap50']:.3f} "
                  f"| {x['ties']} | {x['day_e']:.1f} |")
        pairs.append((name, a, b))
        # Other variants of the same scenario and design on the repeat's machine type.
        rest = name[name.index("-" + b["scenario"] + "-") + 1:]
        for other in sorted(cells.glob(f"*-{rest}/results.json")):
            o = load(other.parent)
            if other.parent.name != name and o["machine"] == b["machine"]:
                print(f"| {other.parent.name} | {o['machine']} | {o['map']:.4f} | {o['ap50']:.3f} "
                      f"| {o['ties']} | {o['day_e']:.1f} |")
    print()
    for name, a, b in pairs:
        print(f"{name}: repeat − original {b['map'] - a['map']:+.4f} mAP, "
              f"{b['ap50'] - a['ap50']:+.3f} AP50, day E {b['day_e'] - a['day_e']:+.1f} ms")
        town2 = [d / "results-town2.json" for d in (cells / name, repeats / name)]
        if all(f.exists() for f in town2):
            a2, b2 = (load(f.parent, f.name) for f in town2)
            print(f"{name}, town 2: repeat − original {b2['map'] - a2['map']:+.4f} mAP, "
                  f"{b2['ap50'] - a2['ap50']:+.3f} AP50")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
