#!/usr/bin/python3
"""Figure like the paper's Fig. 3: CAM reference generation for a push, for several alpha and beta.

usage: plot_fig3.py data.csv out.png [--title TITLE]

The CSV (written by build/bin/fig3_reference or the generator's unit test) has the columns
series,alpha,beta,t,tau_ankle,tau_min,tau_max,tau_thres,l_ref,ldot_ref,phase; rows of series
"alpha" vary alpha at one beta, rows of series "beta" vary beta at one alpha. Panels: (a) the ankle
torque with its limit and each alpha's threshold while in phase 1, (b) l_c^ref for each alpha,
(c) l_c^ref for each beta; dotted vertical lines mark where phases 1, 2 and 3 begin.
"""
import argparse
import csv

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt


def load(path):
    series = {"alpha": {}, "beta": {}}
    with open(path) as f:
        for row in csv.DictReader(f):
            key = (float(row["alpha"]), float(row["beta"]))
            series[row["series"]].setdefault(key, []).append(
                {k: float(v) for k, v in row.items() if k != "series"})
    return series


def phase_lines(ax, rows, color):
    for k in range(1, len(rows)):
        p = rows[k]["phase"]
        if p != rows[k - 1]["phase"] and p in (1, 2, 3):
            ax.axvline(rows[k]["t"], color=color, linestyle=":", linewidth=0.8)


def active_window(series):
    """From 0.3 s before the first phase 1 to 0.5 s after the last return to idle."""
    t0, t1 = None, None
    for runs in series.values():
        for rows in runs.values():
            active = [r["t"] for r in rows if r["phase"] != 0]
            if active:
                t0 = min(active[0], t0) if t0 is not None else active[0]
                t1 = max(active[-1], t1) if t1 is not None else active[-1]
    return (t0 - 0.3, t1 + 0.5) if t0 is not None else None


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("csv")
    p.add_argument("png")
    p.add_argument("--title", default="CAM reference generation for a push (cf. the paper's Fig. 3)")
    a = p.parse_args()
    series = load(a.csv)
    if not series["alpha"] and not series["beta"]:
        raise SystemExit("plot_fig3: no rows in " + a.csv)
    fig, ax = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    first = next(iter(series["alpha"].values() or series["beta"].values()))
    t = [r["t"] for r in first]
    tau = [r["tau_ankle"] for r in first]
    ax[0].plot(t, tau, "k", label=r"$\tau_v^{ankle}$")
    # The limit on the side the torque goes to.
    side = "tau_min" if min(tau) < -max(tau) else "tau_max"
    ax[0].plot(t, [r[side] for r in first], "r:", label=r"$\tau_v^{min}$" if side == "tau_min" else r"$\tau_v^{max}$")
    for (alpha, beta), rows in series["alpha"].items():
        tt = [r["t"] for r in rows]
        line, = ax[1].plot(tt, [r["l_ref"] for r in rows], label=r"$\alpha$ = %.2f ($\beta$ = %.2f)" % (alpha, beta))
        ax[0].plot(tt, [r["tau_thres"] if r["phase"] == 1 else float("nan") for r in rows], "--", color=line.get_color(),
                   label=r"$\tau^{thres} = \alpha\,\tau^{lim}$, $\alpha$ = %.2f" % alpha)
        phase_lines(ax[1], rows, line.get_color())
    for (alpha, beta), rows in series["beta"].items():
        tt = [r["t"] for r in rows]
        line, = ax[2].plot(tt, [r["l_ref"] for r in rows], label=r"$\beta$ = %.2f ($\alpha$ = %.2f)" % (beta, alpha))
        phase_lines(ax[2], rows, line.get_color())
    ax[0].set_ylabel("(a) ankle torque [N m]")
    ax[1].set_ylabel(r"(b) $l_c^{ref}$ [N m s]")
    ax[2].set_ylabel(r"(c) $l_c^{ref}$ [N m s]")
    ax[2].set_xlabel("time [s]")
    window = active_window(series)
    if window:
        ax[2].set_xlim(*window)
    for x in ax:
        x.grid(True, alpha=0.3)
        x.legend(fontsize=7, loc="best")
    ax[0].set_title(a.title, fontsize=10)
    fig.tight_layout()
    fig.savefig(a.png, dpi=110)


if __name__ == "__main__":
    main()
