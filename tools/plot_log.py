#!/usr/bin/python3
"""PNG plots from a harvest LCM log (docs/log-tools.md).

    tools/plot_log.py LOG --out DIR [--harvest-log build/bin/harvest-log] [--frames N]

Reads the log through `harvest-log export` (CSV) and writes, for whatever the
log holds:
  servo.png        servo errors and velocities against time: the selected
                   fruit's offset from the hand image centre [px], the
                   distance from the tool to the selected target [m], the
                   commanded and measured tool velocities, controller states
  trajectory.png   tool trajectory in the base frame, x-y, x-z and y-z
                   projections (thesis figures 6-9..6-11), with the estimated
                   targets and the true fruit positions
  depth.png        depth estimates against truth (SIM_TRUTH): the hand
                   camera's depth along its optical axis and the 3D error of
                   every target against the nearest true fruit
  detections.png   camera frames with the detections drawn on them (from
                   `harvest-log frames`)
  tbz.png          teach by zooming (approach_mode tbz, TBZ_ERROR): the
                   rotation error u theta and the translation error e_v of
                   every TBZ step, and the commanded tool velocities over the
                   same span (like the thesis's figures 5-5, 5-6, 5-8, 5-9),
                   with the share of verified FEATURE_MATCHES
Prints one line per PNG written. Exit 0 if at least one plot was written.
"""
import argparse
import csv
import datetime
import io
import math
import os
import subprocess
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


class Log:
    def __init__(self, path, tool):
        self.path, self.tool = path, tool
        out = subprocess.run([tool, "info", path], capture_output=True, text=True)
        if out.returncode != 0:
            raise SystemExit(f"plot_log: {out.stderr.strip()}")
        self.channels = set()
        self.t0 = 0
        in_table = False
        for line in out.stdout.splitlines():
            if line.startswith("start "):
                when = datetime.datetime.strptime(line.split(None, 1)[1].replace(" UTC", ""), "%Y-%m-%d %H:%M:%S.%f")
                when = when.replace(tzinfo=datetime.timezone.utc)
                self.t0 = round(when.timestamp() * 1e6)
            if line.startswith("channel "):
                in_table = True
                continue
            if in_table:
                if not line.strip():
                    break
                self.channels.add(line.split()[0])

    def rows(self, channel, fields=None):
        """The channel as a list of dicts (numbers as float where possible)."""
        if channel not in self.channels:
            return []
        cmd = [self.tool, "export", self.path, channel, "--format", "csv"]
        if fields:
            cmd += ["--fields", ",".join(fields)]
        out = subprocess.run(cmd, capture_output=True, text=True, check=True)
        rows = []
        for r in csv.DictReader(io.StringIO(out.stdout)):
            d = {}
            for k, v in r.items():
                try:
                    d[k] = float(v)
                except (TypeError, ValueError):
                    d[k] = v
            rows.append(d)
        return rows

    def time(self, row):
        return (row["log_utime"] - self.t0) * 1e-6


def vec(row, key, n=3):
    return [row.get(f"{key}[{i}]", float("nan")) for i in range(n)]


def quat_to_matrix(q):
    w, x, y, z = q
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]


def mark_states(ax, log, status):
    last = None
    for r in status:
        s = r.get("state")
        if s != last and isinstance(s, str):
            t = log.time(r)
            ax.axvline(t, color="0.8", lw=0.6, zorder=0)
            ax.text(t, 1.0, s, transform=ax.get_xaxis_transform(), rotation=90, fontsize=6, va="top", color="0.4")
            last = s


