#!/usr/bin/python3
"""The live operator console (--console) in headless Chromium, driven by
Selenium through chromedriver: a campaign watched on the embedded rig, a
trip's banner (an injected fault on the embedded rig, and a rig's own
emergency stop over Modbus in real time), the stop button (with and
without the token), and clients that misbehave while a run goes on.

Usage: console_browser_test.py KCRIG ARTIFACT_DIR [TEST_NAME...]
(ctest runs the real-time test apart, alone.)
"""
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import unittest
import urllib.error
import urllib.request

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By

KCRIG = sys.argv[1] if len(sys.argv) > 1 else "build/bin/kcrig"
ARTIFACTS = sys.argv[2] if len(sys.argv) > 2 else tempfile.mkdtemp()


class Kcrig:
    """A kcrig command with --console: its URL, its output as it comes."""

    def __init__(self, args):
        self.proc = subprocess.Popen(
            [KCRIG] + args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            text=True, start_new_session=True)
        self.lines = []
        self.url = None
        self.found = threading.Event()
        threading.Thread(target=self._read, daemon=True).start()
        if not self.found.wait(30):
            self.proc.kill()
            raise AssertionError("no console URL: " + "".join(self.lines))

    def _read(self):
        for line in self.proc.stdout:
            self.lines.append(line)
            match = re.search(r"console at (http://\S+)", line)
            if match and self.url is None:
                self.url = match.group(1)
                self.found.set()
        self.found.set()

    @property
    def base(self):
        return self.url.split("?")[0].rstrip("/")

    @property
    def token(self):
        return self.url.split("token=")[1]

    def wait(self, timeout=120):
        code = self.proc.wait(timeout)
        time.sleep(0.2)  # the reader's last lines
        return code

    def output(self):
        return "".join(self.lines)


