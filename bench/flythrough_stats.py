#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Per-frame statistics of a toned fly-through (nebtone's 8-bit PNGs), for the producer's
checks: each frame's mean display luminance (Rec. 709 weights of the sRGB-encoded values,
0-255), its black fraction (pixels whose largest channel is at most BLACK, default 8 of 255),
and the largest jump of the mean luminance from a frame to its neighbour, relative to the
smaller of the two.

    bench/flythrough_stats.py 'out/flythrough/f.*.png' [--black 8] [--per-frame]

Prints one summary line: frames, largest jump (and between which frames), largest black
fraction (and which frame), mean luminance range. Reads 8-bit RGBA PNGs, as nebtone writes
them, with bench/tile_png.py's reader (standard library only)."""
import glob
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tile_png import read_png  # noqa: E402 (the PNG reader the bench scripts share)


def frame_stats(path, black):
    w, h, rows = read_png(path)
    ch = 4
    total, dark = 0.0, 0
    for line in rows:
        for x in range(0, w * ch, ch):
            r, g, b = line[x], line[x + 1], line[x + 2]
            total += 0.2126 * r + 0.7152 * g + 0.0722 * b
            if max(r, g, b) <= black:
                dark += 1
    return total / (w * h), dark / (w * h)


def main():
    args = sys.argv[1:]
    black, per_frame, pattern = 8, False, None
    while args:
        a = args.pop(0)
        if a == "--black":
            black = int(args.pop(0))
        elif a == "--per-frame":
            per_frame = True
        else:
            pattern = a
    if not pattern:
        sys.exit(__doc__)
    files = sorted(glob.glob(pattern))
    if len(files) < 2:
        sys.exit(f"flythrough_stats: fewer than 2 frames match {pattern}")
    stats = [frame_stats(f, black) for f in files]
    if per_frame:
        for f, (m, d) in zip(files, stats):
            print(f"{f} mean {m:.2f} black {d:.3f}")
    jump, where = 0.0, 0
    for i in range(1, len(stats)):
        a, b = stats[i - 1][0], stats[i][0]
        j = abs(b - a) / max(min(a, b), 1e-9)
        if j > jump:
            jump, where = j, i
    worst = max(range(len(stats)), key=lambda i: stats[i][1])
    means = [m for m, _ in stats]
    print(f"frames {len(files)}  largest jump {100 * jump:.1f} % (frames {where}-{where + 1})  "
          f"largest black fraction {100 * stats[worst][1]:.1f} % (frame {worst + 1})  "
          f"mean luminance {min(means):.1f}-{max(means):.1f} of 255")


if __name__ == "__main__":
    main()
