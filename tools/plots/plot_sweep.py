#!/usr/bin/env python3
"""Polar plot of push envelopes (push_sweep's sweep.json): the largest recovered impulse per push
direction, one curve per support and strategy of each table; a table given as PATH=LABEL has its
curves labelled (e.g. "with stepping") and drawn dotted after the first.

    plot_sweep.py sweep.json [other.json=LABEL ...] out.png
"""
import json
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main() -> int:
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    tables = []
    for arg in sys.argv[1:-1]:
        path, _, label = arg.partition("=")
        with open(path) as f:
            tables.append((json.load(f), label))
    fig = plt.figure(figsize=(6.5, 6.5))
    ax = fig.add_subplot(projection="polar")
    styles = {"cam": ("tab:blue", "-", "o"), "ankle": ("tab:red", "--", "s")}
    extra_colors = iter(["tab:green", "tab:purple", "tab:orange", "tab:brown"])
    for k, (table, label) in enumerate(tables):
        curves = {}
        for r in table["results"]:
            if r.get("failed"):  # a case whose cluster task failed: no figure to draw
                continue
            curves.setdefault((r["support"], r["strategy"]), []).append((r["direction_deg"], r["max_recovered_Ns"]))
        for (support, strategy), pts in sorted(curves.items()):
            pts.sort()
            th = [math.radians(d) for d, _ in pts] + [math.radians(pts[0][0])]
            rr = [v for _, v in pts] + [pts[0][1]]
            color, ls, marker = styles.get(strategy, ("k", "-", "x"))
            if k > 0:
                color, ls = next(extra_colors, "k"), ":"
            name = f"{strategy} ({support} support)" + (f", {label}" if label else "")
            ax.plot(th, rr, ls, color=color, marker=marker, label=name)
            for t, v in zip(th[:-1], rr[:-1]):
                ax.annotate(f"{v:.1f}", (t, v), textcoords="offset points", xytext=(4, 4), fontsize=7, color=color)
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(1)
    ax.set_title(f"Largest recovered impulse [N s] per push direction\n(0° = pushed forward from behind, "
                 f"{tables[0][0]['peak_force_N']:.0f} N peak half-sine)", fontsize=10)
    ax.legend(loc="lower left", bbox_to_anchor=(-0.1, -0.12), fontsize=8)
    fig.tight_layout()
    fig.savefig(sys.argv[-1], dpi=120)
    return 0


if __name__ == "__main__":
    sys.exit(main())
