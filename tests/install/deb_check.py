#!/usr/bin/python3
"""The Debian package as an administrator uses it (tools/package --check), on this machine:

  - `dpkg -i` installs it (its dependencies must already be installed);
  - `dpkg -L motionbus` lists every artefact a lab machine needs: the programs, systemd units and
    sysusers entry, /etc/motionbus (as conffiles), the configurations, web page and Chart.js, LCM
    type definitions and the Python, Lua and Java bindings, bash completion, LICENSE; every listed
    file exists, and the motionbus system user was created;
  - `systemd-analyze verify` accepts the installed units;
  - the installed programs, started from a folder outside the source tree, run the simulated lab of
    the installed sim-lab.yaml: every process heartbeats, and a move of x is DONE at its target;
  - `dpkg --purge motionbus` removes every file it installed and /etc/motionbus.

It installs system-wide: root only, and it refuses to run when motionbus is already installed.
Every process it starts is killed by pid.
  deb_check.py DEB
"""

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import Failure, Processes, unique_lcm_url  # noqa: E402

PROGRAMS = ["motion-coordinator", "motion-gateway", "motion-sim", "motion-web", "motionctl"]
UNITS = ["motion-coordinator.service", "motion-gateway@.service", "motion-sim.service", "motion-web.service", "motionbus.target"]
ARTEFACTS = ["/usr/bin/" + p for p in PROGRAMS] + ["/usr/lib/systemd/system/" + u for u in UNITS] + [
    "/usr/lib/sysusers.d/motionbus.conf", "/etc/motionbus/lab.yaml", "/etc/motionbus/motion.env",
    "/usr/share/motionbus/config/sim-lab.yaml", "/usr/share/motionbus/config/examples/hardware.yaml",
    "/usr/share/motion/web/index.html", "/usr/share/motion/web/app.js", "/usr/share/motion/web/vendor/chart.min.js",
    "/usr/share/motionbus/lcmtypes/request_t.lcm", "/usr/lib/python3/dist-packages/motionlcm/request_t.py",
    "/usr/share/lua/5.2/motionlcm/request_t.lua", "/usr/share/java/motionlcm.jar",
    "/usr/share/bash-completion/completions/motionctl", "/usr/share/doc/motionbus/LICENSE",
]
SIM_LAB = "/usr/share/motionbus/config/sim-lab.yaml"


def run(cmd, env=None, timeout=120, check=True, cwd=None):
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout, cwd=cwd)
    if check and done.returncode != 0:
        raise Failure("%s: exit %d\n%s%s" % (" ".join(cmd), done.returncode, done.stdout, done.stderr))
    return done


def installed():
    return run(["dpkg-query", "-W", "-f=${Status}", "motionbus"], check=False).stdout.strip() == "install ok installed"


def check_listing():
    listed = set(run(["dpkg", "-L", "motionbus"]).stdout.split())
    missing = [a for a in ARTEFACTS if a not in listed]
    if missing:
        raise Failure("dpkg -L motionbus does not list: " + ", ".join(missing))
    absent = [p for p in listed if not os.path.lexists(p)]
    if absent:
        raise Failure("listed by dpkg -L but not on disk: " + ", ".join(sorted(absent)[:10]))
    conffiles = run(["dpkg-query", "-W", "-f=${Conffiles}", "motionbus"]).stdout
    for conf in ["/etc/motionbus/lab.yaml", "/etc/motionbus/motion.env"]:
        if conf not in conffiles:
            raise Failure("%s is not a conffile (an upgrade would overwrite the administrator's edits):\n%s" % (conf, conffiles))
    if run(["getent", "passwd", "motionbus"], check=False).returncode != 0:
        raise Failure("the package did not create the motionbus system user (postinst)")
    print("dpkg -L: %d paths, every artefact listed and on disk; conffiles and the motionbus user in place" % len(listed))
    return listed


