"""Shared helpers of the scripts that read a simulated run's log against its truth (wind_closes.py, knocks.py)."""
import json, subprocess


def export(hl, log, ch, fields=None):
    """One channel of `log` as a list of dicts, through `harvest-log export` (binary `hl`)."""
    cmd = [hl, "export", log, ch, "--format", "jsonl"]
    if fields: cmd += ["--fields", fields]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return [json.loads(l) for l in out.splitlines() if l.strip()]


def quat_rot(q):
    """Rotation matrix of a unit quaternion (w, x, y, z), as in pose_t."""
    w, x, y, z = q
    return [[1-2*(y*y+z*z), 2*(x*y-w*z), 2*(x*z+w*y)],
            [2*(x*y+w*z), 1-2*(x*x+z*z), 2*(y*z-w*x)],
            [2*(x*z-w*y), 2*(y*z+w*x), 1-2*(x*x+y*y)]]


def sub(a, b): return [a[i]-b[i] for i in range(3)]
def to_tool(R, d): return [sum(R[r][c]*d[r] for r in range(3)) for c in range(3)]  # R^T d


def get(m, pfx, n):
    return [m[f"{pfx}[{i}]"] for i in range(n)]
