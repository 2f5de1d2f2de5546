#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Plots nebrender --sed CSV files (one or more renders, e.g. at several --wavelengths) as the
SED of each component: flux density at the observer [Jy] against wavelength [nm].

    plot_sed.py sed1.csv [sed2.csv ...] -o sed.png
"""
import argparse
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    rows = []
    try:
        with open(path, newline="") as f:
            lines = [line for line in f if not line.startswith("#")]
    except OSError as e:
        sys.exit(f"plot_sed.py: {path}: {e.strerror}")
    reader = csv.DictReader(lines)
    need = ["wavelength_nm", "total_Jy", "direct_Jy", "scattered_Jy", "single_Jy", "field_Jy"]
    if reader.fieldnames not in (need, need + ["emission_Jy"]):
        sys.exit(f"plot_sed.py: {path}: expected the columns {','.join(need)}[,emission_Jy] "
                 "(nebrender --sed)")
    for r in reader:
        try:
            rows.append({k: float(v) for k, v in r.items()})
        except ValueError:
            sys.exit(f"plot_sed.py: {path}: a value is not a number: {r}")
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("csv", nargs="+", help="nebrender --sed files")
    ap.add_argument("-o", "--output", required=True, help="the PNG")
    ap.add_argument("--title", default="SED at the observer")
    args = ap.parse_args()
    rows = sorted((r for p in args.csv for r in read(p)), key=lambda r: r["wavelength_nm"])
    if not rows:
        sys.exit("plot_sed.py: no rows")
    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=120)
    lam = [r["wavelength_nm"] for r in rows]
    for key, label, style in [("total_Jy", "total", "k-o"), ("direct_Jy", "direct (stars)", "C0--s"),
                              ("scattered_Jy", "scattered", "C3-^"), ("single_Jy", "single", "C1:."),
                              ("field_Jy", "multiple (field)", "C2:."),
                              ("emission_Jy", "gas emission", "C4-")]:
        values = [r.get(key, 0.0) for r in rows]
        if any(v > 0 for v in values):
            ax.plot(lam, [v if v > 0 else float("nan") for v in values], style, label=label, ms=4)
    ax.set_yscale("log")
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel("flux density [Jy]")
    ax.set_title(args.title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.output)


if __name__ == "__main__":
    main()
