#!/usr/bin/env python3
"""Fit every mesh in a folder with PolyFit: a progress bar, then a table.

    PYTHONPATH=build/python python3 examples/python/batch_fit.py MESHES --out DIR [--order 4] [--patches 0]

Resumable (a rerun skips meshes already fitted; --force refits). Writes per
mesh <name>.pfm, <name>.recon.ply, <name>.summary.json and per run
report.csv / report.json into DIR, as `polyfit fit` does.
"""
import argparse
import sys
import time

import polyfit


def progress_bar(done, total, item, start=time.monotonic()):
    width = 30
    filled = width * done // total
    status = item.status.name.lower()
    sys.stderr.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} "
                     f"{time.monotonic() - start:6.1f} s  {status:7s} {item.name[:30]:30s}")
    if done == total:
        sys.stderr.write("\n")
    sys.stderr.flush()


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("inputs", nargs="+", help="mesh files, folders or glob patterns")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--order", type=int, help="jet order (default: the library's)")
    parser.add_argument("--patches", type=int, help="patch count, 0: from the area (default: the library's)")
    parser.add_argument("--threads", type=int, default=0, help="threads (0: all)")
    parser.add_argument("--force", action="store_true", help="refit meshes already fitted")
    args = parser.parse_args()

    settings = {"num_threads": args.threads, "force": args.force}
    if args.order is not None:
        settings["fit__jet_fit__order"] = args.order
    if args.patches is not None:
        settings["fit__clustering__num_patches"] = args.patches
    try:
        summary = polyfit.fit_mesh_files(args.inputs, args.out, progress=progress_bar, **settings)
    except (polyfit.Error, ValueError) as e:
        sys.exit(f"batch_fit: {e}")

    print(f"{'mesh':24s} {'status':8s} {'vertices':>9s} {'patches':>8s} {'chamfer x1e3':>13s} {'time s':>8s}")
    for item in summary.items:
        s = item.summary
        if item.status == polyfit.BatchItemStatus.FAILED:
            print(f"{item.name[:24]:24s} {'failed':8s} {item.error}")
            continue
        print(f"{item.name[:24]:24s} {item.status.name.lower():8s} {s.input_vertices:9d} "
              f"{s.clustering.num_patches:8d} {1e3 * s.chamfer:13.4f} {s.total_time_s:8.3f}")
    print(f"{summary.num_fitted} fitted, {summary.num_skipped} skipped, {summary.num_failed} failed "
          f"in {summary.total_time_s:.1f} s; report: {args.out}/report.csv")
    return 1 if summary.num_failed else 0


if __name__ == "__main__":
    sys.exit(main())
