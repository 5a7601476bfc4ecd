#!/usr/bin/env python3
"""Figures of one push experiment, from the CSV files lcm_export writes from its LCM log.

    plot_trial.py CSV_DIR OUT_DIR [--title TEXT] [--window T0 T1]

Writes, like the paper's figures:
  fig5.png   contact torques of the virtual stance foot (ankle, hip, total) with their limits and the
             activation threshold; reference, commanded and measured CAM and their rates; CoP and
             CoM deviation along the push; phase boundaries dashed, the push shaded
  fig7d.png  each body segment's contribution to the commanded CAM
  fig8.png   optimised velocities and positions of the adjusted coordinates with their limits
"""
import argparse
import os
import sys

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def load(csv_dir, channel):
    """One channel's CSV as a structured array (columns by name); None if absent or empty."""
    path = os.path.join(csv_dir, channel + ".csv")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        names = f.readline().rstrip("\n").split(",")
    try:
        # The fast parser; it refuses the empty cells of a message that lacks a column.
        values = np.loadtxt(path, delimiter=",", skiprows=1, dtype=float, ndmin=2)
        if values.shape[0] == 0:
            return None
        data = np.rec.fromarrays(values.T, names=names)
    except ValueError:
        data = np.genfromtxt(path, delimiter=",", names=True, dtype=float, missing_values="", filling_values=np.nan,
                             deletechars="", invalid_raise=False)
    if data.size == 0:
        return None
    return np.atleast_1d(data)


def push_interval(truth):
    if truth is None or "push_active" not in truth.dtype.names:
        return None
    active = truth["push_active"] > 0.5
    if not active.any():
        return None
    t = truth["t"][active]
    return t[0], t[-1]


def push_axes(truth):
    """(horizontal axis of the push: 0 = x, 1 = y; sign of the push along it)."""
    if truth is None:
        return 0, 1.0
    fx, fy = np.abs(truth["push_force_W_0"]).max(), np.abs(truth["push_force_W_1"]).max()
    axis = 0 if fx >= fy else 1
    f = truth["push_force_W_%d" % axis]
    sign = 1.0 if f[np.argmax(np.abs(f))] >= 0 else -1.0
    return axis, sign


def decorate(ax, push, phases):
    if push is not None:
        ax.axvspan(push[0], push[1], color="0.85", zorder=0, label="_push")
    for t, name in phases:
        ax.axvline(t, color="0.3", ls="--", lw=0.8)
    ax.grid(True, lw=0.3)


def phase_lines(camref, torque_axis):
    """Times at which phases 1, 2 and 3 began on the torque axis (last occurrence of each)."""
    if camref is None:
        return []
    out = []
    for p in (1, 2, 3):
        col = "t_phase_start_%d_%d" % (torque_axis, p)
        if col not in camref.dtype.names:
            continue
        v = camref[col]
        v = v[v >= 0]
        if v.size:
            out.append((float(np.unique(v)[-1]), "phase %d" % p))
    return out