def plot_servo(log, out):
    state = log.rows("ROBOT_STATE", ["tool_pose.position", "tool_twist"])
    cmd = log.rows("ROBOT_COMMAND", ["type", "twist"])
    hand = log.rows("FRUIT_HAND", ["image_width", "image_height", "selected_index", "fruits[].u_px", "fruits[].v_px"])
    targets = log.rows("TARGETS", ["selected_fruit_id", "targets[].fruit_id", "targets[].position_base"])
    status = log.rows("HARVEST_STATUS", ["state"])
    if not (state or cmd or hand):
        return None
    fig, axes = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    # image error of the selected fruit in the hand camera
    t, eu, ev = [], [], []
    for r in hand:
        k = int(r.get("selected_index", -1))
        if k < 0:
            continue
        u, v = r.get(f"fruits[{k}].u_px"), r.get(f"fruits[{k}].v_px")
        if isinstance(u, float) and isinstance(v, float):
            t.append(log.time(r))
            eu.append(u - r["image_width"] / 2)
            ev.append(v - r["image_height"] / 2)
    axes[0].plot(t, eu, ".", ms=2, label="u - cx")
    axes[0].plot(t, ev, ".", ms=2, label="v - cy")
    axes[0].set_ylabel("hand image error [px]")
    # distance from the tool to the selected target
    tool_t = [log.time(r) for r in state]
    tool_p = [vec(r, "tool_pose.position") for r in state]
    t, dist = [], []
    j = 0
    for r in targets:
        sel = r.get("selected_fruit_id", -1)
        k = 0
        while f"targets[{k}].fruit_id" in r and isinstance(r[f"targets[{k}].fruit_id"], float):
            if r[f"targets[{k}].fruit_id"] == sel:
                break
            k += 1
        p = vec(r, f"targets[{k}].position_base")
        if sel < 0 or any(not isinstance(x, float) or math.isnan(x) for x in p) or not tool_p:
            continue
        tr = log.time(r)
        while j + 1 < len(tool_t) and tool_t[j + 1] <= tr:
            j += 1
        t.append(tr)
        dist.append(math.dist(p, tool_p[j]))
    axes[1].plot(t, dist, ".", ms=2)
    axes[1].set_ylabel("tool to target [m]")
    tc = [log.time(r) for r in cmd if r.get("type") == 1.0]
    for i, name in enumerate("xyz"):
        axes[2].plot(tc, [r.get(f"twist.linear[{i}]") for r in cmd if r.get("type") == 1.0], lw=0.8, label=f"cmd v{name}")
        axes[2].plot(tool_t, [r.get(f"tool_twist.linear[{i}]") for r in state], lw=0.5, ls="--", label=f"meas v{name}")
        axes[3].plot(tc, [r.get(f"twist.angular[{i}]") for r in cmd if r.get("type") == 1.0], lw=0.8, label=f"cmd w{name}")
    axes[2].set_ylabel("tool velocity [m/s]")
    axes[3].set_ylabel("angular velocity [rad/s]")
    axes[3].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        mark_states(ax, log, status)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=6, ncol=3, loc="lower right")
    fig.suptitle(f"servo errors and velocities: {os.path.basename(log.path)}")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out


def plot_trajectory(log, out):
    state = log.rows("ROBOT_STATE", ["tool_pose.position"])
    truth = log.rows("SIM_TRUTH", ["tool_pose.position", "fruits[].position_base"])
    targets = log.rows("TARGETS", ["targets[].position_base", "targets[].selected"])
    tool = [vec(r, "tool_pose.position") for r in state] or [vec(r, "tool_pose.position") for r in truth]
    if not tool:
        return None
    est = []
    for r in targets:
        k = 0
        while f"targets[{k}].position_base[0]" in r and isinstance(r[f"targets[{k}].position_base[0]"], float):
            est.append(vec(r, f"targets[{k}].position_base"))
            k += 1
    fruit = []
    if truth:
        r = truth[0]
        k = 0
        while f"fruits[{k}].position_base[0]" in r and isinstance(r[f"fruits[{k}].position_base[0]"], float):
            fruit.append(vec(r, f"fruits[{k}].position_base"))
            k += 1
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.5))
    for ax, (a, b) in zip(axes, [(0, 1), (0, 2), (1, 2)]):
        ax.plot([p[a] for p in tool], [p[b] for p in tool], lw=1.2, label="tool (ROBOT_STATE)")
        ax.plot(tool[0][a], tool[0][b], "go", ms=5, label="start")
        ax.plot(tool[-1][a], tool[-1][b], "ks", ms=5, label="end")
        if est:
            ax.plot([p[a] for p in est], [p[b] for p in est], ".", ms=2, color="tab:orange", alpha=0.5, label="TARGETS")
        if fruit:
            ax.plot([p[a] for p in fruit], [p[b] for p in fruit], "r*", ms=9, label="true fruit")
        # Outlying estimates must not hide the trajectory.
        pts = tool + fruit
        for setlim, k in ((ax.set_xlim, a), (ax.set_ylim, b)):
            lo, hi = min(p[k] for p in pts), max(p[k] for p in pts)
            pad = max(0.1, 0.15 * (hi - lo))
            setlim(lo - pad, hi + pad)
        ax.set_xlabel("xyz"[a] + " [m]")
        ax.set_ylabel("xyz"[b] + " [m]")
        ax.set_aspect("equal", adjustable="box")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"tool trajectory in the base frame: {os.path.basename(log.path)}")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out


