#!/usr/bin/python3
"""Frame-to-command latency of the real process graph over LCM (docs/performance.md).

Starts two harvest-camera drivers (image folders at 30 Hz: the simulator's
frames of a reference log at their 640x480 sensor size, published 320x240
JPEG as the simulator's cameras publish them), both fruit detectors, the reconstructor, the
servo controller, and the robot link against harvest-sim-drives on the UDP
virtual CAN bus, all on an LCM URL and CAN bus of their own (ttl=0), records
everything with lcm-logger, starts the harvest (operator START), runs for a
bounded time, stops every process by its PID, and reports with
`harvest-log latency --json`. Standard library only; run by
`tools/harvest bench latency`.
"""

import argparse
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def free_udp_port():
    """A UDP port nobody holds now (the kernel's choice), as the demo picks its own."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("", 0))
        return s.getsockname()[1]


def log(msg):
    print(f"[latency-bench] {msg}", flush=True)


class Processes:
    """Started processes, each stopped by its own PID (SIGINT, then SIGKILL after a grace time)."""

    def __init__(self, out_dir):
        self.out_dir = out_dir
        self.procs = []  # (name, Popen, output file)

    def start(self, name, argv):
        out = open(self.out_dir / f"{name}.txt", "w")
        p = subprocess.Popen(argv, stdout=out, stderr=subprocess.STDOUT, cwd=ROOT)
        self.procs.append((name, p, out))
        return p

    def dead(self):
        return [(n, p.returncode) for n, p, _ in self.procs if p.poll() is not None]

    def stop(self, names, grace_s=5.0):
        """Stops the processes named, in that order."""
        for name, p, out in sorted((e for e in self.procs if e[0] in names), key=lambda e: names.index(e[0])):
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
                try:
                    p.wait(timeout=grace_s)
                except subprocess.TimeoutExpired:
                    log(f"{name} (pid {p.pid}) did not stop in {grace_s:.0f} s: SIGKILL")
                    p.kill()
                    p.wait()
            out.close()

    def cpu_seconds(self):
        """User + system CPU time of every running process so far [s] (/proc/PID/stat), by name."""
        tick = os.sysconf("SC_CLK_TCK")
        out = {}
        for name, p, _ in self.procs:
            try:
                fields = Path(f"/proc/{p.pid}/stat").read_text().rsplit(")", 1)[1].split()
                out[name] = (int(fields[11]) + int(fields[12])) / tick
            except (OSError, IndexError, ValueError):
                pass
        return out

    def stop_all(self):
        # Commands first, then the arm, then the rest; the logger last.
        order = ["servo-controller", "robot-link", "sim-drives"]
        self.stop(order)
        rest = [n for n, _, _ in self.procs if n not in order and n != "logger"]
        self.stop(rest)
        self.stop(["logger"])


def extract_frames(harvest_log, source_log, channel, folder):
    folder.mkdir(parents=True, exist_ok=True)
    r = subprocess.run([str(harvest_log), "frames", str(source_log), channel, "--out", str(folder), "--max", "1000",
                        "--sensor-size", "--format", "bmp"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"latency-bench: cannot extract {channel} frames from {source_log}: {r.stderr.strip()}")
    n = len(list(folder.glob("*.bmp")))
    if n == 0:
        sys.exit(f"latency-bench: no {channel} frames in {source_log}")
    return n


def states_seen(harvest_log, log_file):
    """The controller states HARVEST_STATUS went through, in order, each change once."""
    r = subprocess.run([str(harvest_log), "export", str(log_file), "HARVEST_STATUS", "--format", "jsonl",
                        "--fields", "state"], capture_output=True, text=True)
    seen = []
    for line in r.stdout.splitlines():
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue
        s = row.get("state")
        if s is not None and (not seen or seen[-1] != s):
            seen.append(s)
    return seen


def controller_fault(output):
    """The first FAULT the servo controller logged, or None."""
    for line in output.read_text(errors="replace").splitlines():
        if "FAULT: " in line:
            return line.split("FAULT: ", 1)[1]
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="measured time after START [s] (default 20)")
    ap.add_argument("--out", type=Path, help="folder for the log, process outputs and latency.json "
                    "(default logs/bench/latency-<time>)")
    ap.add_argument("--build-dir", type=Path, default=Path(os.environ.get("HARVEST_BUILD_DIR", ROOT / "build")))
    ap.add_argument("--frames-from", type=Path, default=ROOT / "logs/exp1-lcm-logger.lcmlog",
                    help="a log whose CAMERA_FIXED and CAMERA_HAND frames the cameras loop over "
                    "(default: the simulator's experiment I reference log)")
    ap.add_argument("--rate", type=float, default=30.0, help="frame rate of each camera [Hz]")
    ap.add_argument("--width", type=int, default=320, help="published frame width [px] (the simulator's)")
    ap.add_argument("--height", type=int, default=240, help="published frame height [px]")
    ap.add_argument("--tick-period-ms", type=float, default=20.0,
                    help="the controller's tick_period_s in ms (config/servo/controller.yaml)")
    ap.add_argument("--realtime", type=int, default=0, metavar="PRIO",
                    help="SCHED_FIFO priority for the robot link (control.realtime_priority, as on the robot "
                    "computer) and the simulated drives (chrt; hardware in the field); 0: normal scheduling. "
                    "On a loaded machine a starved link or drive misses the 25 ms RPDO deadline and the arm faults")
    ap.add_argument("--set", action="append", default=[], metavar="PROCESS:KEY=VALUE",
                    help="a configuration override for one process (camera-fixed, servo-controller, ...)")
    args = ap.parse_args()
    # A SIGTERM (a test's timeout) unwinds through the finally below, which stops every process it started.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))

    bin_dir = (args.build_dir if args.build_dir.is_absolute() else ROOT / args.build_dir) / "bin"
    harvest_log = bin_dir / "harvest-log"
    out = args.out or ROOT / "logs/bench" / time.strftime("latency-%Y%m%d-%H%M%S")
    out = out if out.is_absolute() else Path.cwd() / out
    out.mkdir(parents=True, exist_ok=True)
    url = f"udpm://239.255.76.67:{free_udp_port()}?ttl=0"
    bus = f"udp_multicast:239.74.163.2:{free_udp_port()}?ttl=0"
    overrides = {}
    for s in args.set:
        proc, _, kv = s.partition(":")
        overrides.setdefault(proc, []).extend(["--set", kv])

    frames = Path(tempfile.mkdtemp(prefix="latency-frames-"))
    counts = {cam: extract_frames(harvest_log, args.frames_from, ch, frames / cam)
              for cam, ch in (("fixed", "CAMERA_FIXED"), ("hand", "CAMERA_HAND"))}
    log(f"LCM {url}, CAN {bus}; frames from {args.frames_from.name}: {counts['fixed']} fixed, {counts['hand']} hand")

    common = ["--lcm-url", url, "--no-netcheck"]
    procs = Processes(out)
    load_before = os.getloadavg()
    log_file = out / "latency.lcmlog"
    try:
        procs.start("logger", ["lcm-logger", "-f", f"--lcm-url={url}", str(log_file)])
        chrt = ["chrt", "-f", str(args.realtime)] if args.realtime > 0 else []
        procs.start("sim-drives", [*chrt, str(bin_dir / "harvest-sim-drives"), *common, "--config",
                                   "config/arm/sim_drives.yaml", "--set", f"bus={bus}"])
        time.sleep(0.3)
        procs.start("robot-link", [str(bin_dir / "harvest-robot-link"), *common, "--config",
                                   "config/arm/robot_link.yaml", "--set", f"bus={bus}", "--set",
                                   f"control.realtime_priority={args.realtime}",
                                   *overrides.get("robot-link", [])])
        for cam in ("fixed", "hand"):
            procs.start(f"detector-{cam}", [str(bin_dir / "harvest-fruit-detector"), *common, "--instance",
                                            f"detector-{cam}", "--config", f"config/vision/detector-{cam}.yaml",
                                            *overrides.get(f"detector-{cam}", [])])
        procs.start("reconstructor", [str(bin_dir / "harvest-reconstructor"), *common, "--config",
                                      "config/vision/reconstructor.yaml", *overrides.get("reconstructor", [])])
        procs.start("servo-controller", [str(bin_dir / "harvest-servo-controller"), *common, "--config",
                                         "config/servo/controller.yaml", *overrides.get("servo-controller", [])])
        time.sleep(1.0)
        for cam in ("fixed", "hand"):
            procs.start(f"camera-{cam}", [str(bin_dir / "harvest-camera"), *common, "--instance", f"camera-{cam}",
                                          "--config", f"config/vision/camera-{cam}.yaml", "--set", "source=folder",
                                          "--set", f"path={frames / cam}", "--set", "loop=true", "--set",
                                          f"frame_rate_hz={args.rate}", "--set", "encoding=jpeg",
                                          "--set", f"output_width={args.width}", "--set", f"output_height={args.height}",
                                          *overrides.get(f"camera-{cam}", [])])
        # START once the arm is enabled and the controller has the fixed camera's targets: retried, the
        # controller refuses it while the robot state is stale.
        started = False
        deadline = time.monotonic() + 30.0
        while not started and time.monotonic() < deadline:
            if procs.dead():
                break
            time.sleep(1.0)
            r = subprocess.run([str(bin_dir / "harvest-operator"), "--lcm-url", url, "start", "--timeout", "2"],
                               capture_output=True, text=True)
            started = r.returncode == 0
            if not started:
                log(f"START not acknowledged yet: {(r.stdout + r.stderr).strip().splitlines()[-1:]}")
        if not started:
            raise RuntimeError(f"the servo controller never acknowledged START; exited: {procs.dead()}")
        log(f"started; measuring {args.seconds:.0f} s")
        cpu_start, t_start = procs.cpu_seconds(), time.monotonic()
        t_end = t_start + args.seconds
        while time.monotonic() < t_end:
            time.sleep(0.2)
            if procs.dead():
                raise RuntimeError(f"a process ended during the run: {procs.dead()} (outputs in {out})")
        cpu_end, wall = procs.cpu_seconds(), time.monotonic() - t_start
        cpu = {n: cpu_end[n] - cpu_start[n] for n in cpu_end if n in cpu_start}
    finally:
        procs.stop_all()
        load_after = os.getloadavg()
        for f in frames.glob("*/*.bmp"):
            f.unlink()
        for d in frames.iterdir():
            d.rmdir()
        frames.rmdir()

    json_file = out / "latency.json"
    r = subprocess.run([str(harvest_log), "latency", str(log_file), "--json", str(json_file), "--command-period-ms",
                        str(args.tick_period_ms)],
                       capture_output=True, text=True)
    print(r.stdout, end="")
    if r.returncode != 0:
        sys.exit(f"latency-bench: harvest-log latency failed: {r.stderr.strip()}")
    report = json.loads(json_file.read_text())
    report["bench"] = {
        "seconds": args.seconds,
        "camera_rate_hz": args.rate,
        "frames_from": str(args.frames_from),
        "lcm_url": url,
        "can_bus": bus,
        "cpus": os.cpu_count(),
        "loadavg_before": load_before,
        "loadavg_after": load_after,
        "controller_states": states_seen(harvest_log, log_file),
        "controller_fault": controller_fault(out / "servo-controller.txt"),
        "realtime_priority": args.realtime,
        # CPU time each process used during the measured time: what our processing costs, apart from the wait
        # for a CPU that the wall-clock stages include on a shared machine.
        "cpu_percent_of_one_core": {n: round(100.0 * c / wall, 1) for n, c in sorted(cpu.items())},
        "cpu_ms_per_frame": {n: round(1000.0 * c / (wall * args.rate), 3) for n, c in sorted(cpu.items())
                             if n.startswith(("camera-", "detector-"))},
    }
    json_file.write_text(json.dumps(report, indent=2) + "\n")
    print(f"controller states: {' -> '.join(map(str, report['bench']['controller_states']))}")
    print(f"load average (1/5/15 min) before {load_before[0]:.2f}/{load_before[1]:.2f}/{load_before[2]:.2f}, "
          f"after {load_after[0]:.2f}/{load_after[1]:.2f}/{load_after[2]:.2f} on {os.cpu_count()} CPUs")
    print("CPU during the measured time (% of one core): " +
          ", ".join(f"{n} {v}" for n, v in report["bench"]["cpu_percent_of_one_core"].items()))
    print("CPU per frame [ms]: " + ", ".join(f"{n} {v}" for n, v in report["bench"]["cpu_ms_per_frame"].items()))
    for root, c in sorted(report.get("chains", {}).items()):
        e = c["end_to_end"]
        p = c.get("own_processing", c["upstream_processing"])
        print(f"{root}: {c['commanded']} of {c['frames']} frames used by a command; frame -> command "
              f"p50 {e['p50_ms']} / p99 {e['p99_ms']} / max {e['max_ms']} ms; own processing without the wait "
              f"for the controller's tick p50 {p['p50_ms']} / p99 {p['p99_ms']} / max {p['max_ms']} ms")
    if report["bench"]["controller_fault"]:
        print(f"WARNING: the controller faulted during the run ({report['bench']['controller_fault'][:160]}...): "
              f"its commands after that are STOPs")
    print(f"wrote {json_file} and {log_file}")
    if not report.get("chains"):
        sys.exit("latency-bench: no command traced back to a camera frame")


if __name__ == "__main__":
    main()