def check_units(work):
    units = os.path.join(work, "units")
    os.makedirs(units)
    for unit in UNITS:
        shutil.copy(os.path.join("/usr/lib/systemd/system", unit), os.path.join(units, unit.replace("@.", "@can0.")))
    names = ["./" + u.replace("@.", "@can0.") for u in UNITS]
    done = run(["systemd-analyze", "verify", "--man=no"] + names, check=False, cwd=units)
    out = (done.stdout + done.stderr).strip()
    if done.returncode != 0 or out:
        raise Failure("systemd-analyze verify of the installed units:\n%s" % out)
    print("systemd-analyze verify: %d installed units accepted" % len(UNITS))


def check_lab(work, procs):
    url = unique_lcm_url(41)
    env = dict(os.environ, MOTION_SIM_DIR=os.path.join(work, "sim"), LCM_DEFAULT_URL=url)
    env.pop("MOTION_CONFIG", None)
    common = ["--config", SIM_LAB, "--lcm-url", url]

    def ctl(*words, timeout=60):
        return run(["/usr/bin/motionctl"] + common + list(words), env=env, timeout=timeout, cwd=work)

    buses = ctl("config", "buses").stdout.split()
    logs = {}

    def start(name, program, *words):
        logs[name] = open(os.path.join(work, name + ".log"), "w")
        procs.add(subprocess.Popen(["/usr/bin/" + program] + common + list(words), env=env, cwd=work, stdout=logs[name],
                                   stderr=subprocess.STDOUT))

    start("sim", "motion-sim")
    for bus in buses:
        start("gateway-" + bus, "motion-gateway", "--bus", bus)
    start("coordinator", "motion-coordinator")
    expect = ["sim", "coordinator"] + ["gateway:" + b for b in buses]
    try:
        ctl("health", "--listen", "20", *[w for name in expect for w in ("--expect", name)])
        # The drives come online as their gateways set them up: retry the enable for a while.
        for attempt in range(20):
            done = run(["/usr/bin/motionctl"] + common + ["enable", "x"], env=env, check=False, cwd=work)
            if done.returncode == 0:
                break
            time.sleep(0.5)
        else:
            raise Failure("enable x never succeeded:\n%s%s" % (done.stdout, done.stderr))
        result = json.loads(ctl("--json", "move", "--wait", "x=5").stdout)
        if result["status"].upper() != "DONE" or abs(result["axes"]["x"]["position"] - 5.0) > 1e-3:
            raise Failure("the move on the installed lab: %s" % result)
    except Failure:
        for name in logs:
            logs[name].flush()
            with open(os.path.join(work, name + ".log")) as f:
                sys.stderr.write("----- %s -----\n%s\n" % (name, f.read()[-3000:]))
        raise
    finally:
        procs.close()
        for f in logs.values():
            f.close()
    print("installed programs (cwd %s, no source tree): %d processes heartbeat, move x=5 DONE" % (work, len(expect)))


def main():
    if len(sys.argv) != 2:
        print(__doc__.strip().splitlines()[-1])
        return 2
    deb = os.path.abspath(sys.argv[1])
    if os.geteuid() != 0:
        print("deb_check: installs the package system-wide; run it as root (a throwaway machine or container)", file=sys.stderr)
        return 2
    if installed():
        print("deb_check: motionbus is already installed here; the check installs and purges it, so remove it first", file=sys.stderr)
        return 2
    procs = Processes()
    work = tempfile.mkdtemp(prefix="motion-deb-")
    try:
        run(["dpkg", "-i", deb])
        print("dpkg -i %s: installed" % os.path.basename(deb))
        listed = check_listing()
        check_units(work)
        check_lab(work, procs)
        run(["dpkg", "--purge", "motionbus"])
        left = [p for p in listed if os.path.isfile(p) or os.path.islink(p)]
        if installed() or left or os.path.exists("/etc/motionbus"):
            raise Failure("dpkg --purge left: %s" % ", ".join((left + (["/etc/motionbus"] if os.path.exists("/etc/motionbus") else []))[:10]))
        print("dpkg --purge: every installed file and /etc/motionbus removed")
        print("deb checks passed")
        return 0
    except Failure as e:
        print("deb_check: FAILED: %s" % e, file=sys.stderr)
        return 1
    finally:
        procs.close()
        if installed():
            run(["dpkg", "--purge", "motionbus"], check=False)
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
