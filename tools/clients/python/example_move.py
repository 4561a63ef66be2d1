#!/usr/bin/env python3
"""Enables two axes, moves them together (one synchronized request) and prints their final positions.

    example_move.py [--lcm-url URL] [--prefix MOTION_] [--axes x y] [--targets 10 5] [--timeout 60] [--config FILE] [--key FILE]

--key (default $MOTION_KEY): sign the requests with this private key (motionctl keygen).

Exit codes as the other programs: 0 done, 1 the coordinator refused or the move failed (its reason is
printed), 2 bad command line, 4 LCM unavailable.
"""
import argparse
import os
import sys

import _paths

_paths.add_lcmtypes()
from motionclient import (Client, KeyFileError, REQUEST_TIMEOUT, RequestFailed, key_path, load_private_key,  # noqa: E402
                          status_name)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--lcm-url", default=None, help="LCM URL (default: $LCM_DEFAULT_URL, then LCM's default)")
    p.add_argument("--prefix", default=None, help="channel prefix (default: the configuration's lcm.channel_prefix, else MOTION_)")
    p.add_argument("--config", default=os.environ.get("MOTION_CONFIG"),
                   help="a motionbus configuration: its lcm.url and lcm.channel_prefix (default: $MOTION_CONFIG)")
    p.add_argument("--axes", nargs=2, default=["x", "y"], metavar="AXIS", help="the two axes (default: x y)")
    p.add_argument("--targets", nargs=2, type=float, default=[10.0, 5.0], metavar="POS",
                   help="absolute targets in user units (default: 10 5)")
    p.add_argument("--timeout", type=float, default=REQUEST_TIMEOUT, help="seconds to wait for each terminal reply (default: %(default)s)")
    p.add_argument("--key", default=None, help="private key to sign requests with (motionctl keygen); default $MOTION_KEY")
    args = p.parse_args()

    key = None
    if key_path(args.key):
        try:
            key = load_private_key(key_path(args.key))
        except (KeyFileError, ImportError) as e:
            print(f"example_move: --key: {e}", file=sys.stderr)
            return 2
    try:
        if args.config:
            client = Client.from_config(args.config, url=args.lcm_url, prefix=args.prefix, client_id="example_move.py", key=key)
        else:
            client = Client(args.lcm_url, prefix=args.prefix or "MOTION_", client_id="example_move.py", key=key)
    except OSError as e:
        print(f"example_move: {e}", file=sys.stderr)
        return 4
    except ValueError as e:  # a URL this client does not understand
        print(f"example_move: {e}", file=sys.stderr)
        return 2
    with client:
        try:
            client.enable(args.axes, timeout=args.timeout, check=True)
            print(f"enabled {' '.join(args.axes)}")

            def progress(r):
                print(f"  {status_name(r.status)} {r.progress * 100:5.1f}%", flush=True)

            done = client.move(dict(zip(args.axes, args.targets)), timeout=args.timeout, on_progress=progress, check=True)
        except RequestFailed as e:
            print(f"example_move: {e}", file=sys.stderr)
            return 1
        positions = dict(zip(done.axes, done.positions))
        for axis in args.axes:
            print(f"{axis} = {positions.get(axis, float('nan')):.6g}")
        if done.num_axes > 1:
            print(f"measured start skew {done.measured_start_skew_us:.1f} us "
                  f"(predicted arrival spread {done.predicted_skew_us:.1f} us)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
