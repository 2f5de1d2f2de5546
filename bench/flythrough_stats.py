#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Per-frame statistics of a toned fly-through (nebtone's 8-bit PNGs), for the producer's
checks: each frame's mean display luminance (Rec. 709 weights of the sRGB-encoded values,
0-255), its black fraction (pixels whose largest channel is at most BLACK, default 8 of 255),
and the largest jump of the mean luminance from a frame to its neighbour, relative to the
smaller of the two.

    bench/flythrough_stats.py 'out/flythrough/f.*.png' [--black 8] [--per-frame]

Prints one summary line: frames, largest jump (and between which frames), largest black
fraction (and which frame), mean luminance range. Reads PNGs with the standard library only
(zlib): 8-bit RGB or RGBA, non-interlaced, as nebtone writes them."""
import glob
import struct
import sys
import zlib


def read_png(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG")
    pos, idat, width = 8, [], None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind = data[pos + 4:pos + 8]
        body = data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            width, height, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or ctype not in (2, 6) or interlace:
                raise ValueError(f"{path}: expected 8-bit RGB(A), non-interlaced")
            channels = 4 if ctype == 6 else 3
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
    raw = zlib.decompress(b"".join(idat))
    stride = width * channels
    rows, prev = [], bytearray(stride)
    for y in range(height):
        ftype = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
            if ftype == 1:
                line[i] = (line[i] + a) & 255
            elif ftype == 2:
                line[i] = (line[i] + b) & 255
            elif ftype == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif ftype == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        prev = line
    return width, height, channels, rows


def frame_stats(path, black):
    w, h, ch, rows = read_png(path)
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
