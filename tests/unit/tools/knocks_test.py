"""tools/knocks.py: which fruit the gripper knocked off, and how (finger beside, finger early, palm)."""
import os
import subprocess
import sys
import unittest

SOURCE = os.environ.get("HARVEST_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "../../.."))
sys.path.insert(0, os.path.join(SOURCE, "tools"))
import knocks  # noqa: E402


def truth_row(utime, fruits):
    """A SIM_TRUTH row with the tool at the origin looking along base z; fruits: (sim_id, state, xyz m, attempts)."""
    m = {"log_utime": utime, "num_fruits": len(fruits)}
    m.update({f"tool_pose.position[{i}]": 0.0 for i in range(3)})
    m.update({f"tool_pose.orientation[{i}]": v for i, v in enumerate((1.0, 0.0, 0.0, 0.0))})
    for q, (sid, state, p, attempts) in enumerate(fruits):
        m[f"fruits[{q}].sim_id"] = sid
        m[f"fruits[{q}].state"] = state
        m[f"fruits[{q}].diameter_m"] = 0.07
        m[f"fruits[{q}].grasp_attempts"] = attempts
        m.update({f"fruits[{q}].position_base[{i}]": p[i] for i in range(3)})
    return m


class Knocks(unittest.TestCase):
    def test_each_kind_once_with_the_note_before_it(self):
        beside, early, palm, held = (0.03, 0.0, 0.01), (0.005, 0.0, 0.05), (0.0, 0.01, -0.03), (0.0, 0.0, 0.01)
        on = [(1, 0, beside, 0), (2, 0, early, 0), (3, 0, palm, 0), (4, 0, held, 0)]
        truth = [truth_row(1_000_000, on),
                 truth_row(2_000_000, [(1, 3, beside, 1), (2, 0, early, 0), (3, 0, palm, 0), (4, 1, held, 1)]),
                 truth_row(3_000_000, [(1, 3, beside, 1), (2, 3, early, 1), (3, 3, palm, 0), (4, 2, held, 1)]),
                 truth_row(4_000_000, [(1, 3, beside, 1), (2, 3, early, 1), (3, 3, palm, 0), (4, 2, held, 1)])]
        status = [{"log_utime": 1_500_000, "state": "GRASP", "summary": "GRASP fruit 7 | picked 0 | closing"},
                  {"log_utime": 2_500_000, "state": "IR_APPROACH",
                   "summary": "IR_APPROACH fruit 8 | picked 0 | IR at 33 mm, fruit 300 mm ahead: past a leaf"}]
        found = knocks.knocks(truth, status)
        self.assertEqual([(f["sim_id"], f["how"]) for f in found],
                         [(1, "finger, beside"), (2, "finger, early"), (3, "palm")])
        self.assertAlmostEqual(found[0]["lat"], 30.0, places=6)
        self.assertAlmostEqual(found[1]["ax"], 50.0, places=6)
        self.assertEqual((found[0]["t"], found[0]["state"], found[0]["note"]), (1.0, "GRASP", "closing"))
        self.assertEqual(knocks.summary(found),
                         "3 knocked off: 1 finger, beside, 1 finger, early, 1 palm (1 of the palm's going on past a leaf)")
        # A wider capture range ahead: the early close is a close beside.
        self.assertEqual(knocks.knocks(truth, status, axial_max_mm=60.0)[1]["how"], "finger, beside")

    def test_the_reference_pick_knocks_nothing_off(self):
        hl = os.environ.get("HARVEST_LOG_BIN")
        if not hl:
            self.skipTest("HARVEST_LOG_BIN not set")
        p = subprocess.run([sys.executable, os.path.join(SOURCE, "tools", "knocks.py"),
                            os.path.join(SOURCE, "logs", "exp1-harvest.lcmlog"), "--harvest-log", hl],
                           capture_output=True, text=True)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertEqual(p.stdout.strip().splitlines()[-1],
                         "0 knocked off: 0 finger, beside, 0 finger, early, 0 palm (0 of the palm's going on past a leaf)")


if __name__ == "__main__":
    unittest.main()
