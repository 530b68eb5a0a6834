#!/usr/bin/env python3
"""Turns a `polyfit fit` report.csv into a Markdown table (standard library only).

    python3 docs/scripts/report_to_markdown.py OUT/report.csv > table.md
"""
import csv
import statistics
import sys


def number(row, key, scale=1.0, digits=4):
    value = row.get(key, "")
    return f"{float(value) * scale:.{digits}f}" if value not in ("", None) else ""


def main(path):
    rows = list(csv.DictReader(open(path, newline="")))
    print("| mesh | faces | fitted faces | patches | time s | Chamfer x1e3 | floor x1e3 | to surface x1e3 | height RMSE | normal ° |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in sorted(rows, key=lambda r: r["name"]):
        if r["status"] == "failed":
            print(f"| {r['name']} | failed: {r['error'].split(': ', 1)[-1][:80]} | | | | | | | | |")
            continue
        print(f"| {r['name']} | {r['input_faces']} | {r['fitted_faces']} | {r['patches']} | {number(r, 'time_s', digits=3)} "
              f"| {number(r, 'chamfer_x1e3')} | {number(r, 'chamfer_floor_x1e3')} | {number(r, 'surface_chamfer_x1e3', digits=5)} "
              f"| {number(r, 'height_rmse', digits=5)} | {number(r, 'normal_error_deg', digits=2)} |")
    fitted = [r for r in rows if r["status"] != "failed"]
    if fitted:
        def stat(key):
            values = [float(r[key]) for r in fitted if r[key] != ""]
            return statistics.median(values), statistics.mean(values)
        print()
        print(f"{len(fitted)} fitted, {len(rows) - len(fitted)} failed. Median / mean: "
              + "; ".join(f"{label} {m:.4g} / {a:.4g}" for label, (m, a) in [
                  ("time s", stat("time_s")), ("Chamfer x1e3", stat("chamfer_x1e3")),
                  ("floor x1e3", stat("chamfer_floor_x1e3")), ("to surface x1e3", stat("surface_chamfer_x1e3")),
                  ("normal °", stat("normal_error_deg"))]))


if __name__ == "__main__":
    main(sys.argv[1])
