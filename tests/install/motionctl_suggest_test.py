#!/usr/bin/python3
"""motionctl's suggestions for misspelt words (tools/motionctl/suggest.cpp): a misspelt subcommand or
axis name is refused at once (exit 2, nothing sent) with the nearest name, also when global options
come first; a known subcommand after global options with values is not mistaken for one.
  motionctl_suggest_test.py --bin BUILD/bin
"""

import argparse
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import Failure, unique_lcm_url, write_tiny_config  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--bin", required=True)
    args = parser.parse_args()
    ctl = os.path.join(args.bin, "motionctl")
    with tempfile.TemporaryDirectory(prefix="motion-suggest-") as work:
        config = write_tiny_config(work)
        url = unique_lcm_url(31)
        cases = [
            # argv, exit code, text expected on stderr (or stdout for exit 0)
            (["mvoe", "x=1"], 2, "motionctl: unknown command 'mvoe'; did you mean 'move'?"),
            (["--config", config, "--log-level", "warn", "stauts"], 2, "unknown command 'stauts'; did you mean 'status'?"),
            (["--config", config, "frobnicate"], 2, "unknown command 'frobnicate' (motionctl --help"),
            (["--config", config, "--lcm-url", url, "enable", "xx", "--timeout", "1"], 2, "motionctl: unknown axis 'xx'; did you mean 'x'?"),
            (["--config", config, "--lcm-url", url, "move", "q=1"], 2, "unknown axis 'q' (axes of %s: x)" % config),
            (["--config", config, "--lcm-url", url, "param", "xy", "1"], 2, "unknown axis 'xy'; did you mean 'x'?"),
            (["--config", config, "config", "axes"], 0, "x"),
        ]
        for argv, code, text in cases:
            done = subprocess.run([ctl] + argv, capture_output=True, text=True, timeout=30)
            out = done.stdout if code == 0 else done.stderr
            if done.returncode != code or text not in out:
                print("FAIL: motionctl %s: exit %d (expected %d), output:\n%s%s\nexpected to contain: %s" % (
                    " ".join(argv), done.returncode, code, done.stdout, done.stderr, text))
                return 1
    print("motionctl suggestions checked (%d cases)" % len(cases))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except Failure as e:
        print("FAIL: %s" % e)
        sys.exit(1)
