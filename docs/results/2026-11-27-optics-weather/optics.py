#!/usr/bin/env python3
"""Issue 41's tables from finished cells named VARIANT-SCENARIO-sSEED (results.json; results-town2.json
where eval_town.sh made one), one experiment folder at a time:

  optics.py aperture CELLS_DIR   the `aperture` experiment (f16, aperture, iris × calibrated,
                                 noise20): per variant the mAP over seeds, overall and per
                                 illumination; each seed's design, f-number, exposure and gain by
                                 day, night and tunnel; each variant minus f16 paired by seed
                                 (mAP, exposure and gain per light, pitch, focal length, night
                                 frame); each seed's difference beside the
                                 f-numbers both cells ran at.
  optics.py fog CELLS_DIR        the `fog` experiment (tacos/joca × clear/fog300): per method and
                                 weather the mAP over seeds; each seed's design and settings; fog
                                 minus clear per method and ours minus TaCOS per weather, paired
                                 by seed (mAP, settings, pitch, focal length, night frame).

Intervals: mean ± t(0.975, n − 1)·s/√n over seeds (scipy's Student t), as table1.py. Every cell of a
seed sees the same training frames and test scenes, so differences are paired by seed (the designs
differ: each variant runs its own GA)."""
import json, sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "2026-11-27-table1-again"))
from table1 import header, interval, read_cell, signed  # noqa: E402

LIGHTS = ["day", "night", "tunnel", "cycle"]

def load(d):
    """{(variant, scenario, seed): {"r": results, "town2": mAP or None}}."""
    cells = {}
    for f in sorted(Path(d).glob("*/results.json")):
        variant_scenario, seed = f.parent.name.rsplit("-s", 1)
        variant, scenario = variant_scenario.rsplit("-", 1)
        cells[(variant, scenario, int(seed))] = read_cell(f.parent)
    return cells

# Display order of variants and scenarios; others after them, by name.
ORDER = ["f16", "aperture", "iris", "tacos-clear", "joca-clear", "tacos-fog300", "joca-fog300",
         "calibrated", "noise20"]

def rank(v):
    return (ORDER.index(v), "") if v in ORDER else (len(ORDER), v)

def keys(cells, at):
    return sorted({k[at] for k in cells}, key=rank)

def light_map(c, light):
    return c["r"]["test_by_illumination"][light]["map"]

# A design's f-number when results.json leaves it out: the calibration aperture (joca-camera's
# design.rs writes `f_number` only where it differs from it).
CALIBRATION_F_NUMBER = 16.0

def f_number(r, light):
    """The f-number a light was tested at: the iris's, else the design's."""
    return r.get("f_number_by_illumination", {}).get(
        light, r["design"].get("f_number", CALIBRATION_F_NUMBER))

def summary(cells):
    header("scenario", "variant", "seeds", "mAP, test town", "mAP, town 2",
           *[f"mAP {l}" for l in LIGHTS], "f-number (day, night, tunnel)")
    for sc in keys(cells, 1):
        for v in keys(cells, 0):
            cs = [c for (cv, csc, _), c in sorted(cells.items()) if cv == v and csc == sc]
            if not cs:
                continue
            t2 = [c["town2"] for c in cs if c["town2"] is not None]
            print(f"| {sc} | {v} | {len(cs)} | {interval([c['r']['test']['map'] for c in cs])} | "
                  f"{interval(t2) if t2 else '–'} | "
                  + " | ".join(interval([light_map(c, l) for c in cs]) for l in LIGHTS) + " | "
                  + f_numbers(cs) + " |")

def f_numbers(cs):
    """Each light's f-number over the cells, mean ± interval (one value where all agree)."""
    ns = {l: [f_number(c["r"], l) for c in cs] for l in ["day", "night", "tunnel"]}
    if len({n for v in ns.values() for n in v}) == 1:
        return f"f/{ns['day'][0]:.1f}"
    if ns["day"] == ns["night"] == ns["tunnel"]:  # the design's, no iris: one value per cell
        return f"{interval(ns['day'])} (" + ", ".join(f"f/{n:.1f}" for n in ns["day"]) + ")"
    return "; ".join(f"{l} {interval(v)}" for l, v in ns.items())

def settings(r, light):
    e, g = r["settings_by_illumination"][light]
    return f"{e:.1f}, {g:.1f}, f/{f_number(r, light):.1f}"

def designs(cells):
    header("scenario", "variant", "seed", "design", "mAP", "day E (ms), G (dB), N",
           "night E, G, N", "tunnel E, G, N", "night mAP", "tunnel mAP")
    for (v, sc, s), c in sorted(cells.items(),
                                key=lambda kv: (rank(kv[0][1]), rank(kv[0][0]), kv[0][2])):
        r, d = c["r"], c["r"]["design"]
        print(f"| {sc} | {v} | {s} | {d['sensor']} {d['pixel_pitch_um']:g} µm, "
              f"{d['focal_length_mm']:.2f} mm | {r['test']['map']:.4f} | "
              + " | ".join(settings(r, l) for l in ["day", "night", "tunnel"])
              + f" | {light_map(c, 'night'):.4f} | {light_map(c, 'tunnel'):.4f} |")

