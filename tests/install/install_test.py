#!/usr/bin/python3
"""`cmake --install` of the build tree into a temporary prefix (and once more through DESTDIR), and
the installed programs run from there (cmake/MotionPackage.cmake):

  - the files a lab machine needs are there: programs, web page and Chart.js, LCM type definitions
    and their Python/Lua/Java bindings, configurations (share/ and etc/motionbus/), systemd units
    whose ExecStart= and /etc paths name this prefix, sysusers, bash completion, LICENSE;
  - every installed program answers --version (the project's version) and --help;
  - installed motionctl defaults to the installed sim-lab.yaml (not the source tree's) and
    validates the etc/motionbus/lab.yaml example; the installed Python types import;
  - the installed motion-web, on a free port with a tiny configuration, serves its page and
    Chart.js from share/motion/web;
  - `systemd-analyze verify` accepts the installed units (motion-web.service included);
  - the installed bash completion completes subcommands, axis names and bus names.

Every process is killed by pid at the end.
  install_test.py --build BUILD --cmake CMAKE --version X.Y.Z --lcm-types N
"""

import argparse
import glob
import os
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import Failure, Processes, unique_lcm_url, write_tiny_config  # noqa: E402

PROGRAMS = ["motion-gateway", "motion-coordinator", "motion-sim", "motion-web", "motionctl"]
UNITS = ["motion-gateway@.service", "motion-coordinator.service", "motion-web.service", "motion-sim.service", "motionbus.target"]


def run(cmd, env=None, timeout=60, check=True):
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout)
    if check and done.returncode != 0:
        raise Failure("%s: exit %d\n%s%s" % (" ".join(cmd), done.returncode, done.stdout, done.stderr))
    return done


def expect_files(prefix, paths):
    missing = [p for p in paths if not glob.glob(os.path.join(prefix, p))]
    if missing:
        raise Failure("not installed under %s: %s" % (prefix, ", ".join(missing)))


def check_layout(args, prefix):
    expect_files(prefix, ["bin/" + p for p in PROGRAMS] + [
        "share/motion/web/index.html", "share/motion/web/app.js", "share/motion/web/vendor/chart.min.js",
        "share/motionbus/config/sim-lab.yaml", "share/motionbus/config/motion.env",
        "share/motionbus/config/examples/hardware.yaml", "etc/motionbus/lab.yaml", "etc/motionbus/motion.env",
        "lib/python3*/dist-packages/motionlcm/request_t.py", "share/lua/5.2/motionlcm/request_t.lua",
        "include/motionlcm/request_t.hpp", "lib/sysusers.d/motionbus.conf",
        "share/bash-completion/completions/motionctl", "share/doc/motionbus/LICENSE", "share/doc/motionbus/README.md",
    ] + ["lib/systemd/system/" + u for u in UNITS])
    if args.jar:
        expect_files(prefix, ["share/java/motionlcm.jar"])
    types = glob.glob(os.path.join(prefix, "share/motionbus/lcmtypes/*.lcm"))
    if len(types) != args.lcm_types:
        raise Failure("%d LCM type definitions installed, the source has %d" % (len(types), args.lcm_types))


def check_units(prefix, unit_prefix):
    """ExecStart= names the installed programs, /etc paths the installed etc/motionbus (the files
    are under `prefix`, which is `unit_prefix` or DESTDIR + `unit_prefix`)."""
    etc = unit_prefix + "/etc/motionbus"
    for unit in UNITS[:4]:
        with open(os.path.join(prefix, "lib/systemd/system", unit)) as f:
            text = f.read()
        program = unit.split("@")[0].split(".")[0]
        if "ExecStart=%s/bin/%s " % (unit_prefix, program) not in text:
            raise Failure("%s: ExecStart= does not name %s/bin/%s:\n%s" % (unit, unit_prefix, program, text))
        if "/usr/local/" in text and unit_prefix != "/usr/local":
            raise Failure("%s: still names /usr/local/:\n%s" % (unit, text))
        if "EnvironmentFile=-%s/motion.env" % etc not in text or "Type=notify" not in text:
            raise Failure("%s: no EnvironmentFile=-%s/motion.env or no Type=notify:\n%s" % (unit, etc, text))
    with open(os.path.join(prefix, "etc/motionbus/motion.env")) as f:
        env = f.read()
    if "MOTION_CONFIG=%s/lab.yaml" % etc not in env:
        raise Failure("etc/motionbus/motion.env does not name %s/lab.yaml:\n%s" % (etc, env))


def check_programs(args, prefix):
    for program in PROGRAMS:
        path = os.path.join(prefix, "bin", program)
        version = run([path, "--version"]).stdout.strip()
        if version != args.version:
            raise Failure("%s --version printed %r, expected %r" % (program, version, args.version))
        usage = run([path, "--help"]).stdout
        if "--config" not in usage or "--log-level" not in usage:
            raise Failure("%s --help lacks the common options:\n%s" % (program, usage))
    env = {k: v for k, v in os.environ.items() if k != "MOTION_CONFIG"}
    ctl = os.path.join(prefix, "bin", "motionctl")
    out = run([ctl, "config"], env=env).stdout
    expected = os.path.join(prefix, "share/motionbus/config/sim-lab.yaml")
    if not out.startswith(expected + ": valid"):
        raise Failure("installed motionctl does not default to %s:\n%s" % (expected, out))
    out = run([ctl, "--config", os.path.join(prefix, "etc/motionbus/lab.yaml"), "config", "buses"], env=env).stdout.split()
    if "can0" not in out:
        raise Failure("etc/motionbus/lab.yaml example: buses %s, expected can0 among them" % out)
    python_dir = glob.glob(os.path.join(prefix, "lib/python3*/dist-packages"))[0]
    out = run(["/usr/bin/python3", "-c", "import motionlcm; m = motionlcm.request_t(); print(len(m.encode()) > 8)"],
              env=dict(env, PYTHONPATH=python_dir, PYTHONDONTWRITEBYTECODE="1")).stdout.strip()
    if out != "True":
        raise Failure("installed Python types: %r" % out)


