#!/usr/bin/env python3
"""The joca detector in PyTorch, layer for layer, timed the way `joca bench detector` times it.

Optional reference for the Rust benchmark (needs `pip install torch==2.13.0`). It prints one JSON
object: {"HxW": {"infer_ms": ..., "train_ms": ...}, ...}. `joca bench detector` runs it when
`python3 -c "import torch"` works and reports the ratio joca / PyTorch measured in the same run.

Usage: python3 scripts/bench_detector_pytorch.py --width 16 [--deep] [--shared-head] --threads 2 --repeats 10
"""
import argparse
import json
import time

import torch
import torch.nn as nn
import torch.nn.functional as F


def gn(c):
    return nn.GroupNorm(max(c // 8, 1), c)


class Block(nn.Module):
    def __init__(self, i, o, stride):
        super().__init__()
        self.conv1, self.norm1 = nn.Conv2d(i, o, 3, stride, 1, bias=False), gn(o)
        self.conv2, self.norm2 = nn.Conv2d(o, o, 3, 1, 1, bias=False), gn(o)
        self.down = None
        if stride != 1 or i != o:
            self.down = nn.Sequential(nn.Conv2d(i, o, 1, stride, 0, bias=False), gn(o))

    def forward(self, x):
        y = self.norm2(self.conv2(F.relu(self.norm1(self.conv1(x)))))
        return F.relu(y + (self.down(x) if self.down is not None else x))


class Head(nn.Module):
    def __init__(self, c, out, bias):
        super().__init__()
        self.hidden, self.out = nn.Conv2d(c, c, 3, 1, 1), nn.Conv2d(c, out, 1)
        nn.init.constant_(self.out.bias, bias)

    def forward(self, x):
        return self.out(F.relu(self.hidden(x)))


class SharedHeads(nn.Module):
    """One 3x3 hidden layer for the three outputs (joca's `shared_head`)."""

    def __init__(self, c, classes):
        super().__init__()
        self.hidden = nn.Conv2d(c, c, 3, 1, 1)
        self.heat, self.size, self.offset = nn.Conv2d(c, classes, 1), nn.Conv2d(c, 2, 1), nn.Conv2d(c, 2, 1)
        nn.init.constant_(self.heat.bias, -2.19)

    def forward(self, x):
        h = F.relu(self.hidden(x))
        return self.heat(h), self.size(h), self.offset(h)


class SeparateHeads(nn.Module):
    def __init__(self, c, classes):
        super().__init__()
        self.heat, self.size, self.offset = Head(c, classes, -2.19), Head(c, 2, 0.0), Head(c, 2, 0.0)

    def forward(self, x):
        return self.heat(x), self.size(x), self.offset(x)


class Detector(nn.Module):
    def __init__(self, c, classes=3, deep=False, shared_head=False):
        super().__init__()
        self.stem, self.stem_norm = nn.Conv2d(3, c, 3, 2, 1, bias=False), gn(c)
        self.l1_down, self.l1_norm = nn.Conv2d(c, 2 * c, 3, 2, 1, bias=False), gn(2 * c)
        self.layer1 = Block(2 * c, 2 * c, 1)
        self.layer2 = nn.Sequential(Block(2 * c, 4 * c, 2), Block(4 * c, 4 * c, 1))
        self.layer3 = nn.Sequential(Block(4 * c, 8 * c, 2), Block(8 * c, 8 * c, 1))
        self.layer4 = None
        if deep:
            self.layer4 = nn.Sequential(Block(8 * c, 16 * c, 2), Block(16 * c, 16 * c, 1))
            self.lat4 = nn.Conv2d(16 * c, 4 * c, 1, bias=False)
            self.smooth3 = nn.Conv2d(4 * c, 4 * c, 3, 1, 1, bias=False)
        self.lat3 = nn.Conv2d(8 * c, 4 * c, 1, bias=False)
        self.lat2 = nn.Conv2d(4 * c, 4 * c, 1, bias=False)
        self.lat1 = nn.Conv2d(2 * c, 4 * c, 1, bias=False)
        self.smooth2 = nn.Conv2d(4 * c, 4 * c, 3, 1, 1, bias=False)
        self.smooth1 = nn.Conv2d(4 * c, 4 * c, 3, 1, 1, bias=False)
        self.heads = (SharedHeads if shared_head else SeparateHeads)(4 * c, classes)

    def forward(self, x):
        x = F.relu(self.stem_norm(self.stem(x)))
        c2 = self.layer1(F.relu(self.l1_norm(self.l1_down(x))))
        c3 = self.layer2(c2)
        c4 = self.layer3(c3)
        if self.layer4 is not None:
            c5 = self.layer4(c4)
            up = F.interpolate(self.lat4(c5), size=c4.shape[2:], mode="nearest")
            p4 = F.relu(self.smooth3(up + self.lat3(c4)))
        else:
            p4 = self.lat3(c4)
        p3 = F.relu(self.smooth2(F.interpolate(p4, size=c3.shape[2:], mode="nearest") + self.lat2(c3)))
        p2 = F.relu(self.smooth1(F.interpolate(p3, size=c2.shape[2:], mode="nearest") + self.lat1(c2)))
        return self.heads(p2)


def loss_fn(heat, size, offset, target, idx, size_t, off_t):
    p = heat.sigmoid()
    pos = (target == 1).float()
    pos_loss = (F.logsigmoid(heat) * (1 - p) ** 2 * pos).sum()
    neg_loss = (F.logsigmoid(-heat) * p ** 2 * (1 - target) ** 4 * (1 - pos)).sum()
    hm = -(pos_loss + neg_loss) / max(float(idx.numel()), 1.0)
    at = lambda m: m.view(2, -1).index_select(1, idx)
    return hm + (at(size) - size_t).abs().mean() + (at(offset) - off_t).abs().mean()


def best(repeats, f):
    f()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        times.append((time.perf_counter() - t) * 1e3)
    return min(times)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--width", type=int, default=16)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--deep", action="store_true")
    ap.add_argument("--shared-head", action="store_true")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    out = {}
    for h, w in [(240, 320), (480, 640)]:
        net = Detector(args.width, deep=args.deep, shared_head=args.shared_head)
        opt = torch.optim.AdamW(net.parameters(), lr=1e-4, weight_decay=1e-6)
        x = torch.rand(1, 3, h, w) - 0.5
        with torch.no_grad():
            heat, _, _ = net(x)
        hh, ww = heat.shape[2:]
        target = torch.zeros_like(heat)
        idx = torch.tensor([(k * 7 % hh) * ww + (k * 11 % ww) for k in range(6)])
        for k in range(6):
            target.view(3, -1)[k % 3, idx[k]] = 1.0
        size_t, off_t = torch.zeros(2, 6), torch.full((2, 6), 0.5)

        def infer():
            with torch.no_grad():
                net(x)[0][0, 0, 0, 0].item()

        def train():
            h_, s_, o_ = net(x)
            loss = loss_fn(h_, s_, o_, target, idx, size_t, off_t)
            opt.zero_grad()
            loss.backward()
            opt.step()

        out[f"{h}x{w}"] = {"infer_ms": best(args.repeats, infer), "train_ms": best(args.repeats, train)}
    print(json.dumps(out))


if __name__ == "__main__":
    main()