def rss_kib(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def flood(host, port, chunks):
    """Sends `chunks`; whether the server closed the connection (not a
    timeout of ours), and the bytes it took."""
    sent = 0
    with socket.create_connection((host, port)) as s:
        s.settimeout(5)
        try:
            for chunk in chunks:
                s.sendall(chunk)
                sent += len(chunk)
            # All sent: the answer (a refusal) or the close comes now.
            while s.recv(1 << 16):
                pass
            return True, sent
        except socket.timeout:
            return False, sent
        except OSError:  # reset or broken pipe: closed by the server
            return True, sent


def browser():
    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for argument in ["--headless=new", "--no-sandbox", "--disable-gpu",
                     "--disable-dev-shm-usage", "--window-size=1500,1900",
                     "--hide-scrollbars"]:
        options.add_argument(argument)
    return webdriver.Chrome(service=Service("/usr/bin/chromedriver"),
                            options=options)


def data(driver, name):
    return driver.execute_script(
        "return document.body.dataset[arguments[0]] ?? null;", name)


def until(predicate, timeout, what, step=0.05):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = predicate()
        if value:
            return value
        time.sleep(step)
    raise AssertionError("timed out waiting for " + what)


def request(url, method="GET", headers=None):
    req = urllib.request.Request(url, method=method, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=10) as reply:
            return reply.status, reply.read()
    except urllib.error.HTTPError as error:
        return error.code, error.read()


class ConsoleTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="kcrig_console_")
        self.driver = None
        self.kcrig = None

    def tearDown(self):
        if self.driver is not None:
            self.driver.quit()
        if self.kcrig is not None and self.kcrig.proc.poll() is None:
            os.killpg(self.kcrig.proc.pid, 9)
        shutil.rmtree(self.dir, ignore_errors=True)

    def open(self, kcrig):
        if self.driver is None:
            self.driver = browser()
        self.driver.get(kcrig.url)
        until(lambda: data(self.driver, "connected"), 20, "the stream")

    def test_campaign_is_watched_as_it_runs(self):
        out = os.path.join(self.dir, "campaign")
        # Chromium first: on a loaded machine it takes longer to start than
        # a paced run lasts, and the page must see a run from its lead-in.
        self.driver = browser()
        self.kcrig = Kcrig(["campaign", "--rig", "sim", "--iterations", "1",
                            "--budget", "12", "--console", "127.0.0.1:0",
                            "--out", out, "--quiet"])
        self.open(self.kcrig)
        d = self.driver
        until(lambda: data(d, "drawn") and int(data(d, "drawn")) > 0, 20,
              "the first drawing")
        first = d.get_screenshot_as_png()
        values = data(d, "lastValues")
        phases = {data(d, "phase")}
        # New values reach the page as the run goes (on a loaded machine
        # the run may stand still for a while: waited for, not slept).
        until(lambda: data(d, "lastValues") != values, 30, "new values")
        second = d.get_screenshot_as_png()
        self.assertNotEqual(first, second)
        with open(os.path.join(ARTIFACTS, "console_screenshot.png"),
                  "wb") as f:
            f.write(second)
        # Phases advance; iteration 0's estimates land while iteration 1's
        # run still goes.
        seen_iteration_at_run = None
        shot = False
        end = time.monotonic() + 300  # a loaded machine estimates slowly
        while time.monotonic() < end:
            phases.add(data(d, "phase"))
            if data(d, "iterations") == "1" and seen_iteration_at_run is None:
                seen_iteration_at_run = (data(d, "run"), data(d, "runEnd"),
                                         self.kcrig.proc.poll())
            # Iteration 1's run half-way, iteration 0's estimates shown.
            if (seen_iteration_at_run and not shot and
                    data(d, "phase") == "ramp" and
                    float(data(d, "t") or 0) > 4.0):
                shot = True
                with open(os.path.join(ARTIFACTS,
                                       "console_campaign_screenshot.png"),
                          "wb") as f:
                    f.write(d.get_screenshot_as_png())
            if data(d, "ended"):
                break
            time.sleep(0.05)
        self.assertEqual(self.kcrig.wait(), 0, self.kcrig.output())
        self.assertIsNotNone(seen_iteration_at_run, "iteration 0 never shown")
        self.assertIsNone(seen_iteration_at_run[2],
                          "iteration 0 shown only after the campaign ended")
        # The page's own record: a poll under load can miss a short phase.
        shown = (data(d, "phasesShown") or "").split()
        self.assertTrue({"lead_in", "ramp", "ramp_down"} <= set(shown),
                        (shown, phases))
        self.assertTrue(phases - {None} <= set(shown), (shown, phases))
        self.assertEqual(data(d, "iterations"), "2")
        table = d.find_element(By.ID, "iterations").text
        self.assertIn("c_O1", table)
        self.assertIn("N/mm", table)
        self.assertTrue(data(d, "report").endswith("report.html"))
        self.assertEqual(data(d, "error"), None)
        self.assertIn("completed", data(d, "ended") or "",
                      "the end never reached the page (stream: %s)" %
                      d.find_element(By.ID, "connection").text)

    def test_trip_banner_within_half_a_second(self):
        log = os.path.join(self.dir, "trip")
        # At 10 s of a 22.7 s run: the page is open long before.
        self.kcrig = Kcrig(["run", "--rig", "sim", "--duration", "20",
                            "--inject", "silent:at=10000", "--console", "0",
                            "--log-dir", log, "--quiet"])
        self.open(self.kcrig)
        d = self.driver
        self.assertIsNone(data(d, "trip"), "tripped before the page opened")
        until(lambda: data(d, "trip"), 30, "the trip banner", step=0.01)
        latency = float(data(d, "tripShownAt")) - float(data(d, "tripSeenAt"))
        banner = d.find_element(By.ID, "trip").text
        print("trip banner %.0f ms after the logger saw it: %s" %
              (latency, banner))
        self.assertEqual(data(d, "trip"), "watchdog")
        self.assertIn("watchdog", banner)
        self.assertLessEqual(latency, 500)
        self.assertEqual(self.kcrig.wait(), 3, self.kcrig.output())
        with open(os.path.join(ARTIFACTS, "console_trip_screenshot.png"),
                  "wb") as f:
            f.write(d.get_screenshot_as_png())

    def test_a_rigs_emergency_stop_is_on_the_page_within_half_a_second(self):
        # The real loop over Modbus TCP in real time: the rig's e-stop
        # (SIGUSR1 to kcrig emulate) to the banner, end to end.
        log = os.path.join(self.dir, "estop")
        emulator = subprocess.Popen(
            [KCRIG, "emulate", "--modbus-tcp", "127.0.0.1:0"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            start_new_session=True)
        try:
            uri = re.search(r"(modbus-tcp://\S+)",
                            emulator.stdout.readline()).group(1)
            self.kcrig = Kcrig(["run", "--rig", uri, "--duration", "20",
                                "--console", "0", "--log-dir", log,
                                "--quiet"])
            self.open(self.kcrig)
            d = self.driver
            until(lambda: data(d, "phase") == "ramp", 20, "the ramp")
            pressed = time.time() * 1000
            emulator.send_signal(signal.SIGUSR1)
            until(lambda: data(d, "trip"), 10, "the trip banner", step=0.01)
            latency = float(data(d, "tripShownAt")) - pressed
            print("rig e-stop to the banner: %.0f ms" % latency)
            self.assertEqual(data(d, "trip"), "rig_fault")
            self.assertIn("emergency stop",
                          d.find_element(By.ID, "trip").text)
            self.assertLessEqual(latency, 500)
            self.assertEqual(self.kcrig.wait(60), 3, self.kcrig.output())
        finally:
            emulator.terminate()
            emulator.wait(10)

    def test_stop_needs_the_token_and_ramps_down(self):
        log = os.path.join(self.dir, "stop")
        self.kcrig = Kcrig(["run", "--rig", "sim", "--duration", "20",
                            "--console", "0", "--log-dir", log, "--quiet"])
        k = self.kcrig
        for url, headers in [(k.base + "/stop", {}),
                             (k.base + "/stop?token=" + "0" * 64, {}),
                             (k.base + "/stop", {"X-Kcrig-Token": "wrong"})]:
            status, _ = request(url, "POST", headers)
            self.assertEqual(status, 403, url)
        self.open(k)
        d = self.driver
        until(lambda: data(d, "phase") == "ramp", 20, "the ramp")
        self.assertIsNone(k.proc.poll(), "a refused stop stopped the run")
        d.find_element(By.ID, "stop").click()
        self.assertEqual(k.wait(60), 3, k.output())
        self.assertIn("signal (SIGINT)", k.output())
        until(lambda: data(d, "trip") == "signal", 5, "the stop's banner")
        self.assertTrue(os.path.exists(os.path.join(log, "run.csv")))
        with open(os.path.join(log, "run.json")) as f:
            hil = json.load(f)["hil"]
        self.assertEqual(hil["safety"]["cause"], "signal", hil)
        self.assertLess(hil["cycles"], 22700, hil)

    def test_misbehaving_clients_do_not_disturb_the_run(self):
        log = os.path.join(self.dir, "hostile")
        # A 30 s ramp: 32.7 s of run, long enough to see a stall dropped.
        self.kcrig = Kcrig(["run", "--rig", "sim", "--console", "0",
                            "--duration", "30", "--log-dir", log, "--quiet"])
        k = self.kcrig
        host, port = k.base[len("http://"):].split(":")
        port = int(port)
        # Heads without end, before any token is checked: the console
        # closes each after its 8 KiB limit, the process's memory flat.
        before = rss_kib(k.proc.pid)
        for chunks in ([b"GET /"] + [b"a" * 65536] * 800,
                       [b"GET / HTTP/1.1\r\n"] + [b"X-A: b\r\n"] * 100000,
                       [b"GET /?token=x HTTP/1.1\r\nRange: bytes=" +
                        b"0-0," * 3000 + b"0-0\r\n\r\n"]):
            closed, taken = flood(host, port, chunks)
            self.assertTrue(closed, "a flood of %d bytes was not refused" %
                            taken)
            self.assertLess(taken, 16 << 20)
        time.sleep(1)
        self.assertLess(rss_kib(k.proc.pid) - before, 20 << 10)
        for path in ["/", "/events", "/../../etc/passwd", "/stop"]:
            status, _ = request(k.base + path)
            self.assertEqual(status, 403, path)
        status, _ = request(k.base + "/stop", "OPTIONS", {
            "Origin": "http://evil.example",
            "Access-Control-Request-Method": "POST"})
        self.assertEqual(status, 403, "a CORS preflight")
        for path in ["/etc/passwd", "/run.csv", "/../run.json", "/events/x"]:
            status, _ = request(k.base + path + "?token=" + k.token)
            self.assertEqual(status, 404, path)
        # 50 connections that send nothing, three malformed requests and a
        # stream that is never read (a small window).
        idle = [socket.create_connection((host, port)) for _ in range(50)]
        stalled = socket.socket()
        stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        stalled.connect((host, port))
        stalled.sendall(("GET /events?token=%s HTTP/1.1\r\nHost: x\r\n\r\n"
                         % k.token).encode())
        opened = time.monotonic()
        for garbage in [b"\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03",
                        b"GET / HTTP/1.1\r\n" + b"X: " + b"a" * 100000,
                        b"BREW /coffee HTCPCP/1.0\r\n\r\n"]:
            s = socket.create_connection((host, port))
            s.sendall(garbage)
            s.close()
        # Never read for 15 s, the stream has been dropped (the console
        # closed it) while the run goes on: what it holds is read within
        # 2 s, a kept stream would go on after it.
        time.sleep(max(0.0, 15 - (time.monotonic() - opened)))
        stalled.settimeout(0.5)
        dropped = False
        drain_end = time.monotonic() + 2
        try:
            while time.monotonic() < drain_end and not dropped:
                dropped = stalled.recv(1 << 16) == b""
        except socket.timeout:
            dropped = False
        except OSError:
            dropped = True
        self.assertIsNone(k.proc.poll(), "the run ended before the check")
        self.assertTrue(dropped, "a stream never read was kept open")
        for s in idle + [stalled]:
            s.close()
        # Eight viewers at most, each answered; a ninth is refused.
        streams = []
        for _ in range(8):
            s = socket.create_connection((host, port))
            s.sendall(("GET /events?token=%s HTTP/1.1\r\nHost: x\r\n\r\n"
                       % k.token).encode())
            s.settimeout(10)
            self.assertTrue(s.recv(12).startswith(b"HTTP/1.1 200"))
            streams.append(s)
        status, _ = request(k.base + "/events?token=" + k.token)
        self.assertEqual(status, 503)
        for s in streams:
            s.close()
        # A well-behaved viewer still gets the run.
        self.open(k)
        d = self.driver
        until(lambda: data(d, "updates") and int(data(d, "updates")) > 3, 30,
              "updates beside the misbehaving clients")
        self.assertEqual(k.wait(60), 0, k.output())
        with open(os.path.join(log, "run.json")) as f:
            hil = json.load(f)["hil"]
        self.assertEqual(hil["cycles"], 32700, hil)
        self.assertEqual(hil["overruns"], 0, hil)
        self.assertEqual(hil["dropped_log_records"], 0, hil)

if __name__ == "__main__":
    os.makedirs(ARTIFACTS, exist_ok=True)
    unittest.main(argv=sys.argv[:1] + ["ConsoleTest." + name
                                       for name in sys.argv[3:]],
                  verbosity=2)