def common_seeds(cells, a, b, sc):
    """The seeds at which variants A and B both finished in scenario SC."""
    return sorted(s for (v, c, s) in cells if v == a and c == sc and (b, sc, s) in cells)

def paired(cells, pairs):
    """Rows A − B for each (A, B) in PAIRS, per scenario, over the seeds both have."""
    header("scenario", "A − B", "seeds", "Δ mAP, test town", "ahead", "Δ mAP, town 2",
           *[f"Δ mAP {l}" for l in LIGHTS],
           *[f"Δ {l} {q}" for l in ["day", "night", "tunnel"] for q in ["E (ms)", "G (dB)"]],
           "Δ pitch (µm)", "Δ focal (mm)", "Δ night frame (DN)")
    for sc in keys(cells, 1):
        for a, b in pairs:
            seeds = common_seeds(cells, a, b, sc)
            if not seeds:
                continue
            ps = [(cells[(a, sc, s)], cells[(b, sc, s)]) for s in seeds]
            diff = lambda f: signed([f(x) - f(y) for x, y in ps])
            d1 = [x["r"]["test"]["map"] - y["r"]["test"]["map"] for x, y in ps]
            d2 = [x["town2"] - y["town2"] for x, y in ps
                  if x["town2"] is not None and y["town2"] is not None]
            print(f"| {sc} | {a} − {b} | {len(seeds)} | {signed(d1)} | "
                  f"{sum(x > 0 for x in d1)} of {len(d1)} | {signed(d2) if d2 else '–'} | "
                  + " | ".join(diff(lambda c, l=l: light_map(c, l)) for l in LIGHTS) + " | "
                  + " | ".join(diff(lambda c, l=l, i=i: c["r"]["settings_by_illumination"][l][i])
                               for l in ["day", "night", "tunnel"] for i in [0, 1]) + " | "
                  + " | ".join(diff(lambda c, k=k: c["r"]["design"][k])
                               for k in ["pixel_pitch_um", "focal_length_mm"]) + " | "
                  + diff(lambda c: c["r"]["mean_dn_by_illumination"]["night"]) + " |")

def by_seed(cells, pairs):
    """Each seed's A − B on its own, beside the f-numbers both ran at: whether a difference came
    with an opened lens."""
    header("scenario", "A − B", "seed", "A's f-number (day, night)", "B's", "Δ mAP, test town",
           "Δ mAP, town 2", "Δ mAP night", "Δ mAP tunnel", "Δ day E (ms)", "Δ night E (ms)",
           "Δ night G (dB)")
    for sc in keys(cells, 1):
        for a, b in pairs:
            for s in common_seeds(cells, a, b, sc):
                x, y = cells[(a, sc, s)], cells[(b, sc, s)]
                n = lambda c: ", ".join(f"f/{f_number(c['r'], l):.1f}" for l in ["day", "night"])
                e = lambda l, i: (x["r"]["settings_by_illumination"][l][i]
                                  - y["r"]["settings_by_illumination"][l][i])
                t2 = (f"{x['town2'] - y['town2']:+.3f}"
                      if x["town2"] is not None and y["town2"] is not None else "–")
                print(f"| {sc} | {a} − {b} | {s} | {n(x)} | {n(y)} | "
                      f"{x['r']['test']['map'] - y['r']['test']['map']:+.3f} | {t2} | "
                      f"{light_map(x, 'night') - light_map(y, 'night'):+.3f} | "
                      f"{light_map(x, 'tunnel') - light_map(y, 'tunnel'):+.3f} | "
                      f"{e('day', 0):+.1f} | {e('night', 0):+.1f} | {e('night', 1):+.1f} |")

PAIRS = {
    "aperture": [("aperture", "f16"), ("iris", "f16"), ("iris", "aperture")],
    "fog": [("joca-fog300", "joca-clear"), ("tacos-fog300", "tacos-clear"),
            ("joca-clear", "tacos-clear"), ("joca-fog300", "tacos-fog300")],
}

if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in PAIRS:
        sys.exit(__doc__)
    cells = load(sys.argv[2])
    print(f"Cells: {sys.argv[2]} ({len(cells)} finished)")
    parts = [summary, designs, lambda c: paired(c, PAIRS[sys.argv[1]])]
    if sys.argv[1] == "aperture":
        parts.append(lambda c: by_seed(c, PAIRS["aperture"]))
    for part in parts:
        print()
        part(cells)
