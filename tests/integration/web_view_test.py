#!/usr/bin/python3
"""The web view in a real browser: headless Chromium driven by Selenium against motion-web on a
simulated lab (config/sim-lab.yaml) that this test starts on its own LCM URL and simulation folder.

Checks: the page loads (Chart.js served locally) and logs no error, the axis table shows every configured axis and
updates during a move (issued with motionctl), an event appears in the event list, the move's plot
exists with data points for the moved axis. Saves a screenshot (--artifacts/web.png) and prints its
path.

Exit codes: 0 passed, 1 failed, 77 skipped (chromium or chromedriver not installed; ctest
SKIP_RETURN_CODE). Every process it starts (the lab, motion-web, chromedriver and the browser
processes under it) is killed by pid at the end, whatever happened.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support", "python"))
from motion_testproc import Failure, kill_pid, unique_lcm_url, wait_for  # noqa: E402

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
SKIP = 77
MOVED_AXIS = "x"  # the axis whose row and plot are checked
TARGET = 40.0     # user units, inside x's limits in config/sim-lab.yaml
OTHER = ("y", 25.0)  # moved with it, so the plot shows a synchronized move


def start_time(pid):
    """The start time of process `pid` (/proc/PID/stat field 22), None when there is none."""
    try:
        with open("/proc/%d/stat" % pid) as f:
            stat = f.read()
    except OSError:
        return None
    return int(stat[stat.rindex(")") + 2:].split()[19])


def descendants(pid):
    """(pid, start time) of every process under `pid` (from /proc), parents before their children."""
    parents = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open("/proc/%s/stat" % entry) as f:
                stat = f.read()
        except OSError:
            continue
        ppid = int(stat[stat.rindex(")") + 2:].split()[1])
        parents.setdefault(ppid, []).append(int(entry))
    out, todo = [], [pid]
    while todo:
        for child in parents.get(todo.pop(), []):
            out.append((child, start_time(child)))
            todo.append(child)
    return out


class Lab:
    """The simulated lab and motion-web as child processes with logs in `work`."""

    def __init__(self, args, work):
        self.args, self.work = args, work
        self.url = unique_lcm_url(3)
        self.env = dict(os.environ, MOTION_SIM_DIR=os.path.join(work, "sim"), LCM_DEFAULT_URL=self.url)
        self.procs = {}  # name -> Popen

    def program(self, name):
        return os.path.join(self.args.bin, name)

    def start(self, name, program, *extra):
        log = open(os.path.join(self.work, name.replace(":", "-") + ".log"), "wb")
        cmd = [self.program(program), "--config", self.args.config, "--lcm-url", self.url, *extra]
        self.procs[name] = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=self.env)
        log.close()

    def ctl(self, *argv, timeout=30):
        cmd = [self.program("motionctl"), "--config", self.args.config, "--lcm-url", self.url, *argv]
        done = subprocess.run(cmd, capture_output=True, text=True, env=self.env, timeout=timeout)
        if done.returncode != 0:
            raise Failure("motionctl %s: exit %d\n%s%s" % (" ".join(argv), done.returncode, done.stdout, done.stderr))
        return done.stdout

    def ctl_start(self, name, *argv):
        """motionctl in the background (killed with the lab unless it ended); returns its Popen."""
        cmd = [self.program("motionctl"), "--config", self.args.config, "--lcm-url", self.url, *argv]
        self.procs[name] = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=self.env)
        return self.procs[name]

    def log(self, name):
        try:
            with open(os.path.join(self.work, name.replace(":", "-") + ".log"), errors="replace") as f:
                return f.read()
        except OSError:
            return ""

    def web_url(self):
        for line in self.log("web").splitlines():
            if line.startswith("motion-web: serving "):
                return line.split()[-1]
        if self.procs["web"].poll() is not None:
            raise Failure("motion-web exited with %s:\n%s" % (self.procs["web"].returncode, self.log("web")))
        return None

    def up(self):
        buses = self.ctl("config", "buses").split()
        self.start("sim", "motion-sim")
        for bus in buses:
            self.start("gateway:" + bus, "motion-gateway", "--bus", bus)
        self.start("coordinator", "motion-coordinator")
        self.start("web", "motion-web", "--listen", "127.0.0.1:0")
        expect = ["sim", "coordinator", "web"] + ["gateway:" + b for b in buses]
        self.ctl("health", "--listen", "20", *[a for name in expect for a in ("--expect", name)], timeout=40)
        axes = json.loads(self.ctl("--json", "status", "--listen", "0.5"))
        wait_for("every axis online", lambda: all(a.get("online") for a in json.loads(self.ctl("--json", "status", "--listen", "0.5")).values()),
                 timeout=20, period=0)
        return sorted(axes), wait_for("motion-web's address", self.web_url, timeout=10)

    def down(self):
        for proc in self.procs.values():
            if proc.poll() is None:  # a pid already reaped may belong to another process by now
                kill_pid(proc.pid)

    def print_logs(self):
        for name in self.procs:
            print("----- log of %s -----\n%s" % (name, self.log(name)[-4000:]))


def open_browser(work):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1500,1400",
                 "--user-data-dir=" + os.path.join(work, "chromium")):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})  # the page's console, checked for errors
    service = Service(executable_path=CHROMEDRIVER, log_path=os.path.join(work, "chromedriver.log"))
    return webdriver.Chrome(service=service, options=options)


def run(args, lab, work, browser_pids):
    axes, url = lab.up()
    print("lab up: axes %s, web view at %s" % (" ".join(axes), url))
    driver = open_browser(work)
    browser_pids.append((driver.service.process.pid, start_time(driver.service.process.pid)))
    try:
        driver.set_script_timeout(10)
        driver.get(url)
        js = driver.execute_script
        if not js("return typeof Chart === 'function'"):
            raise Failure("Chart.js did not load from %svendor/chart.min.js" % url)
        wait_for("the axis table to show every configured axis with a state",
                 lambda: js("return [...document.querySelectorAll('#axes tbody tr')]"
                            ".filter(r => Number(r.dataset.updates) > 0).map(r => r.dataset.axis).sort()") == axes, timeout=10)
        wait_for("a heartbeat of motion-web in the process table",
                 lambda: js("return !!document.querySelector('#processes tr[data-process=\"web\"]')"), timeout=5)
        row = "document.querySelector('#axes tr[data-axis=\"%s\"]')" % MOVED_AXIS
        before = js("return [Number(%s.dataset.updates), %s.querySelector('.position').textContent]" % (row, row))
        events_before = js("return document.querySelectorAll('#events li').length")

        # A drive of a loaded machine's simulated lab may drop offline for a moment (its gateway
        # retries it): enabling is retried until it is done.
        def enabled():
            try:
                return lab.ctl("enable", MOVED_AXIS, OTHER[0]) or True
            except Failure as e:
                print("retrying: %s" % str(e).splitlines()[0])
                return None
        wait_for("%s and %s enabled" % (MOVED_AXIS, OTHER[0]), enabled, timeout=20, period=0.5)
        # The row while the move runs: the positions it shows with the axis moving.
        move = lab.ctl_start("motionctl move", "move", "--wait", "%s=%g" % (MOVED_AXIS, TARGET), "%s=%g" % OTHER)
        moving_positions = set()
        deadline = time.monotonic() + 40
        while move.poll() is None and time.monotonic() < deadline:
            state, position = js("return [%s.querySelector('.state').textContent, %s.querySelector('.position').textContent]" % (row, row))
            if "moving" in state:
                moving_positions.add(float(position.split()[0]))
            time.sleep(0.03)
        output, _ = move.communicate(timeout=5)
        if move.returncode != 0:
            raise Failure("motionctl move: exit %s\n%s" % (move.returncode, output))
        between = sorted(p for p in moving_positions if 0 < p < TARGET)
        if not between:
            raise Failure("the %s row never showed the axis moving between 0 and %g (seen while moving: %s)" % (MOVED_AXIS, TARGET, sorted(moving_positions)))

        def at_target():
            shown = js("return [Number(%s.dataset.updates), %s.querySelector('.position').textContent]" % (row, row))
            return shown if abs(float(shown[1].split()[0]) - TARGET) < 0.01 else None
        after = wait_for("the %s row to show the new position %g" % (MOVED_AXIS, TARGET), at_target, timeout=10)
        if after[0] <= before[0]:
            raise Failure("the %s row did not update during the move (updates %d -> %d)" % (MOVED_AXIS, before[0], after[0]))
        events = wait_for("an event in the event list",
                          lambda: js("return document.querySelectorAll('#events li').length") or None, timeout=10)
        plot = wait_for("the move's plot with data points of %s" % MOVED_AXIS, lambda: js("""
            const card = [...document.querySelectorAll('#moves .move')].find(c => c.dataset.status === 'done');
            if (!card) return null;
            const chart = Chart.getChart(card.querySelector('canvas'));
            const sets = Object.fromEntries(chart.data.datasets.map(d => [d.label, d.data.length]));
            return sets[arguments[0] + ' position'] > 3 ? {id: card.dataset.moveId, sets} : null;
        """, MOVED_AXIS), timeout=10)
        print("axis %s: %d updates during the test, %d positions shown while moving, then %s; %d events (%d before the move); "
              "plot of move %s: %s" % (MOVED_AXIS, after[0] - before[0], len(between), after[1], events, events_before, plot["id"], plot["sets"]))
        if plot["sets"].get("%s target" % MOVED_AXIS, 0) == 0:
            raise Failure("the move's plot has no target line for %s: %s" % (MOVED_AXIS, plot["sets"]))

        errors = [e["message"] for e in driver.get_log("browser") if e.get("level") == "SEVERE"]
        if errors:
            raise Failure("the page logged errors:\n  " + "\n  ".join(errors))

        os.makedirs(args.artifacts, exist_ok=True)
        shot = os.path.join(args.artifacts, "web.png")
        time.sleep(0.5)  # one more redraw of the page (200 ms period) with the last samples
        driver.save_screenshot(shot)
        print("screenshot: %s" % shot)
    finally:
        browser_pids.extend(descendants(driver.service.process.pid))
        driver.quit()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bin", required=True, help="folder of the motion-* programs and motionctl")
    parser.add_argument("--config", required=True, help="the lab's configuration (config/sim-lab.yaml)")
    parser.add_argument("--artifacts", required=True, help="folder for the screenshot")
    args = parser.parse_args()

    missing = [p for p in (CHROMIUM, CHROMEDRIVER) if not os.access(p, os.X_OK)]
    if missing:
        print("SKIP: %s not installed (apt-get install chromium chromium-driver)" % " and ".join(missing))
        return SKIP
    try:
        import selenium  # noqa: F401
    except ImportError:
        print("FAIL: python3-selenium is not installed for /usr/bin/python3 (apt-get install python3-selenium)")
        return 1

    work = tempfile.mkdtemp(prefix="motion-web-test-")
    lab = Lab(args, work)
    browser_pids = []
    started = time.monotonic()
    try:
        run(args, lab, work, browser_pids)
        print("PASS in %.1f s" % (time.monotonic() - started))
        return 0
    except Exception as e:  # every failure ends in the same report and clean-up
        print("FAIL: %s: %s" % (type(e).__name__, e))
        lab.print_logs()
        return 1
    finally:
        # Children first; a pid whose start time changed is another process by now.
        for pid, started_at in reversed(browser_pids):
            if started_at is not None and start_time(pid) == started_at:
                kill_pid(pid, grace=1.0)
        lab.down()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
