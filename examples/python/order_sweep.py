#!/usr/bin/env python3
"""Error against jet order and time: PolyFit on one mesh at orders 1 to 8.

    PYTHONPATH=build/python python3 examples/python/order_sweep.py MESH [--patches K] [--out sweep.png]

Prints a table (order, surface Chamfer distance: no sampling floor; normal
error; fit time) and, where
matplotlib is installed (apt-get install python3-matplotlib), plots the
Chamfer distance against the order and against the time.
"""
import argparse
import statistics
import sys

import polyfit


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("mesh", help="a mesh file; 'torus' for a built-in bumpy torus")
    parser.add_argument("--patches", type=int, default=0, help="patch count (0: from the area)")
    parser.add_argument("--max-order", type=int, default=polyfit.MAX_JET_ORDER)
    parser.add_argument("--repeats", type=int, default=5, help="fits per order (times: their median)")
    parser.add_argument("--out", default="order_sweep.png", help="the plot (PNG)")
    args = parser.parse_args()

    try:
        mesh = polyfit.make_bumpy_torus(96, 48) if args.mesh == "torus" else polyfit.read_mesh(args.mesh)
    except polyfit.Error as e:
        sys.exit(f"order_sweep: {e}")
    rows = []
    print(f"{'order':>5s} {'surface chamfer x1e3':>21s} {'normal error deg':>17s} {'fit ms':>8s} {'total ms':>9s}")
    for order in range(1, args.max_order + 1):
        # Times: the median of --repeats fits (one thread; the error is the same every time).
        runs = [polyfit.fit_mesh(mesh, jet_fit__order=order, clustering__num_patches=args.patches, num_threads=1,
                                 evaluate=(r == 0))[2] for r in range(args.repeats)]
        s = runs[0]
        fit_ms = 1e3 * statistics.median(r.fit_time_s for r in runs)
        total_ms = 1e3 * statistics.median(r.total_time_s for r in runs)
        rows.append((order, 1e3 * s.surface_chamfer, s.normal_error_deg, fit_ms, total_ms))
        print(f"{order:5d} {rows[-1][1]:21.5f} {rows[-1][2]:17.3f} {rows[-1][3]:8.2f} {rows[-1][4]:9.1f}")

    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed (apt-get install python3-matplotlib): no plot")
        return 0
    orders, chamfer, _, fit_ms, _ = zip(*rows)
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.6))
    a.semilogy(orders, chamfer, "o-")
    a.set_xlabel("jet order n")
    a.set_ylabel("surface Chamfer x1e3")
    a.grid(True, which="both", alpha=0.3)
    b.loglog(fit_ms, chamfer, "o-")
    for n, x, y in zip(orders, fit_ms, chamfer):
        b.annotate(str(n), (x, y), textcoords="offset points", xytext=(4, 4))
    b.set_xlabel("jet fitting time (ms)")
    b.set_ylabel("surface Chamfer x1e3")
    b.grid(True, which="both", alpha=0.3)
    fig.suptitle(f"{args.mesh}: {s.clustering.num_patches} patches, {s.input_vertices} vertices")
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
