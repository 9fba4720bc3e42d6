#!/usr/bin/python3
"""Figures like thesis 5-5..5-9 from harvest-tbz-sim CSV output.

usage: plot_tbz.py --csv DIR --out DIR
Reads DIR/errors.csv and DIR/features.csv; writes rotation_errors.png,
translation_errors.png, feature_trajectories.png, angular_velocity.png,
linear_velocity.png.
"""
import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"error: {path} has no rows")
    return {k: [float(r[k]) for r in rows] for k in rows[0]}


def three(d, keys, labels, ylabel, title, path):
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(6, 6))
    for ax, k, lab in zip(axes, keys, labels):
        ax.plot(d["t"], d[k])
        ax.set_ylabel(lab)
        ax.grid(True)
    axes[0].set_title(title)
    axes[-1].set_xlabel("time [s]")
    fig.supylabel(ylabel)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--csv", required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    e = read(os.path.join(a.csv, "errors.csv"))
    f = read(os.path.join(a.csv, "features.csv"))
    os.makedirs(a.out, exist_ok=True)
    three(e, ["ew_x", "ew_y", "ew_z"], ["e_w1", "e_w2", "e_w3"], "[rad]", "Rotation errors (fig. 5-5)",
          os.path.join(a.out, "rotation_errors.png"))
    three(e, ["ev_1", "ev_2", "ev_3"], ["e_v1", "e_v2", "e_v3"], "unitless", "Translation errors (fig. 5-6)",
          os.path.join(a.out, "translation_errors.png"))
    three(e, ["w_x", "w_y", "w_z"], ["w_r1", "w_r2", "w_r3"], "[rad/s]", "Angular velocity input (fig. 5-8)",
          os.path.join(a.out, "angular_velocity.png"))
    three(e, ["v_x", "v_y", "v_z"], ["v_r1", "v_r2", "v_r3"], "[m/s]", "Linear velocity input (fig. 5-9)",
          os.path.join(a.out, "linear_velocity.png"))
    fig, ax = plt.subplots(figsize=(6, 6))
    n = sum(1 for k in f if k.startswith("u"))
    for i in range(1, n + 1):
        u, v = f[f"u{i}"], f[f"v{i}"]
        ax.plot(u, v, label=f"point {i}")
        ax.plot(u[0], v[0], "k+", markersize=10)
        ax.plot(u[-1], v[-1], "kx", markersize=10)
    ax.invert_yaxis()
    ax.set_xlabel("u [px]")
    ax.set_ylabel("v [px]")
    ax.set_title("Feature trajectories, + start, x goal (fig. 5-7)")
    ax.legend()
    ax.grid(True)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "feature_trajectories.png"), dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    main()