def plot_depth(log, out):
    truth = log.rows("SIM_TRUTH", ["hand_camera_pose", "fruits[].position_base"])
    targets = log.rows("TARGETS", ["source_camera", "targets[].depth_m", "targets[].position_base",
                                    "targets[].source_camera"])
    if not truth or not targets:
        return None
    tt = [log.time(r) for r in truth]

    def truth_at(t):
        j = min(range(len(tt)), key=lambda i: abs(tt[i] - t))
        r = truth[j]
        fruits, k = [], 0
        while f"fruits[{k}].position_base[0]" in r and isinstance(r[f"fruits[{k}].position_base[0]"], float):
            fruits.append(vec(r, f"fruits[{k}].position_base"))
            k += 1
        return r, fruits

    series = {"fixed": ([], [], [], []), "hand": ([], [], [], [])}
    for r in targets:
        t = log.time(r)
        tr, fruits = truth_at(t)
        if not fruits:
            continue
        k = 0
        while f"targets[{k}].depth_m" in r and isinstance(r[f"targets[{k}].depth_m"], float):
            cam = r.get(f"targets[{k}].source_camera", r.get("source_camera"))
            p = vec(r, f"targets[{k}].position_base")
            nearest = min(fruits, key=lambda f: math.dist(f, p))
            s = series.setdefault(cam if isinstance(cam, str) else "?", ([], [], [], []))
            s[0].append(t)
            s[1].append(r[f"targets[{k}].depth_m"])
            s[3].append(math.dist(nearest, p))
            if cam == "hand":
                c = vec(tr, "hand_camera_pose.position")
                rot = quat_to_matrix(vec(tr, "hand_camera_pose.orientation", 4))
                d = [nearest[i] - c[i] for i in range(3)]
                s[2].append(sum(rot[i][2] * d[i] for i in range(3)))  # z in the camera frame
            else:
                s[2].append(float("nan"))
            k += 1
    fig, axes = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    for cam, (t, est, true, err) in series.items():
        if not t:
            continue
        axes[0].plot(t, est, ".", ms=2, label=f"{cam}: estimated depth")
        if cam == "hand":
            axes[0].plot(t, true, "-", lw=0.8, label="hand: true depth")
        axes[1].plot(t, err, ".", ms=2, label=f"{cam}: |target - true fruit|")
    axes[0].set_ylabel("depth [m]")
    axes[1].set_ylabel("3D error [m]")
    axes[1].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"depth estimate against truth: {os.path.basename(log.path)}")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out