def check_web(prefix, work, procs, config):
    log_path = os.path.join(work, "web.log")
    with open(log_path, "wb") as log:
        proc = procs.add(subprocess.Popen(
            [os.path.join(prefix, "bin/motion-web"), "--config", config, "--lcm-url", unique_lcm_url(21), "--listen", "127.0.0.1:0"],
            stdout=log, stderr=subprocess.STDOUT))
    url = None
    deadline = time.monotonic() + 10
    while url is None and time.monotonic() < deadline:
        with open(log_path, errors="replace") as f:
            for line in f:
                if line.startswith("motion-web: serving "):
                    url = line.split()[-1]
        if proc.poll() is not None:
            with open(log_path, errors="replace") as f:
                raise Failure("installed motion-web exited with %s:\n%s" % (proc.returncode, f.read()))
        time.sleep(0.05)
    if url is None:
        raise Failure("installed motion-web printed no address within 10 s")
    page = urllib.request.urlopen(url, timeout=5).read().decode()
    with open(os.path.join(prefix, "share/motion/web/index.html")) as f:
        if page != f.read():
            raise Failure("motion-web at %s did not serve share/motion/web/index.html" % url)
    chart = urllib.request.urlopen(url + "vendor/chart.min.js", timeout=5).read()
    if len(chart) < 10000:
        raise Failure("vendor/chart.min.js: %d bytes" % len(chart))
    code = procs.stop(proc)
    if code != 0:
        raise Failure("installed motion-web: exit %s after SIGTERM" % code)
    print("installed motion-web served %s (index.html, Chart.js %d bytes)" % (url, len(chart)))


def check_systemd_verify(prefix, work):
    analyze = shutil.which("systemd-analyze")
    if analyze is None:
        raise Failure("systemd-analyze not found (apt-get install systemd)")
    units = os.path.join(work, "units")
    os.makedirs(units)
    for unit in UNITS:
        shutil.copy(os.path.join(prefix, "lib/systemd/system", unit), units)
    os.rename(os.path.join(units, "motion-gateway@.service"), os.path.join(units, "motion-gateway@can0.service"))
    names = ["./" + u.replace("@.", "@can0.") for u in UNITS]
    done = subprocess.run([analyze, "verify", "--man=no"] + names, capture_output=True, text=True, cwd=units, timeout=60)
    out = (done.stdout + done.stderr).strip()
    if done.returncode != 0 or out:
        raise Failure("systemd-analyze verify of the installed units:\n%s" % out)


def complete(prefix, words):
    """What the installed completion offers for `words` (the last one being completed)."""
    script = os.path.join(prefix, "share/bash-completion/completions/motionctl")
    quoted = " ".join("'%s'" % w for w in words)
    code = 'source "%s"; COMP_WORDS=(%s); COMP_CWORD=%d; _motionctl; printf "%%s\\n" "${COMPREPLY[@]}"' % (
        script, quoted, len(words) - 1)
    return run(["bash", "--norc", "-c", code], env=dict(os.environ, PATH=os.path.join(prefix, "bin") + ":" + os.environ["PATH"])).stdout.split()


def check_completion(prefix, config):
    ctl = os.path.join(prefix, "bin/motionctl")
    cases = [
        ([ctl, "mo"], ["move"]),
        ([ctl, "--config", config, "se"], ["send", "set-position"]),
        ([ctl, "--config", config, "move", ""], ["x="]),
        ([ctl, "--config", config, "enable", ""], ["x"]),
        ([ctl, "--config", config, "dump", ""], ["can0"]),
        ([ctl, "--log-level", "w"], ["warn"]),
    ]
    for words, expected in cases:
        got = complete(prefix, words)
        if sorted(got) != sorted(expected):
            raise Failure("completion of %r: %r, expected %r" % (words[1:], got, expected))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--build", required=True)
    parser.add_argument("--cmake", required=True)
    parser.add_argument("--version", required=True)
    parser.add_argument("--lcm-types", type=int, required=True)
    parser.add_argument("--jar", action="store_true", help="the Java types jar was built: expect it installed")
    args = parser.parse_args()
    procs = Processes()
    start = time.monotonic()
    try:
        with tempfile.TemporaryDirectory(prefix="motion-install-") as work:
            prefix = os.path.join(work, "prefix")
            run([args.cmake, "--install", args.build, "--prefix", prefix], timeout=120)
            check_layout(args, prefix)
            check_units(prefix, prefix)
            # DESTDIR: files under it, the units naming the prefix without it.
            stage = os.path.join(work, "stage")
            run([args.cmake, "--install", args.build, "--prefix", "/opt/motionbus"], env=dict(os.environ, DESTDIR=stage), timeout=120)
            check_units(stage + "/opt/motionbus", "/opt/motionbus")
            print("installed in %.1f s (prefix, then DESTDIR)" % (time.monotonic() - start))
            config = write_tiny_config(work)
            check_programs(args, prefix)
            check_web(prefix, work, procs, config)
            check_systemd_verify(prefix, work)
            check_completion(prefix, config)
    except Failure as e:
        print("FAIL: %s" % e)
        return 1
    finally:
        procs.close()
    print("install checks passed in %.1f s" % (time.monotonic() - start))
    return 0


if __name__ == "__main__":
    sys.exit(main())
