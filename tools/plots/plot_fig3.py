#!/usr/bin/python3
"""Figure like the paper's Fig. 3: CAM reference generation for a push, for several alpha.

usage: plot_fig3.py data.csv out.png
The CSV has columns: alpha,t,tau_ankle,tau_thres,tau_limit,l_ref,ldot_ref,phase
"""
import csv
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt


def main(src, dst):
    runs = {}
    with open(src) as f:
        for row in csv.DictReader(f):
            runs.setdefault(row["alpha"], []).append({k: float(v) for k, v in row.items()})
    fig, ax = plt.subplots(3, 1, figsize=(7, 8), sharex=True)
    first = next(iter(runs.values()))
    t = [r["t"] for r in first]
    ax[0].plot(t, [r["tau_ankle"] for r in first], "k", label=r"$\tau_v^{ankle}$")
    ax[0].plot(t, [-r["tau_limit"] for r in first], "k:", label=r"$\tau_v^{min}$")
    for alpha, rows in runs.items():
        ta = [r["t"] for r in rows]
        line, = ax[0].plot(ta, [r["tau_thres"] if r["phase"] == 1 else float("nan") for r in rows], "--",
                           label=r"$\tau^{thres}$, $\alpha$=" + alpha)
        ax[1].plot(ta, [r["l_ref"] for r in rows], color=line.get_color(), label=r"$\alpha$=" + alpha)
        ax[2].plot(ta, [r["ldot_ref"] for r in rows], color=line.get_color(), label=r"$\alpha$=" + alpha)
        for k in range(1, len(rows)):
            if rows[k]["phase"] != rows[k - 1]["phase"] and rows[k]["phase"] in (1, 2, 3):
                for a in ax:
                    a.axvline(rows[k]["t"], color=line.get_color(), linestyle=":", linewidth=0.8)
    ax[0].set_ylabel("ankle torque y [N m]")
    ax[1].set_ylabel(r"$l_c^{ref}$ y [N m s]")
    ax[2].set_ylabel(r"$\dot l_c^{ref}$ y [N m]")
    ax[2].set_xlabel("time [s]")
    for a in ax:
        a.grid(True, alpha=0.3)
        a.legend(fontsize=7, loc="upper right")
    ax[0].set_title("CAM reference generation for a push from behind (cf. paper Fig. 3)")
    fig.tight_layout()
    fig.savefig(dst, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
