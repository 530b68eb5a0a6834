#!/usr/bin/python3
"""Plots a polysft trace.csv: e_3D of the window's newest frame (or the cost, without
ground truth) against time, with Debian's python3-matplotlib.

    /usr/bin/python3 docs/scripts/plot_trace.py OUT/trace.csv OUT/trace.png
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png_path):
    rows = list(csv.DictReader(open(csv_path, newline="")))
    time = [float(r["time_s"]) for r in rows]
    has_e3d = any(r["e3d"] for r in rows)
    values = [float(r["e3d"]) if has_e3d and r["e3d"] else float(r["cost"]) for r in rows]
    frames = [int(r["frame"]) for r in rows]
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.plot(time, values, lw=0.8)
    ax.scatter(time, values, c=frames, s=4, cmap="viridis")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("e_3D of the newest frame" if has_e3d else "cost")
    ax.set_yscale("log")
    ax.grid(True, alpha=0.3)
    ax.set_title("PolySfT: every solver iteration (colour: frame)")
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
