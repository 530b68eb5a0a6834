#!/usr/bin/python3
"""Plots mesh_fit_benchmark's CSV (time against mesh size) with Debian's python3-matplotlib.

    build/bin/mesh_fit_benchmark --csv scaling.csv
    /usr/bin/python3 docs/scripts/plot_scaling.py scaling.csv docs/images/mesh_fit_scaling.png
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png_path):
    rows = list(csv.DictReader(open(csv_path, newline="")))
    faces = [int(r["faces"]) for r in rows]
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for key, label in [("total_s", "total"), ("cluster_s", "clustering"), ("fit_s", "jet fits"),
                       ("reconstruct_s", "reconstruction")]:
        ax.loglog(faces, [float(r[key]) for r in rows], "o-", label=label)
    ref = [float(rows[0]["total_s"]) * f / faces[0] for f in faces]
    ax.loglog(faces, ref, "k:", label="linear")
    ax.axhline(2.0, color="r", lw=0.8, ls="--", label="2 s target (100k)")
    ax.set_xlabel("triangles")
    ax.set_ylabel("seconds (best of 3, 2 threads)")
    ax.set_title(f"PolyFit: {rows[0]['patches']} patches, order 4")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
