#!/usr/bin/python3
"""Every fruit the gripper knocked off the tree in a recorded simulated run, and how.

One line per fruit that went to "knocked off" (SIM_TRUTH): the run time, the
controller's state then, the fruit centre in the tool frame when it fell
(lat: off the gripper axis, ax: along it, + ahead of the tool point, mm), its
diameter, and how: "finger, beside" (the fingers closed on it off the axis),
"finger, early" (closed with it more than --axial-max ahead: the IR read
something nearer), or "palm" (no close: the palm ran into it); then the
controller's last note before it fell. A summary line counts each kind and
how many palm knocks came while going on past a leaf. Needs SIM_TRUTH in the
log (docs/log-tools.md).

    knocks.py LOG [--harvest-log build/bin/harvest-log] [--axial-max 35]
"""
import argparse, bisect, math, os, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from simlog import export, quat_rot, sub, to_tool, get

KNOCKED = 3  # sim_fruit_truth_t.state
KINDS = ("finger, beside", "finger, early", "palm")


def knocks(truth, status, axial_max_mm=35.0):
    """Knocked-off fruit from SIM_TRUTH rows and HARVEST_STATUS rows (harvest-log export jsonl, in log order)."""
    stt = [m["log_utime"] for m in status]
    t0 = truth[0]["log_utime"] if truth else 0
    out, state_of = [], {}
    for m in truth:
        for q in range(m["num_fruits"]):
            sid, s = m[f"fruits[{q}].sim_id"], m[f"fruits[{q}].state"]
            if s == KNOCKED and state_of.get(sid) != KNOCKED:
                R = quat_rot(get(m, "tool_pose.orientation", 4))
                v = to_tool(R, sub(get(m, f"fruits[{q}].position_base", 3), get(m, "tool_pose.position", 3)))
                lat, ax = math.hypot(v[0], v[1]) * 1e3, v[2] * 1e3
                if m[f"fruits[{q}].grasp_attempts"] > 0:
                    how = "finger, early" if ax > axial_max_mm else "finger, beside"
                else:
                    how = "palm"
                k = bisect.bisect_right(stt, m["log_utime"]) - 1
                state, note = (status[k]["state"], status[k]["summary"].split(" | ")[-1]) if k >= 0 else ("-", "")
                out.append({"t": (m["log_utime"] - t0) / 1e6, "sim_id": sid, "state": state, "lat": lat, "ax": ax,
                            "diameter": m[f"fruits[{q}].diameter_m"] * 1e3, "how": how, "note": note})
            state_of[sid] = s
    return out


def summary(found):
    n = {k: sum(1 for f in found if f["how"] == k) for k in KINDS}
    leaf = sum(1 for f in found if f["how"] == "palm" and "past a leaf" in f["note"])
    return (f"{len(found)} knocked off: " + ", ".join(f"{n[k]} {k}" for k in KINDS) +
            f" ({leaf} of the palm's going on past a leaf)")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("log")
    ap.add_argument("--harvest-log", default="build/bin/harvest-log")
    ap.add_argument("--axial-max", type=float, default=35.0, help="[mm] capture range ahead of the tool point")
    a = ap.parse_args()
    truth = export(a.harvest_log, a.log, "SIM_TRUTH",
                   "tool_pose,num_fruits,fruits[].sim_id,fruits[].state,fruits[].position_base,fruits[].diameter_m,"
                   "fruits[].grasp_attempts")
    if not truth:
        sys.exit(f"{a.log}: no SIM_TRUTH (a simulated run recorded with it is needed)")
    found = knocks(truth, export(a.harvest_log, a.log, "HARVEST_STATUS", "state,summary"), a.axial_max)
    for f in found:
        print(f"{f['t']:7.1f} s  fruit sim{f['sim_id']:<3} {f['state']:<12} lat {f['lat']:5.1f} ax {f['ax']:6.1f} "
              f"d {f['diameter']:3.0f} mm  {f['how']:<15} | {f['note']}")
    print(summary(found))


if __name__ == "__main__":
    main()
