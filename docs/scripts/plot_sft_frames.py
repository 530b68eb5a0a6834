#!/usr/bin/python3
"""Plots RMSE per frame of polysft runs (their metrics.json), one panel per
scene and one line per run, with Debian's python3-matplotlib.

    /usr/bin/python3 docs/scripts/plot_sft_frames.py OUT.png \
        "crease:one patch=A/metrics.json" "crease:atlas=B/metrics.json" ...

Each argument is PANEL:LABEL=PATH; panels appear in the order first named.
"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(png_path, runs):
    panels = {}
    for run in runs:
        key, path = run.split("=", 1)
        panel, label = key.split(":", 1)
        frames = json.load(open(path))["frames"]
        panels.setdefault(panel, []).append((label, [f["frame"] for f in frames], [f["rmse_mm"] for f in frames]))
    fig, axes = plt.subplots(1, len(panels), figsize=(4 * len(panels), 3.2), squeeze=False)
    for ax, (panel, lines) in zip(axes[0], panels.items()):
        for label, x, y in lines:
            ax.plot(x, y, label=label)
        ax.set_title(panel)
        ax.set_xlabel("frame")
        ax.set_ylabel("RMSE (mm)")
        ax.grid(alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(png_path, dpi=100)


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2:])
