#!/usr/bin/env python3
"""OpenCV's DIS optical flow on the pair `joca bench flow` measures: the peer it is timed against.

Usage: bench_flow_opencv.py FIRST.png SECOND.png OUT_DIR --threads 1 2 --repeats 5

Both frames are read as 8-bit grayscale (joca writes them with R = G = B, so OpenCV's grayscale
conversion returns the very values joca computes on). For each preset and thread count the flow
is computed once to warm up, then timed `repeats` times; the best time is reported and the flow
is written to OUT_DIR/<preset>-<threads>.flo (Middlebury), which joca reads back and scores with
the same code as its own flow. Prints one JSON object on stdout. Needs numpy and
opencv-python-headless; an optional cross-check, never part of joca's main path.
"""
import argparse
import json
import os
import time

import cv2

PRESETS = {
    "ultrafast": cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST,
    "fast": cv2.DISOPTICAL_FLOW_PRESET_FAST,
    "medium": cv2.DISOPTICAL_FLOW_PRESET_MEDIUM,
}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("first")
    ap.add_argument("second")
    ap.add_argument("out_dir")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    i0 = cv2.imread(a.first, cv2.IMREAD_GRAYSCALE)
    i1 = cv2.imread(a.second, cv2.IMREAD_GRAYSCALE)
    if i0 is None or i1 is None:
        raise SystemExit(f"cannot read {a.first} or {a.second}")
    rows = []
    for name, preset in PRESETS.items():
        for threads in a.threads:
            cv2.setNumThreads(threads)
            dis = cv2.DISOpticalFlow_create(preset)
            flow = dis.calc(i0, i1, None)  # warm
            best = float("inf")
            for _ in range(a.repeats):
                t = time.perf_counter()
                flow = dis.calc(i0, i1, None)
                best = min(best, time.perf_counter() - t)
            path = os.path.join(a.out_dir, f"{name}-{threads}.flo")
            cv2.writeOpticalFlow(path, flow)
            rows.append({"preset": name, "threads": threads, "ms": 1e3 * best, "flo": path})
    print(json.dumps({"version": cv2.__version__, "rows": rows}))


if __name__ == "__main__":
    main()
