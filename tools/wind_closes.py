#!/usr/bin/python3
"""Per gripper close of a recorded run: where the true fruit was relative to the tool point.

The fruit: the one on the tree nearest to the controller's estimate in the
outcome recorded after the close (estE: how far that estimate was from it,
mm). lat/ax: the fruit centre off the gripper axis and along it (+: ahead of
the tool point), mm, at the close command (0) and at its end 0.6 s later
(E); cLat/cAx: the same for the middle of its sway (its mean position over
the 2.5 s before the close) at the end. IR: the last IR range before the
close. after: the fruit's state 1.5 s after the close. note: the
controller's summary just after the close.

    wind_closes.py LOG [--harvest-log build/bin/harvest-log]
"""
import argparse, math, os, sys, bisect

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from simlog import export, quat_rot, sub, to_tool, get

ap = argparse.ArgumentParser()
ap.add_argument("log")
ap.add_argument("--harvest-log", default="build/bin/harvest-log")
a = ap.parse_args()
hl = a.harvest_log
gc = [m for m in export(hl, a.log, "GRIPPER_COMMAND") if m.get("action") == 1]
truth = export(hl, a.log, "SIM_TRUTH")
ir = export(hl, a.log, "IR_RANGE", "range_m,validity")
st = export(hl, a.log, "HARVEST_STATUS", "state,summary,current_fruit_id,num_outcomes,outcomes[].target_base,outcomes[].detail")
tt = [m["log_utime"] for m in truth]
it = [m["log_utime"] for m in ir]
stt = [m["log_utime"] for m in st]

def fruits(m):
    n = m["num_fruits"]
    return [(m[f"fruits[{i}].sim_id"], m[f"fruits[{i}].state"], get(m, f"fruits[{i}].position_base", 3)) for i in range(n)]

def truth_at(t):
    k = min(bisect.bisect_left(tt, t), len(tt)-1)
    return truth[k]

names = {0: "tree", 1: "held", 2: "picked", 3: "knocked"}
print(f"{'t_s':>6} {'fruit':>5} {'estE':>5} {'IR_mm':>6} {'lat0':>5} {'ax0':>5} {'latE':>5} {'axE':>5} {'cLat':>5} {'cAx':>5} {'after':>8}  note")
t0 = tt[0]
for g in gc:
    tc = g["log_utime"]
    m0 = truth_at(tc)
    mE = truth_at(tc + 600000)
    mA = truth_at(tc + 1500000)
    tool0 = get(m0, "tool_pose.position", 3); R0 = quat_rot(get(m0, "tool_pose.orientation", 4))
    toolE = get(mE, "tool_pose.position", 3); RE = quat_rot(get(mE, "tool_pose.orientation", 4))
    fE = fruits(mE)
    # target: the fruit on the tree at the close nearest to the tool at its end
    on_tree = {f[0] for f in fruits(m0) if f[1] == 0}
    # the fruit aimed at: nearest to the estimate of the first outcome recorded after the close
    k0 = bisect.bisect_left(stt, tc); n0 = st[k0-1]["num_outcomes"] if k0 > 0 else 0
    est = None
    for m in st[k0:]:
        if m["num_outcomes"] > n0:
            est = [m[f"outcomes[{n0}].target_base[{i}]"] for i in range(3)]
            break
    ref = est if est else toolE
    best = min((f for f in fE if f[0] in on_tree), key=lambda f: math.dist(f[2], ref), default=None)
    est_off = math.dist(est, [f for f in fruits(m0) if f[0] == best[0]][0][2]) * 1e3 if est and best else float("nan")
    if best is None: continue
    fid = best[0]
    f0 = [f for f in fruits(m0) if f[0] == fid][0]
    # sway centre: mean over the 2.5 s (one period at 0.4 Hz) before the close
    ks = [k for k in range(bisect.bisect_left(tt, tc-2500000), bisect.bisect_left(tt, tc))]
    cen = [0, 0, 0]
    for k in ks:
        p = [f for f in fruits(truth[k]) if f[0] == fid][0][2]
        cen = [cen[i] + p[i]/len(ks) for i in range(3)]
    l0 = to_tool(R0, sub(f0[2], tool0)); lE = to_tool(RE, sub(best[2], toolE)); lc = to_tool(RE, sub(cen, toolE))
    after = [f for f in fruits(mA) if f[0] == fid][0][1]
    ki = bisect.bisect_left(it, tc) - 1
    irr = ir[ki]["range_m"]*1000 if ki >= 0 else float("nan")
    ks2 = bisect.bisect_right(stt, tc+100000) - 1
    note = st[ks2]["summary"] if ks2 >= 0 else ""
    hyp = lambda v: math.hypot(v[0], v[1])
    print(f"{(tc-t0)/1e6:6.1f} {fid:5d} {est_off:5.0f} {irr:6.0f} {hyp(l0)*1e3:5.0f} {l0[2]*1e3:5.0f} {hyp(lE)*1e3:5.0f} {lE[2]*1e3:5.0f} {hyp(lc)*1e3:5.0f} {lc[2]*1e3:5.0f} {names.get(after, after):>8}  {note[:110]}")
