#!/usr/bin/python3
"""Plots the progress of `onefit train` runs (MODEL.csv): each batch's loss after its
solve (a running mean over 25 batches), and the validation drape's epsilon_c and
epsilon_e, against wall time. Needs Debian's python3-matplotlib.

    /usr/bin/python3 docs/scripts/plot_training.py OUT.png "LABEL=run_a.pfonefit.csv" ...

A spec ending in ":loss" draws that run's loss only (a run whose validation
read other frames than the others' cannot be compared on it).
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

WINDOW = 25


def read_run(path):
    rows = list(csv.DictReader(open(path, newline="")))
    if not rows or "final_loss_J" not in rows[0]:
        raise SystemExit(f"{path}: not an onefit train progress file (no final_loss_J column)")
    time = [float(r["time_s"]) / 60.0 for r in rows]
    loss = [float(r["final_loss_J"]) for r in rows]
    mean = []
    for i in range(len(loss)):
        window = loss[max(0, i - WINDOW + 1) : i + 1]
        mean.append(sum(window) / len(window))
    validated = [r for r in rows if r["validation_inside_percent"]]
    return {
        "time": time,
        "loss": mean,
        "val_time": [float(r["time_s"]) / 60.0 for r in validated],
        "inside": [float(r["validation_inside_percent"]) for r in validated],
        "strain": [float(r["validation_edge_strain_percent"]) for r in validated],
    }


def main(png_path, specs):
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    for spec in specs:
        label, _, path = spec.partition("=")
        if not path:
            label, path = spec, spec
        loss_only = path.endswith(":loss")
        if loss_only:
            path = path[: -len(":loss")]
        run = read_run(path)
        line = axes[0].plot(run["time"], run["loss"], lw=1, label=label)[0]
        if loss_only:
            continue
        axes[1].plot(run["val_time"], run["inside"], lw=1, color=line.get_color(), marker=".", ms=3)
        axes[2].plot(run["val_time"], run["strain"], lw=1, color=line.get_color(), marker=".", ms=3)
    axes[0].set_ylabel(f"batch loss after its solve (J, mean of {WINDOW})")
    axes[0].set_yscale("log")
    axes[1].set_ylabel("validation epsilon_c (%)")
    axes[2].set_ylabel("validation epsilon_e (%)")
    for ax in axes:
        ax.set_xlabel("wall time (min)")
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    print(f"wrote {png_path}")


if __name__ == "__main__":
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    main(sys.argv[1], sys.argv[2:])
