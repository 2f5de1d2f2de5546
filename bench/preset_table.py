#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The statistics table of docs/presets.md from examples/presets/<preset>-<res>.json
(nebstats --json), printed as Markdown: each figure beside the observed range, met or not."""
import json
import pathlib
import sys

PRESETS = ["reflection", "external", "pillars", "bubble", "hii", "globule", "bipolar"]
OBSERVED = {"sigma": (0.3, 0.6), "slope": (-3.2, -2.5), "dimension": (1.25, 1.45)}


def mark(value, key, applies=True):
    lo, hi = OBSERVED[key]
    if not applies:
        return f"{value:.2f}"
    return f"{value:.2f} {'✓' if lo <= value <= hi else '✗'}"


def main(folder):
    folder = pathlib.Path(folder)
    print("| preset | res | σ(ln N) | high side p(ln N) ~ N^s | tail (x lognormal) "
          "| spectrum slope (k range) | D (contours) |")
    print("|---|---|---|---|---|---|---|")
    for preset in PRESETS:
        for res in (128, 256):
            path = folder / f"{preset}-{res}.json"
            if not path.exists():
                continue
            j = json.loads(path.read_text())
            pdf, sp, c = j["pdf"], j["spectrum"], j["contours"]
            quiescent = preset in ("reflection", "external")
            tail = (f"{'yes' if pdf['tail'] else 'no'} ({pdf['tail_excess']:.1f})"
                    if not quiescent else "-")
            print(f"| {preset} | {res}³ | {mark(pdf['sigma_ln'], 'sigma', quiescent)} "
                  f"| {pdf['tail_slope']:.1f} | {tail} "
                  f"| {mark(sp['slope'], 'slope')} ± {sp['slope_error']:.2f} "
                  f"({sp['k_min']:.1f}-{sp['k_max']:.0f}) "
                  f"| {mark(c['dimension'], 'dimension')} ± {c['error']:.2f} ({c['count']}) |")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "examples/presets")
