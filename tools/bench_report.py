#!/usr/bin/env python3
"""Ratio lines from Google Benchmark JSON output (tools/harvest bench).

Benchmarks named BM_<job>_<impl>[/args] are paired by job and args: the
`Ours` one against each other implementation (OpenCV, ViSP, Eigen) of the
same job. A counter `target_ratio` on the Ours benchmark is the largest
ours/theirs ratio we accept; `target_ms` is an absolute target for a job
with nothing to compare against (its line also shows counters `inliers`,
`rms_px`, `worst_rms_px` when the job reports its accuracy). Times are the median CPU time over the
repetitions (wall time on a shared machine measures the other processes).

usage: bench_report.py OUT.json [OUT.json ...]
"""
import json
import os
import re
import sys

NAME = re.compile(r"^BM_(?P<job>.+)_(?P<impl>Ours|OpenCV|ViSP|Eigen)(?P<args>/.*)?$")
TO_MS = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}


def load(paths):
    """{(job, args): {impl: entry}} from the median aggregates (or single runs)."""
    runs = {}
    for path in paths:
        if os.path.getsize(path) == 0:
            continue  # a binary whose benchmarks the filter left out writes nothing
        with open(path) as f:
            data = json.load(f)
        for b in data.get("benchmarks", []):
            aggregate = b.get("run_type") == "aggregate"
            if aggregate and b.get("aggregate_name") != "median":
                continue
            m = NAME.match(b.get("run_name", b["name"]))
            if not m:
                continue
            key = (m["job"], m["args"] or "")
            entry = runs.setdefault(key, {}).get(m["impl"])
            if entry is not None and not aggregate and entry.get("run_type") != "aggregate":
                continue  # several plain runs: keep the first
            runs[key][m["impl"]] = b
    return runs


def ms(entry):
    return entry["cpu_time"] * TO_MS[entry.get("time_unit", "ns")]


def fmt(t_ms):
    if t_ms >= 1.0:
        return f"{t_ms:8.2f} ms"
    return f"{t_ms * 1e3:8.1f} us"


def accuracy(entry):
    """The accuracy a job reports beside its time (counters inliers, rms_px, worst_rms_px)."""
    if "rms_px" not in entry:
        return ""
    text = f"  ({entry['inliers']:.0f} inliers" if "inliers" in entry else "  ("
    text += f", transfer rms {entry['rms_px']:.3f} px"
    if "worst_rms_px" in entry:
        text += f", worst {entry['worst_rms_px']:.3f}"
    return text + ")"


def main(paths):
    runs = load(paths)
    lines, failed = [], 0
    for (job, args), impls in runs.items():
        ours = impls.get("Ours")
        if ours is None:
            continue
        label = f"{job}{args}"
        others = [(k, v) for k, v in sorted(impls.items()) if k != "Ours"]
        for impl, theirs in others:
            ratio = ms(ours) / ms(theirs)
            target = ours.get("target_ratio")
            verdict = ""
            if target is not None:
                ok = ratio <= target
                failed += not ok
                verdict = f"target <= {target:.2f}x  {'ok' if ok else 'MISSED'}"
            lines.append(f"{label:<22} ours {fmt(ms(ours))} | {impl:<6} {fmt(ms(theirs))} | "
                         f"{ratio:6.2f}x  {verdict}")
        if not others and "target_ms" not in ours:
            lines.append(f"{label:<22} ours {fmt(ms(ours))} | (no target)")
        if "target_ms" in ours:
            ok = ms(ours) <= ours["target_ms"]
            failed += not ok
            lines.append(f"{label:<22} ours {fmt(ms(ours))} | {'':<6} {'':>11} | {'':>7}  "
                         f"target <= {ours['target_ms']:g} ms  {'ok' if ok else 'MISSED'}{accuracy(ours)}")
    if not lines:
        print("bench_report: no BM_<job>_Ours benchmarks in the output", file=sys.stderr)
        return 1
    print("ours vs the library a user would pick (median CPU time; ratio = ours / theirs, lower is faster)")
    for line in lines:
        print(line)
    return 1 if failed else 0


if __name__ == "__main__":
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1:]))
