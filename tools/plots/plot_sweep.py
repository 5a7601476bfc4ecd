#!/usr/bin/env python3
"""Polar plot of push envelopes (push_sweep's sweep.json): the largest recovered impulse per push
direction, one curve per support and strategy of each table (one polar plot per peak force; a
table with double support draws only that); a table given as PATH=LABEL has its
curves labelled (e.g. "with stepping") and drawn dotted after the first.

    plot_sweep.py sweep.json [other.json=LABEL ...] out.png
"""
import json
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


NAMES = {"cam": "CAM strategy as configured (stepping if it is on)",
         "ankle": "ankle strategy as configured (stepping if it is on)",
         "cam-standing": "CAM strategy standing (stepping off)",
         "ankle-standing": "ankle strategy standing (stepping off)"}


def main() -> int:
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    tables = []
    for arg in sys.argv[1:-1]:
        path, _, label = arg.partition("=")
        with open(path) as f:
            tables.append((json.load(f), label))
    peaks = sorted({r.get("peak_force_N", t["peak_force_N"]) for t, _ in tables for r in t["results"]})
    fig = plt.figure(figsize=(6.5 * len(peaks), 7.5))
    styles = {"cam": ("tab:blue", "-", "o"), "ankle": ("tab:red", "--", "s"),
              "cam-standing": ("tab:green", "-.", "^"), "ankle-standing": ("tab:red", "--", "s")}
    for p, peak in enumerate(peaks):
        ax = fig.add_subplot(1, len(peaks), p + 1, projection="polar")
        extra_colors = iter(["tab:green", "tab:purple", "tab:orange", "tab:brown"])
        for k, (table, label) in enumerate(tables):
            curves = {}
            double = any(r["support"] == "double" for r in table["results"])
            for r in table["results"]:
                if r.get("failed") or r.get("peak_force_N", table["peak_force_N"]) != peak:
                    continue  # a case whose cluster task failed: no figure to draw
                if double and r["support"] != "double":
                    continue  # single support beside double (a dominance table): the table has it
                curves.setdefault((r["support"], r["strategy"]), []).append((r["direction_deg"], r["max_recovered_Ns"]))
            for (support, strategy), pts in sorted(curves.items()):
                pts.sort()
                th = [math.radians(d) for d, _ in pts] + [math.radians(pts[0][0])]
                rr = [v for _, v in pts] + [pts[0][1]]
                color, ls, marker = styles.get(strategy, ("k", "-", "x"))
                if k > 0:
                    color, ls = next(extra_colors, "k"), ":"
                name = f"{NAMES.get(strategy, strategy)} ({support} support)" + (f", {label}" if label else "")
                ax.plot(th, rr, ls, color=color, marker=marker, label=name)
                for t, v in zip(th[:len(pts)], rr[:len(pts)]):
                    ax.annotate(f"{v:.1f}", (t, v), textcoords="offset points", xytext=(4, 4), fontsize=7, color=color)
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(1)
        ax.set_title(f"Largest recovered impulse [N s] per push direction\n(0° = pushed forward from behind, "
                     f"{peak:.0f} N peak half-sine)", fontsize=10)
        ax.legend(loc="upper left", bbox_to_anchor=(-0.1, -0.06), fontsize=8)
    fig.tight_layout()
    fig.savefig(sys.argv[-1], dpi=120)
    return 0


if __name__ == "__main__":
    sys.exit(main())
