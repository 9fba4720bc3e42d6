#!/usr/bin/python3
"""The operator console in a real browser (docs/console.md).

Starts the simulated process set (config/sets/sim.yaml, experiment I) on a
private LCM URL (TTL 0), its own virtual CAN bus and board port, and
harvest-console; headless Chromium loads the page, sees the processes, clicks
Start, sees the controller acknowledge it and a fruit picked, presses the
e-stop and sees it acknowledged and the arm stopped. A request the console
does not know is refused on screen and sends nothing. Screenshots and the
processes' output are left in $HARVEST_ARTEFACTS. Every process this test
starts is stopped by its PID.
"""
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
import unittest

import yaml

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By

SRC = os.environ.get("HARVEST_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "../../.."))
BIN = os.environ.get("HARVEST_BIN_DIR", os.path.join(SRC, "build/bin"))
ART = os.environ.get("HARVEST_ARTEFACTS", os.path.join(SRC, "build/artefacts/console"))


def free_port(kind):
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def stop(proc, sig, timeout):
    """Stops one process this test started, by its PID."""
    if proc is None or proc.poll() is not None:
        return
    os.kill(proc.pid, sig)
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()


class ConsoleBrowser(unittest.TestCase):
    def setUp(self):
        os.makedirs(ART, exist_ok=True)
        for f in os.listdir(ART):
            os.remove(os.path.join(ART, f))
        self.lcm_url = "udpm://239.255.76.67:%d?ttl=0" % free_port(socket.SOCK_DGRAM)
        can_bus = "udp_multicast:239.74.163.2:%d?ttl=0" % free_port(socket.SOCK_DGRAM)
        board_port = free_port(socket.SOCK_STREAM)
        self.http = "127.0.0.1:%d" % free_port(socket.SOCK_STREAM)
        self.launch_out = open(os.path.join(ART, "launch.log"), "w")
        self.console_log = os.path.join(ART, "console.log")
        self.console_out = open(self.console_log, "w")
        # Experiment I with room for a person's pace: its 40 s limit counts from the simulator's start.
        with open(os.path.join(SRC, "config/scenarios/experiment1.yaml")) as f:
            scenario = yaml.safe_load(f)
        scenario["time_limit_s"] = 150
        scenario_path = os.path.join(ART, "experiment1-console.yaml")
        with open(scenario_path, "w") as f:
            yaml.safe_dump(scenario, f)
        with open(os.path.join(SRC, "config/sets/sim.yaml")) as f:
            process_set = yaml.safe_load(f)
        # The copy lives in the artefacts: its relative paths made absolute, as harvest-demo's copy.
        process_set["site"] = os.path.join(SRC, "config/site/sim.yaml")
        process_set["recording"]["folder"] = ART
        for p in process_set["processes"]:
            p["cwd"] = SRC
            if p["name"] == "sim":
                p["args"] += ["--set", "scenario=" + scenario_path]
        set_path = os.path.join(ART, "set.yaml")
        with open(set_path, "w") as f:
            yaml.safe_dump(process_set, f)
        self.launcher = None
        self.set_path = set_path
        self.launch_args = (can_bus, board_port)
        self.console = subprocess.Popen(
            [os.path.join(BIN, "harvest-console"), "--listen", self.http, "--lcm-url", self.lcm_url,
             "--stats-s", "5"], cwd=SRC, stdout=self.console_out, stderr=subprocess.STDOUT)
        self.driver = None
        options = webdriver.ChromeOptions()
        options.binary_location = "/usr/bin/chromium"
        for a in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
                  "--window-size=1500,1300"):
            options.add_argument(a)
        self.driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)

    def start_set(self):
        # Started once the browser is up, so Chromium's start-up (CPU on 2 shared cores) does not overlap the
        # simulated drives being enabled (they missed the link's first PDO deadlines when it did).
        self.launcher = subprocess.Popen(
            [os.path.join(BIN, "harvest-launch"), self.set_path, "--exit-with", "sim", "--no-table",
             "--bin-dir", BIN, "--lcm-url", self.lcm_url, "--set", "site.can_bus=" + self.launch_args[0],
             "--set", "site.board_port=%d" % self.launch_args[1]],
            cwd=SRC, stdout=self.launch_out, stderr=subprocess.STDOUT)

    def tearDown(self):
        if self.driver is not None:
            self.driver.quit()
        stop(self.console, signal.SIGTERM, 10)
        stop(self.launcher, signal.SIGTERM, 30)
        self.launch_out.close()
        self.console_out.close()

    def shot(self, name):
        self.driver.save_screenshot(os.path.join(ART, name + ".png"))

    def text(self, element_id):
        return self.driver.find_element(By.ID, element_id).text

    def wait_for(self, what, predicate, timeout):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.assertTrue(self.launcher is None or self.launcher.poll() is None, "the set ended early (see %s/launch.log)" % ART)
            self.assertIsNone(self.console.poll(), "harvest-console exited (see %s)" % self.console_log)
            value = predicate()
            if value:
                return value
            time.sleep(0.2)
        self.shot("timeout")
        self.fail("%s not seen within %.0f s; page: ack=%r state=%r arm=%r %r" %
                  (what, timeout, self.text("ack"), self.text("h-state"), self.text("r-mode"),
                   self.text("r-fault")[:300]))

    def console_output(self):
        with open(self.console_log) as f:
            return f.read()

    def sent_lines(self):
        return [line for line in self.console_output().splitlines() if " sent " in line or "FAILED to send" in line]

    def test_start_pick_estop(self):
        d = self.driver
        self.wait_for("the console serving", lambda: "serving" in self.console_output(), 10)
        d.get("http://%s/" % self.http)
        self.wait_for("the page connected", lambda: self.text("link") == "live", 10)
        self.start_set()

        # Every process of the set, each healthy, and the controller's state.
        expected = {"sim", "robot-link", "ee-bridge", "detector-fixed", "detector-hand", "reconstructor",
                    "servo-controller"}

        # On a loaded machine the simulated drives can miss the link's first deadlines and the link latches a
        # fault (robot-link ERROR, arm FAULT); an operator presses Reset fault, and so does this test.
        resets = []

        def instances_ok():
            if self.text("r-mode") == "FAULT" and len(resets) < 3 and \
                    (not resets or time.monotonic() - resets[-1] > 5):
                print("arm in FAULT before start (%s): pressing Reset fault" % self.text("r-fault")[:120])
                d.find_element(By.ID, "btn-reset-fault").click()
                resets.append(time.monotonic())
            # Read in one script: the table is redrawn 5 times a second.
            ok = d.execute_script("""
                return [...document.querySelectorAll('#proc-table tbody tr')]
                    .filter(r => r.children[4].textContent === 'OK').map(r => r.dataset.instance);""")
            return expected <= set(ok) and self.text("r-mode") == "IDLE"
        self.wait_for("every process OK and the arm IDLE", instances_ok, 60)
        self.wait_for("the controller's state", lambda: self.text("h-state") == "IDLE", 30)
        self.shot("01-processes")
        self.assertEqual(len(self.sent_lines()), len(resets),
                         "the console sent something before a button was pressed: %s" % self.sent_lines())

        # A request the console does not know: refused on screen, nothing sent.
        d.execute_script("socket.send(JSON.stringify({command: 'launch'}))")
        self.wait_for("the bad request refused", lambda: "unknown command" in self.text("ack"), 5)
        self.assertEqual(len(self.sent_lines()), len(resets))

        # Start: the controller refuses until it has the arm's state; an operator presses again.
        def started():
            ack = d.find_element(By.ID, "ack")
            if ack.get_attribute("data-verb") == "start" and ack.get_attribute("data-state") == "accepted":
                return True
            if ack.get_attribute("data-state") in (None, "refused", "no reply", "failed") or \
                    ack.get_attribute("data-verb") != "start":
                d.find_element(By.ID, "btn-start").click()
                time.sleep(1.0)
            return False
        self.wait_for("start acknowledged", started, 40)
        self.assertIn("started by", self.text("ack"))
        self.wait_for("the state change", lambda: self.text("h-state") not in ("IDLE", ""), 10)
        self.shot("02-started")

        # Both camera streams reach the page.
        for cam in ("fixed", "hand"):
            self.wait_for(cam + " camera frames", lambda: d.execute_script(
                "return document.getElementById('img-%s').naturalWidth" % cam) > 0, 10)

        # The page shows the arm moving (its speed from ROBOT_STATE), then a fruit picked.
        speeds = []

        def picked():
            speed = self.text("r-speed")
            if speed not in ("–", ""):
                speeds.append(float(speed))
            return self.text("h-picked") not in ("–", "0")
        self.wait_for("a fruit picked", picked, 120)
        print("arm speed on the page before the e-stop: up to %.3f m/s" % max(speeds))
        self.assertGreater(max(speeds), 0.01)
        self.shot("03-picked")

        d.find_element(By.ID, "estop").click()
        self.wait_for("e-stop acknowledged", lambda: d.find_element(By.ID, "ack").get_attribute("data-verb") ==
                      "estop" and d.find_element(By.ID, "ack").get_attribute("data-state") == "accepted", 5)
        self.assertIn("E-STOP", self.text("h-flags"))
        self.wait_for("the robot link latched the e-stop", lambda: self.text("r-mode") == "ESTOP", 5)

        def arm_stopped():
            speed = self.text("r-speed")
            return speed not in ("–", "") and float(speed) < 0.002
        self.wait_for("the arm stopped", arm_stopped, 5)
        self.shot("04-estop")
        print("arm after e-stop: mode %s, speed %s m/s" % (self.text("r-mode"), self.text("r-speed")))
        sent = self.sent_lines()
        self.assertTrue(all(re.search(r"sent (reset-fault|start|estop) as", s) for s in sent), sent)
        self.assertTrue(any("sent estop" in s for s in sent))

        # The console's own CPU share while both 30 Hz cameras ran (its --stats-s lines).
        stats = [line for line in self.console_output().splitlines() if "% of a core" in line]
        for line in stats:
            print(line)
        self.assertTrue(stats, "no CPU report from the console")


if __name__ == "__main__":
    unittest.main(verbosity=2)
