#!/usr/bin/env python3
"""OpenCV's DIS optical flow on a rectified stereo pair with ground-truth disparity: the
reference `joca flow` is compared with (end-point error, share of pixels off by > 3 px, time).

Usage: flow_reference.py LEFT.png RIGHT.png DISP.npy [--threads N] [--joca-flo PRESET=FILE ...]

The true flow of the left image is (-d, 0); pixels with non-finite or non-positive disparity are
unknown and left out, as `joca flow --gt-disparity` does. With --joca-flo, joca's .flo files are
read back with OpenCV's readOpticalFlow (a check of the file format) and scored the same way.
Needs numpy and opencv-python-headless.
"""
import argparse
import time

import cv2
import numpy as np

PRESETS = {
    "ultrafast": cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST,
    "fast": cv2.DISOPTICAL_FLOW_PRESET_FAST,
    "medium": cv2.DISOPTICAL_FLOW_PRESET_MEDIUM,
}


def score(flow, disp):
    known = np.isfinite(disp) & (disp > 0)
    truth = np.stack([-disp, np.zeros_like(disp)], axis=-1)
    err = np.hypot(*(flow - truth)[known].T)
    return err.mean(), (err > 3).mean(), int(known.sum())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("left")
    ap.add_argument("right")
    ap.add_argument("disp")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--joca-flo", nargs="*", default=[])
    a = ap.parse_args()
    cv2.setNumThreads(a.threads)
    left = cv2.cvtColor(cv2.imread(a.left), cv2.COLOR_BGR2GRAY)
    right = cv2.cvtColor(cv2.imread(a.right), cv2.COLOR_BGR2GRAY)
    disp = np.load(a.disp).astype(np.float32)
    print(f"OpenCV {cv2.__version__}, {a.threads} threads, {left.shape[1]}x{left.shape[0]}")
    print("| flow | preset | EPE (px) | > 3 px | mean length (px) | best of %d (ms) |" % a.repeats)
    print("|---|---|---|---|---|---|")
    for name, preset in PRESETS.items():
        dis = cv2.DISOpticalFlow_create(preset)
        flow = dis.calc(left, right, None)  # warm
        times = []
        for _ in range(a.repeats):
            t = time.perf_counter()
            flow = dis.calc(left, right, None)
            times.append(time.perf_counter() - t)
        epe, out, known = score(flow, disp)
        length = np.hypot(flow[..., 0], flow[..., 1]).mean()
        print(f"| OpenCV | {name} | {epe:.3f} | {100 * out:.2f} % | {length:.2f} | {1e3 * min(times):.1f} |")
    for item in a.joca_flo:
        name, path = item.split("=", 1)
        flow = cv2.readOpticalFlow(path)
        if flow is None:
            raise SystemExit(f"OpenCV cannot read {path}")
        epe, out, known = score(flow, disp)
        length = np.hypot(flow[..., 0], flow[..., 1]).mean()
        print(f"| joca (.flo read by OpenCV) | {name} | {epe:.3f} | {100 * out:.2f} % | {length:.2f} | - |")
    d = disp[np.isfinite(disp) & (disp > 0)]
    print(f"ground truth: {d.size} known pixels, mean disparity {d.mean():.2f} px")


if __name__ == "__main__":
    main()
