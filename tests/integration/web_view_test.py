#!/usr/bin/python3
"""The web view in a real browser: headless Chromium driven by Selenium against motion-web on a
simulated lab (config/sim-lab.yaml with security enforced, as tools/demo runs it) that this test
starts on its own LCM URL and simulation folder; the page's commands are signed with the web view's
own key (role operate).

Checks: the page loads (Chart.js served locally) and logs no error, the axis table shows every
configured axis; opened without the access token the page has no controls and motion-web refuses a
command sent over its WebSocket; opened at the address `motion-web --controls` printed, the page
enables two axes and moves them (its buttons), the table updates during the move and shows the
target after it, the move's plot exists with data points and its target line, an event appears;
then a jog started from the page is stopped by its E-STOP button and the axis stays where it
stopped. Saves a screenshot (--artifacts/web.png) and prints its path.

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
        self.config = args.config

    def secure(self):
        """Security enforced, as tools/demo runs the lab: the coordinator's key pair, the gateways'
        key (role gateway) and the web view's own key (role operate), which its page's commands are
        signed with."""
        keys = os.path.join(self.work, "keys")
        for name, role in (("coordinator", "admin"), ("gateway", "gateway"), ("web", "operate")):
            self.ctl("keygen", "--out", keys, "--name", name, "--role", role)
        with open(os.path.join(keys, "authorized_keys"), "w") as out:
            for name in ("web", "gateway"):
                with open(os.path.join(keys, name + ".pub")) as pub:
                    out.write(pub.read())
        self.config = os.path.join(self.work, "lab.yaml")
        key = lambda name: os.path.join(keys, name)
        with open(self.args.config) as base, open(self.config, "w") as out:
            out.write(base.read() + "\nsecurity:\n  mode: enforce\n  authorized_keys: %s\n  key: %s\n"
                      "  coordinator_public_key: %s\n  gateway_key: %s\n"
                      % (key("authorized_keys"), key("coordinator.key"), key("coordinator.pub"), key("gateway.key")))
        return os.path.join(keys, "web.key")

    def program(self, name):
        return os.path.join(self.args.bin, name)

    def start(self, name, program, *extra):
        log = open(os.path.join(self.work, name.replace(":", "-") + ".log"), "wb")
        cmd = [self.program(program), "--config", self.config, "--lcm-url", self.url, *extra]
        self.procs[name] = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=self.env)
        log.close()

    def ctl(self, *argv, timeout=30):
        cmd = [self.program("motionctl"), "--config", self.config, "--lcm-url", self.url, *argv]
        done = subprocess.run(cmd, capture_output=True, text=True, env=self.env, timeout=timeout)
        if done.returncode != 0:
            raise Failure("motionctl %s: exit %d\n%s%s" % (" ".join(argv), done.returncode, done.stdout, done.stderr))
        return done.stdout

    def log(self, name):
        try:
            with open(os.path.join(self.work, name.replace(":", "-") + ".log"), errors="replace") as f:
                return f.read()
        except OSError:
            return ""

    def web_url(self, what="serving"):
        for line in self.log("web").splitlines():
            if line.startswith("motion-web: %s " % what):
                return line.split()[-1]
        if self.procs["web"].poll() is not None:
            raise Failure("motion-web exited with %s:\n%s" % (self.procs["web"].returncode, self.log("web")))
        return None

    def up(self):
        web_key = self.secure()
        buses = self.ctl("config", "buses").split()
        self.start("sim", "motion-sim")
        for bus in buses:
            self.start("gateway:" + bus, "motion-gateway", "--bus", bus)
        self.start("coordinator", "motion-coordinator")
        self.start("web", "motion-web", "--listen", "127.0.0.1:0", "--controls", "--key", web_key)
        expect = ["sim", "coordinator", "web"] + ["gateway:" + b for b in buses]
        self.ctl("health", "--listen", "20", *[a for name in expect for a in ("--expect", name)], timeout=40)
        axes = json.loads(self.ctl("--json", "status", "--listen", "0.5"))
        wait_for("every axis online", lambda: all(a.get("online") for a in json.loads(self.ctl("--json", "status", "--listen", "0.5")).values()),
                 timeout=20, period=0)
        return (sorted(axes), wait_for("motion-web's address", self.web_url, timeout=10),
                wait_for("motion-web's controls address", lambda: self.web_url("controls at"), timeout=10))

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
    axes, url, controls_url = lab.up()
    print("lab up: axes %s, web view at %s" % (" ".join(axes), url))
    if "?token=" not in controls_url or not controls_url.startswith(url):
        raise Failure("motion-web --controls printed '%s', not %s?token=..." % (controls_url, url))
    driver = open_browser(work)
    browser_pids.append((driver.service.process.pid, start_time(driver.service.process.pid)))
    try:
        driver.set_script_timeout(10)
        js = driver.execute_script

        # Without the token: no controls on the page, and motion-web refuses a command sent anyway.
        driver.get(url)
        if not js("return typeof Chart === 'function'"):
            raise Failure("Chart.js did not load from %svendor/chart.min.js" % url)
        wait_for("the axis table to show every configured axis with a state",
                 lambda: js("return [...document.querySelectorAll('#axes tbody tr')]"
                            ".filter(r => Number(r.dataset.updates) > 0).map(r => r.dataset.axis).sort()") == axes, timeout=10)
        if not js("return document.getElementById('controls-section').hidden"):
            raise Failure("the page opened without the access token shows its controls")
        forged = driver.execute_async_script("""
            const done = arguments[arguments.length - 1];
            const ws = new WebSocket(`ws://${location.host}/ws`);
            ws.onopen = () => ws.send(JSON.stringify({type: 'command', token: 'guessed', tag: 99, kind: 'MOVE_ABSOLUTE',
                                                      axes: ['x'], values: [100]}));
            ws.onmessage = (m) => { const r = JSON.parse(m.data); if (r.type === 'command_result') { ws.close(); done(r); } };
        """)
        if forged.get("ok") is not False or "access token" not in forged.get("error", "") or forged.get("tag") != 99:
            raise Failure("a command with a wrong token was not refused for it: %s" % forged)

        driver.get(controls_url)
        wait_for("the controls and the axis table",
                 lambda: not js("return document.getElementById('controls-section').hidden") and
                 js("return [...document.querySelectorAll('#axes tbody tr')].filter(r => Number(r.dataset.updates) > 0).length") == len(axes),
                 timeout=10)
        wait_for("a heartbeat of motion-web in the process table",
                 lambda: js("return !!document.querySelector('#processes tr[data-process=\"web\"]')"), timeout=5)
        row = "document.querySelector('#axes tr[data-axis=\"%s\"]')" % MOVED_AXIS
        before = js("return [Number(%s.dataset.updates), %s.querySelector('.position').textContent]" % (row, row))
        events_before = js("return document.querySelectorAll('#events li').length")

        def command(kind, values, timeout):
            """Ticks the axes of `values` (only those), types their values, clicks `kind`'s button and
            waits for the request's terminal status; returns (status, request id)."""
            js("""
                const values = arguments[0];
                for (const label of document.querySelectorAll('#control-axes label')) {
                  const axis = label.dataset.axis;
                  label.querySelector('.pick').checked = axis in values;
                  if (axis in values) label.querySelector('.value').value = String(values[axis]);
                }
                document.querySelector(`#controls-section button[data-kind="${arguments[1]}"]`).click();
            """, values, kind)
            def ended():
                line = js("const l = document.getElementById('control-status'); return [l.dataset.status, l.dataset.request, l.textContent]")
                return line if line[0] in ("done", "rejected", "aborted", "failed", "refused") else None
            status, request, text = wait_for("%s from the page to end" % kind, ended, timeout=timeout)
            print("page: %s" % text)
            return status, request, text

        # A drive of a loaded machine's simulated lab may drop offline for a moment (its gateway
        # retries it): enabling is retried until it is done.
        wait_for("%s and %s enabled from the page" % (MOVED_AXIS, OTHER[0]),
                 lambda: command("ENABLE", {MOVED_AXIS: 0, OTHER[0]: 0}, 15)[0] == "done" or None, timeout=40, period=0.5)
        # The move, from the page; the row while it runs: the positions it shows with the axis moving.
        js("""
            window.moving_positions = [];
            const row = document.querySelector('#axes tr[data-axis="%s"]');
            window.watcher = setInterval(() => {
              if (row.querySelector('.state').textContent.includes('moving')) {
                window.moving_positions.push(parseFloat(row.querySelector('.position').textContent));
              }
            }, 20);
        """ % MOVED_AXIS)
        status, move_id, text = command("MOVE_ABSOLUTE", {MOVED_AXIS: TARGET, OTHER[0]: OTHER[1]}, 40)
        if status != "done":
            raise Failure("the move from the page ended %s: %s" % (status, text))
        moving_positions = js("clearInterval(window.watcher); return window.moving_positions")
        between = sorted(p for p in moving_positions if 0 < p < TARGET)
        if not between:
            raise Failure("the %s row never showed the axis moving between 0 and %g (seen while moving: %s)" % (MOVED_AXIS, TARGET, sorted(set(moving_positions))))

        def at_target():
            shown = js("return [Number(%s.dataset.updates), %s.querySelector('.position').textContent]" % (row, row))
            return shown if abs(float(shown[1].split()[0]) - TARGET) < 0.01 else None
        after = wait_for("the %s row to show the new position %g" % (MOVED_AXIS, TARGET), at_target, timeout=10)
        if after[0] <= before[0]:
            raise Failure("the %s row did not update during the move (updates %d -> %d)" % (MOVED_AXIS, before[0], after[0]))
        events = wait_for("an event in the event list",
                          lambda: js("return document.querySelectorAll('#events li').length") or None, timeout=10)
        plot = wait_for("the move's plot with data points of %s" % MOVED_AXIS, lambda: js("""
            const card = document.querySelector(`#moves .move[data-move-id="${arguments[1]}"]`);
            if (!card || card.dataset.status !== 'done') return null;
            const chart = Chart.getChart(card.querySelector('canvas'));
            const sets = Object.fromEntries(chart.data.datasets.map(d => [d.label, d.data.length]));
            return sets[arguments[0] + ' position'] > 3 ? {id: card.dataset.moveId, sets,
                predicted: window.motionWeb.moves[arguments[1]].predicted_duration_s} : null;
        """, MOVED_AXIS, move_id), timeout=10)
        print("axis %s: %d updates during the test, %d positions shown while moving, then %s; %d events (%d before the move); "
              "plot of move %s: %s, planned duration %s s" % (MOVED_AXIS, after[0] - before[0], len(between), after[1], events, events_before,
                                                              plot["id"], plot["sets"], plot["predicted"]))
        if plot["sets"].get("%s target" % MOVED_AXIS, 0) == 0:
            raise Failure("the move's plot has no target line for %s: %s" % (MOVED_AXIS, plot["sets"]))
        if not plot["predicted"] or plot["predicted"] <= 0:
            raise Failure("the move has no planned duration for its planned-arrival mark: %s" % plot)

        # A jog from the page, stopped by the page's E-STOP.
        js("""
            for (const label of document.querySelectorAll('#control-axes label')) {
              label.querySelector('.pick').checked = label.dataset.axis === arguments[0];
              if (label.dataset.axis === arguments[0]) label.querySelector('.value').value = '20';
            }
            document.querySelector('#controls-section button[data-kind="JOG"]').click();
        """, MOVED_AXIS)
        wait_for("%s jogging" % MOVED_AXIS, lambda: "moving" in js("return %s.querySelector('.state').textContent" % row), timeout=10)
        jog_id = wait_for("the jog's request id", lambda: js("return document.getElementById('control-status').dataset.request") or None, timeout=5)
        time.sleep(0.3)
        status, _, text = command("ESTOP", {}, 10)
        if status != "done":
            raise Failure("E-STOP from the page ended %s: %s" % (status, text))
        wait_for("%s standing after the e-stop" % MOVED_AXIS,
                 lambda: "moving" not in js("return %s.querySelector('.state').textContent" % row), timeout=5)
        stopped_at = float(js("return %s.querySelector('.position').textContent" % row).split()[0])
        jog_status = wait_for("the jog's terminal reply", lambda: js("""
            const r = window.motionWeb.requests[arguments[0]];
            return r && ['done', 'rejected', 'aborted', 'failed'].includes(r.status) ? r.status : null;""", jog_id), timeout=5)
        jog_plot = wait_for("the jog's plot following x until it stood", lambda: js("""
            const move = window.motionWeb.moves[arguments[0]];
            return move && !move.open && (move.samples[arguments[1]] || []).length > 3 ? move.samples[arguments[1]].length : null;
        """, jog_id, MOVED_AXIS), timeout=5)
        time.sleep(0.5)
        still = float(js("return %s.querySelector('.position').textContent" % row).split()[0])
        print("jog %s ended %s (its plot: %d samples); %s stopped at %.4f, %.4f 0.5 s later" % (jog_id, jog_status, jog_plot, MOVED_AXIS, stopped_at, still))
        if not (TARGET < stopped_at < 300) or abs(still - stopped_at) > 1e-3:
            raise Failure("after the e-stop %s should stand between %g and 300: at %.4f, then %.4f" % (MOVED_AXIS, TARGET, stopped_at, still))

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
