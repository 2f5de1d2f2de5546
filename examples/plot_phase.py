#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Plot nebphase's effective phase function Phi(t, theta) as an SVG (standard library only).

    nebphase -o phase.vdb --json phase.json
    python3 examples/plot_phase.py phase.json phase.svg [--t 0.01,1,3,10,30]

One line per requested t (the nearest table row in log t), against the scattering angle
theta = acos(mu) in degrees, on a log axis, with the thin limit albedo * p(theta) dashed
(DESIGN §3-4).
"""
import argparse
import json
import math
from xml.sax.saxutils import escape

W, H = 760, 500                       # image size [px]
L, R, T, B = 80, 190, 50, 60          # margins: left, right (legend), top, bottom
COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#17becf"]


def phase_function(model, g, mu):
    """p(mu) [1/sr], normalised over the sphere, as in libnebula's dust.h (DESIGN §3)."""
    if model == "hg":
        return (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * mu) ** 1.5)
    if model == "rayleigh":
        return 3 / (16 * math.pi) * (1 + mu * mu)
    n = {"hazy": 8, "murky": 32}[model]  # half isotropic, half ((1 + mu) / 2)^n
    return (0.5 + 0.5 * (n + 1) * ((1 + mu) / 2) ** n) / (4 * math.pi)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("table", help="JSON table written by nebphase --json")
    ap.add_argument("svg", help="output SVG file")
    ap.add_argument("--t", default="0.01,1,3,10,30",
                    help="comma-separated voxel optical thicknesses t (default %(default)s)")
    args = ap.parse_args()
    with open(args.table) as f:
        table = json.load(f)
    rows, mus = table["rows"], table["mu"]
    albedo, g, model = table["albedo"], table["g"], table["phase"]

    # The nearest row (in log t) to each requested t, each row once.
    picked = []
    for t in (float(x) for x in args.t.split(",")):
        row = min(rows, key=lambda r: abs(math.log(r["t"] / t)))
        if row not in picked:
            picked.append(row)
    theta = [math.degrees(math.acos(mu)) for mu in mus]
    thin = [(th, albedo * phase_function(model, g, math.cos(math.radians(th))))
            for th in (0.5 * i for i in range(361))]
    # The thin limit first, so that the table's curves are drawn over it.
    curves = [("thin limit a p(\u03b8)", thin, "#555555", "6,4")]
    curves += [(f"t = {r['t']:.3g}", list(zip(theta, r["phi"])), COLORS[k % len(COLORS)], "")
               for k, r in enumerate(picked)]

    # Log y axis over whole decades that hold every positive value.
    values = [v for _, pts, _, _ in curves for _, v in pts if v > 0]
    y0 = math.floor(math.log10(min(values)))
    y1 = math.ceil(math.log10(max(values)))
    y1 += y1 == y0

    def x_px(th):
        return L + (W - L - R) * th / 180.0

    def y_px(v):
        return H - B - (H - T - B) * (math.log10(v) - y0) / (y1 - y0)

    svg = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" '
           f'viewBox="0 0 {W} {H}" font-family="sans-serif" font-size="13">',
           f'<rect width="{W}" height="{H}" fill="white"/>']

    def text(x, y, s, anchor="middle", extra=""):
        svg.append(f'<text x="{x:.1f}" y="{y:.1f}" text-anchor="{anchor}"{extra}>'
                   f'{escape(s)}</text>')

    # Grid, ticks and tick labels.
    for th in range(0, 181, 30):
        svg.append(f'<line x1="{x_px(th):.1f}" y1="{T}" x2="{x_px(th):.1f}" y2="{H - B}" '
                   'stroke="#e0e0e0"/>')
        text(x_px(th), H - B + 18, f"{th}")
    for e in range(y0, y1 + 1):
        y = y_px(10.0 ** e)
        svg.append(f'<line x1="{L}" y1="{y:.1f}" x2="{W - R}" y2="{y:.1f}" stroke="#e0e0e0"/>')
        text(L - 8, y + 4, f"1e{e}", "end")
    svg.append(f'<rect x="{L}" y="{T}" width="{W - L - R}" height="{H - T - B}" '
               'fill="none" stroke="black"/>')
    text((L + W - R) / 2, H - 15, "scattering angle \u03b8 [degrees]")
    text(20, (T + H - B) / 2, "\u03a6(t, \u03b8) [1/sr per unit optical depth]", "middle",
         f' transform="rotate(-90 20 {(T + H - B) / 2:.1f})"')
    photons = [r["photons"] for r in rows]
    text(W / 2, 28, f"Effective phase function: albedo {albedo:g}, g {g:g} ({model}), "
                    f"{sum(photons)} photons ({min(photons)}-{max(photons)} per t)")

    # The curves (a gap where Phi <= 0, which a log axis cannot show) and the legend.
    for k, (label, pts, color, dash) in enumerate(curves):
        segments, current = [], []
        for th, v in pts:
            if v > 0:
                current.append(f"{x_px(th):.1f},{y_px(v):.1f}")
            elif current:
                segments, current = segments + [current], []
        dashes = f' stroke-dasharray="{dash}"' if dash else ""
        for seg in [s for s in segments + [current] if s]:
            svg.append(f'<polyline points="{" ".join(seg)}" fill="none" stroke="{color}" '
                       f'stroke-width="1.8"{dashes}/>')
        y = T + 20 + 22 * k
        svg.append(f'<line x1="{W - R + 15}" y1="{y}" x2="{W - R + 45}" y2="{y}" '
                   f'stroke="{color}" stroke-width="1.8"{dashes}/>')
        text(W - R + 52, y + 4, label, "start")
    svg.append("</svg>")
    with open(args.svg, "w") as f:
        f.write("\n".join(svg) + "\n")


if __name__ == "__main__":
    main()
