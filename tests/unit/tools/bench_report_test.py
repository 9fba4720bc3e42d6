"""tools/bench_report.py: pairs BM_<job>_<impl> benchmarks, ratios, targets."""
import json
import os
import subprocess
import sys
import tempfile
import unittest

SCRIPT = os.path.join(os.environ.get("HARVEST_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "../../..")),
                      "tools", "bench_report.py")


def entry(run_name, cpu, unit="ms", aggregate="median", **counters):
    e = {"name": f"{run_name}_{aggregate}", "run_name": run_name, "run_type": "aggregate",
         "aggregate_name": aggregate, "cpu_time": cpu, "real_time": cpu * 3, "time_unit": unit}
    e.update(counters)
    return e


def run(benchmarks):
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "out.json")
        with open(path, "w") as f:
            json.dump({"benchmarks": benchmarks}, f)
        p = subprocess.run([sys.executable, SCRIPT, path], capture_output=True, text=True)
        return p.returncode, p.stdout


class BenchReport(unittest.TestCase):
    def test_pairs_by_job_and_args_with_medians_and_targets(self):
        rc, out = run([
            entry("BM_PyrLK_Ours/100/7", 0.25, target_ratio=1.0),
            entry("BM_PyrLK_Ours/100/7", 9.0, aggregate="mean", target_ratio=1.0),  # not the median: ignored
            entry("BM_PyrLK_OpenCV/100/7", 0.50),
            entry("BM_PyrLK_OpenCV/200/7", 0.10),  # no Ours with these args: no line
            entry("BM_Homography_Ours/8", 12.0, unit="us", target_ratio=1.0),
            entry("BM_Homography_OpenCV/8", 200.0, unit="us"),
            entry("BM_Homography_ViSP/8", 24.0, unit="us"),
            entry("BM_Match_Ours/1", 2.5, target_ms=5.0),
        ])
        self.assertEqual(rc, 0, out)
        lines = out.splitlines()[1:]
        self.assertEqual(len(lines), 4, out)
        self.assertRegex(lines[0], r"^PyrLK/100/7 .*OpenCV .* 0\.50x  target <= 1\.00x  ok$")
        self.assertRegex(lines[1], r"^Homography/8 .*OpenCV .* 0\.06x .*ok$")
        self.assertRegex(lines[2], r"^Homography/8 .*ViSP .* 0\.50x .*ok$")
        self.assertRegex(lines[3], r"^Match/1 .*target <= 5 ms  ok$")

    def test_a_missed_target_is_said_and_fails(self):
        rc, out = run([entry("BM_ShiTomasi_Ours", 7.0, target_ratio=1.0), entry("BM_ShiTomasi_OpenCV", 6.0)])
        self.assertEqual(rc, 1)
        self.assertIn("1.17x  target <= 1.00x  MISSED", out)
        rc, out = run([entry("BM_Match_Ours/1", 6.0, target_ms=5.0)])
        self.assertEqual(rc, 1)
        self.assertIn("target <= 5 ms  MISSED", out)

    def test_no_pairs_is_an_error(self):
        rc, _ = run([entry("BM_Render/0/0", 3.0)])
        self.assertEqual(rc, 1)


if __name__ == "__main__":
    unittest.main()