def plot_tbz(log, out):
    err = log.rows("TBZ_ERROR")
    if not err:
        return None
    cmd = [r for r in log.rows("ROBOT_COMMAND", ["type", "twist"]) if r.get("type") == 1.0]
    matches = log.rows("FEATURE_MATCHES", ["status", "num_inliers"])
    status = log.rows("HARVEST_STATUS", ["state"])
    te = [log.time(r) for r in err]
    t0, t1 = te[0], te[-1]
    # TBZ steps come in runs, one per approach: plot the span of the steps, a little either side.
    t0, t1 = t0 - 0.5, t1 + 0.5
    fig, axes = plt.subplots(5, 1, figsize=(9, 12), sharex=True)
    for i, name in enumerate("xyz"):
        axes[0].plot(te, [r[f"angular[{i}]"] for r in err], lw=0.9, label=f"e_w{name}")
    axes[0].plot(te, [math.sqrt(sum(r[f"angular[{i}]"] ** 2 for i in range(3))) for r in err], "k", lw=0.6,
                 label="|e_w|")
    axes[0].set_ylabel("rotation error u theta [rad]")
    for i, name in enumerate(("m_e1 - m_d1", "m_e2 - m_d2", "ln(Z1/Z*1)")):
        axes[1].plot(te, [r[f"linear[{i}]"] for r in err], lw=0.9, label=name)
    axes[1].set_ylabel("translation error e_v")
    c = [r for r in cmd if t0 <= log.time(r) <= t1]
    tc = [log.time(r) for r in c]
    for i, name in enumerate("xyz"):
        axes[2].plot(tc, [r[f"twist.linear[{i}]"] for r in c], lw=0.9, label=f"v{name}")
        axes[3].plot(tc, [r[f"twist.angular[{i}]"] for r in c], lw=0.9, label=f"w{name}")
    axes[2].set_ylabel("commanded v (base) [m/s]")
    axes[3].set_ylabel("commanded w (base) [rad/s]")
    status = [r for r in status if t0 <= log.time(r) <= t1]  # state labels inside the plotted span only
    m = [r for r in matches if t0 <= log.time(r) <= t1]
    axes[4].plot([log.time(r) for r in m], [r.get("num_inliers", 0) if r.get("status") == 0.0 else 0 for r in m], ".",
                 ms=2, label="verified matches (0: status not OK)")
    axes[4].set_ylabel("FEATURE_MATCHES inliers")
    axes[4].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.set_xlim(t0, t1)
        mark_states(ax, log, status)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=6, ncol=4, loc="upper right")
    fig.suptitle(f"teach by zooming: {os.path.basename(log.path)}")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out


def plot_detections(log, out, frames):
    pngs = []
    with tempfile.TemporaryDirectory() as tmp:
        for cam, det in (("CAMERA_FIXED", "FRUIT_FIXED"), ("CAMERA_HAND", "FRUIT_HAND")):
            if cam not in log.channels:
                continue
            n = len(log.rows(cam, ["header.utime"]))
            every = max(1, n // frames)
            cmd = [log.tool, "frames", log.path, cam, "--out", tmp, "--every", str(every), "--max", str(frames)]
            if det in log.channels:
                cmd += ["--detections", det]
            res = subprocess.run(cmd, capture_output=True, text=True)
            pngs.append([p for p in res.stdout.split() if p.endswith(".png")])
        pngs = [p for p in pngs if p]
        if not pngs:
            return None
        cols = max(len(p) for p in pngs)
        fig, axes = plt.subplots(len(pngs), cols, figsize=(3 * cols, 2.4 * len(pngs)), squeeze=False)
        for i, row in enumerate(pngs):
            for j in range(cols):
                ax = axes[i][j]
                ax.axis("off")
                if j < len(row):
                    ax.imshow(mpimg.imread(row[j]))
        fig.suptitle(f"detections on camera frames: {os.path.basename(log.path)}")
        fig.tight_layout()
        fig.savefig(out, dpi=90)
        plt.close(fig)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("log")
    ap.add_argument("--out", required=True, help="output folder")
    default_tool = os.path.join(os.environ.get("HARVEST_BUILD_DIR", os.path.join(ROOT, "build")), "bin", "harvest-log")
    ap.add_argument("--harvest-log", default=default_tool, help="harvest-log executable")
    ap.add_argument("--frames", type=int, default=4, help="frames per camera in detections.png")
    ap.add_argument("--plots", default="servo,trajectory,depth,tbz,detections", help="which plots (comma-separated)")
    a = ap.parse_args()
    if not os.path.exists(a.harvest_log):
        raise SystemExit(f"plot_log: {a.harvest_log} not found (build first, or pass --harvest-log)")
    os.makedirs(a.out, exist_ok=True)
    log = Log(a.log, a.harvest_log)
    if not log.channels:
        raise SystemExit("plot_log: empty log")
    written = []
    wanted = set(a.plots.split(","))
    for name, fn in (("servo", plot_servo), ("trajectory", plot_trajectory), ("depth", plot_depth), ("tbz", plot_tbz)):
        p = fn(log, os.path.join(a.out, name + ".png")) if name in wanted else None
        if p:
            written.append(p)
    p = plot_detections(log, os.path.join(a.out, "detections.png"), a.frames) if "detections" in wanted else None
    if p:
        written.append(p)
    for p in written:
        print(p)
    return 0 if written else 1


if __name__ == "__main__":
    sys.exit(main())