def fig5(d, out, title, window):
    truth, state, bal, cam, wb = d["SIM_TRUTH"], d["ROBOT_STATE"], d["BALANCE_STATUS"], d["CAM_REFERENCE"], d["WHOLEBODY_COMMAND"]
    axis, sign = push_axes(truth)
    # A push along x tips the robot about y (and along y about x).
    tq = 1 if axis == 0 else 0
    names = "xyz"
    push = push_interval(truth)
    phases = phase_lines(cam, tq)
    fig, axs = plt.subplots(4, 1, figsize=(9, 11), sharex=True)
    ax = axs[0]
    if bal is not None:
        t = bal["t"]
        ax.plot(t, bal["tau_ankle_V_%d" % tq], label=r"$\tau_v^{ankle}$")
        ax.plot(t, bal["tau_hip_V_%d" % tq], label=r"$\tau_v^{hip}$")
        ax.plot(t, bal["tau_V_%d" % tq], "k", lw=1.2, label=r"$\tau_v$")
        ax.plot(t, bal["tau_min_V_%d" % tq], "r:", lw=1, label="limits (22)")
        ax.plot(t, bal["tau_max_V_%d" % tq], "r:", lw=1)
    if cam is not None:
        thr = cam["tau_thres_V_%d" % tq]
        ok = np.abs(thr) > 0
        if ok.any():
            ax.plot(cam["t"][ok], thr[ok], ".", ms=1.5, color="tab:purple", label=r"$\tau^{thres}$ (23)")
    ax.set_ylabel("contact torque about %s [N m]" % names[tq])
    ax.legend(loc="upper right", fontsize=7, ncol=3)
    decorate(ax, push, phases)

    ax = axs[1]
    if cam is not None:
        ax.plot(cam["t"], cam["l_ref_W_%d" % tq], label=r"$l_c^{ref}$")
    if wb is not None:
        ax.plot(wb["t"], wb["l_cmd_W_%d" % tq], label=r"$l_c^{cmd}$")
    if state is not None:
        ax.plot(state["t"], state["l_WCom_%d" % tq], label=r"$l_c$ measured")
    if truth is not None:
        ax.plot(truth["t"], truth["l_WCom_%d" % tq], "k", lw=0.8, alpha=0.6, label=r"$l_c$ simulator")
    ax.set_ylabel("CAM about %s [N m s]" % names[tq])
    ax.legend(loc="upper right", fontsize=7, ncol=2)
    decorate(ax, push, phases)

    ax = axs[2]
    if cam is not None:
        ax.plot(cam["t"], cam["ldot_ref_W_%d" % tq], label=r"$\dot l_c^{ref}$")
    if wb is not None:
        ax.plot(wb["t"], wb["ldot_cmd_W_%d" % tq], label=r"$\dot l_c^{cmd}$", alpha=0.8)
    if state is not None:
        ax.plot(state["t"], state["ldot_WCom_%d" % tq], label=r"$\dot l_c$ measured", alpha=0.8)
    ax.set_ylabel("CAM rate [N m]")
    ax.legend(loc="upper right", fontsize=7, ncol=3)
    decorate(ax, push, phases)

    ax = axs[3]
    if bal is not None:
        ax.plot(bal["t"], bal["cop_V_%d" % axis] * 100, label="CoP commanded")
        ax.plot(bal["t"], bal["cop_measured_V_%d" % axis] * 100, label="CoP distributed", alpha=0.8)
    if truth is not None:
        c = truth["p_WCom_%d" % axis]
        t = truth["t"]
        ref = c[(t < push[0])][-200:].mean() if push is not None and (t < push[0]).any() else c[0]
        ax.plot(t, (c - ref) * 100, "k", label="CoM deviation")
    ax.set_ylabel("along %s [cm]" % names[axis])
    ax.set_xlabel("time [s]")
    ax.legend(loc="upper right", fontsize=7, ncol=3)
    decorate(ax, push, phases)
    if window:
        axs[-1].set_xlim(*window)
    fig.suptitle(title + "\n(push shaded, phase boundaries dashed)", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig5.png"), dpi=110)
    plt.close(fig)


def fig7d(d, out, title, window):
    wb, truth = d["WHOLEBODY_COMMAND"], d["SIM_TRUTH"]
    if wb is None:
        return False
    axis, _ = push_axes(truth)
    tq = 1 if axis == 0 else 0
    push = push_interval(truth)
    segs = sorted({n[len("segment_l_W_"):-2] for n in wb.dtype.names if n.startswith("segment_l_W_")})
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for s in segs:
        col = "segment_l_W_%s_%d" % (s, tq)
        v = wb[col]
        if np.nanmax(np.abs(v)) < 1e-3:
            continue
        ax.plot(wb["t"], v, label=s.replace("_", " "))
    ax.plot(wb["t"], wb["l_cmd_W_%d" % tq], "k", lw=1.5, label="total (commanded)")
    ax.set_ylabel("CAM about %s [N m s]" % "xyz"[tq])
    ax.set_xlabel("time [s]")
    ax.legend(fontsize=7, ncol=3)
    decorate(ax, push, [])
    if window:
        ax.set_xlim(*window)
    ax.set_title(title + ": contribution of each segment to the commanded CAM", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig7d.png"), dpi=110)
    plt.close(fig)
    return True


def fig8(d, out, title, window):
    wb, truth = d["WHOLEBODY_COMMAND"], d["SIM_TRUTH"]
    if wb is None:
        return False
    push = push_interval(truth)
    coords = [n[len("xa_opt_"):] for n in wb.dtype.names if n.startswith("xa_opt_")]
    # The coordinates that moved the most.
    moved = sorted(coords, key=lambda c: -np.nanmax(np.abs(wb["xa_opt_" + c])))[:6]
    if not moved:
        return False
    fig, axs = plt.subplots(len(moved), 2, figsize=(11, 2.0 * len(moved)), sharex=True, squeeze=False)
    t = wb["t"]
    def show(ax, y, lo, hi, label):
        # The limits (17) as lines, as in the paper's Fig. 8; the axis spans them and the motion.
        hi = np.where(np.isfinite(hi), hi, np.nan)
        lo = np.where(np.isfinite(lo), lo, np.nan)
        ax.plot(t, y, label=label)
        ax.plot(t, hi, "r--", lw=1, label="limits (17)")
        ax.plot(t, lo, "r--", lw=1)
        top = np.nanmax([np.nanmax(y), np.nanmax(hi)])
        bottom = np.nanmin([np.nanmin(y), np.nanmin(lo)])
        margin = 0.08 * max(top - bottom, 1e-3)
        ax.set_ylim(bottom - margin, top + margin)
        decorate(ax, push, phases)

    phases = []
    if truth is not None:
        axis, _ = push_axes(truth)
        phases = phase_lines(d["CAM_REFERENCE"], 1 if axis == 0 else 0)
    for i, c in enumerate(moved):
        show(axs[i][0], wb["xad_opt_" + c], wb["xad_min_" + c], wb["xad_max_" + c], "optimised velocity")
        axs[i][0].set_ylabel(c.replace("_", " "), fontsize=8)
        show(axs[i][1], wb["xa_opt_" + c], wb["xa_min_" + c], wb["xa_max_" + c], "optimised position (offset)")
        if i == 0:
            axs[i][0].legend(fontsize=7, loc="upper right")
            axs[i][1].legend(fontsize=7, loc="upper right")
    axs[-1][0].set_xlabel("time [s]")
    axs[-1][1].set_xlabel("time [s]")
    if window:
        axs[-1][0].set_xlim(*window)
    fig.suptitle(title + ": adjusted DoF, velocity [rad/s or m/s] and offset from the reference [rad or m]", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig8.png"), dpi=110)
    plt.close(fig)
    return True


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("csv_dir")
    p.add_argument("out_dir")
    p.add_argument("--title", default="push experiment")
    p.add_argument("--window", nargs=2, type=float, default=None, help="time window [s]")
    a = p.parse_args()
    d = {c: load(a.csv_dir, c) for c in ("SIM_TRUTH", "ROBOT_STATE", "BALANCE_STATUS", "CAM_REFERENCE", "WHOLEBODY_COMMAND")}
    if d["SIM_TRUTH"] is None and d["BALANCE_STATUS"] is None:
        print("plot_trial: no SIM_TRUTH or BALANCE_STATUS in %s" % a.csv_dir, file=sys.stderr)
        return 1
    window = a.window
    if window is None:
        push = push_interval(d["SIM_TRUTH"])
        if push is not None:
            window = (max(0.0, push[0] - 0.5), push[1] + 3.0)
    os.makedirs(a.out_dir, exist_ok=True)
    fig5(d, a.out_dir, a.title, window)
    made = ["fig5.png"]
    if fig7d(d, a.out_dir, a.title, window):
        made.append("fig7d.png")
    if fig8(d, a.out_dir, a.title, window):
        made.append("fig8.png")
    print("figures: " + ", ".join(os.path.join(a.out_dir, m) for m in made))
    return 0


if __name__ == "__main__":
    sys.exit(main())
