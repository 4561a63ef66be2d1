#!/usr/bin/env python3
"""Checks signing in the Python client against a coordinator with `security: {mode: enforce}`
(used by ctest test_clients): a signed enable and move of one axis, then the same move unsigned,
signed with a key the coordinator does not know, and signed with the right key but its signature
altered (forged), each printed as one line:
    signed: status=done error_code=0 reason=...
    x = 12.5
    unsigned: status=rejected error_code=19 reason=refused by the coordinator's security ...
    stranger: status=rejected error_code=19 reason=...
    forged: status=rejected error_code=19 reason=...
    after: x = 12.5
("after": where the axis is once the refused requests had time to move it, from its axis state,
followed by "(unverified)", or with --gateway-keys by "(signed by a gateway, N refused)": the
client then takes only axis states signed by a key of role gateway of that authorized_keys file).
Exit 0 when every line came as expected, 1 otherwise, 2 bad command line or key file, 4 LCM
unavailable.

    check_signed.py --lcm-url URL [--prefix MOTION_] [--key FILE] --stranger-key FILE --axis x --target 12.5
                    [--gateway-keys AUTHORIZED_KEYS]
--key defaults to $MOTION_KEY.
"""
import argparse
import sys
import time

import _paths

_paths.add_lcmtypes()
from motionclient import (UNAUTHORIZED, Client, KeyFileError, SigningKey, key_path, load_gateway_keys,  # noqa: E402
                          load_private_key, status_name)
from motionlcm import reply_t  # noqa: E402


class ForgedKey(SigningKey):
    """`key` whose signatures have one bit flipped: what an attacker altering a message gets."""

    def __init__(self, key: SigningKey):
        self.__dict__.update(key.__dict__)

    def sign(self, message: bytes) -> bytes:
        signature = bytearray(super().sign(message))
        signature[5] ^= 0x10
        return bytes(signature)


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--lcm-url", default=None)
    p.add_argument("--prefix", default="MOTION_")
    p.add_argument("--key", default=None, help="private key file (motionctl keygen); default $MOTION_KEY")
    p.add_argument("--stranger-key", required=True, help="a key the coordinator does not know")
    p.add_argument("--axis", default="x")
    p.add_argument("--target", type=float, required=True)
    p.add_argument("--gateway-keys", default=None,
                   help="authorized_keys file: take only axis states signed by its keys of role gateway")
    args = p.parse_args()
    path = key_path(args.key)
    if path is None:
        print("check_signed: no key: --key FILE or $MOTION_KEY", file=sys.stderr)
        return 2
    try:
        key = load_private_key(path)
        stranger = load_private_key(args.stranger_key)
        gateways = load_gateway_keys(args.gateway_keys) if args.gateway_keys else None
    except KeyFileError as e:
        print(f"check_signed: {e}", file=sys.stderr)
        return 2
    ok = True
    try:
        signed = Client(args.lcm_url, prefix=args.prefix, client_id="check_signed.py", key=key)
        plain = Client(args.lcm_url, prefix=args.prefix, client_id="check_signed.py-plain")
        other = Client(args.lcm_url, prefix=args.prefix, client_id="check_signed.py", key=stranger)
        forger = Client(args.lcm_url, prefix=args.prefix, client_id="check_signed.py-forged", key=ForgedKey(key))
    except OSError as e:
        print(f"check_signed: {e}", file=sys.stderr)
        return 4
    if gateways is not None:
        signed.verify_states_with(gateways)
    with signed, plain, other, forger:
        r = signed.enable([args.axis], timeout=10.0)
        if r.status == reply_t.DONE:
            r = signed.move({args.axis: args.target}, timeout=20.0)
        print(f"signed: status={status_name(r.status)} error_code={r.error_code} reason={r.reason}")
        ok = r.status == reply_t.DONE
        if ok:
            print(f"{args.axis} = {dict(zip(r.axes, r.positions)).get(args.axis, float('nan')):.6g}")
        for name, client in (("unsigned", plain), ("stranger", other), ("forged", forger)):
            r = client.move({args.axis: args.target + 5.0}, timeout=5.0)
            print(f"{name}: status={status_name(r.status)} error_code={r.error_code} reason={r.reason}")
            ok = ok and r.status == reply_t.REJECTED and r.error_code == UNAUTHORIZED
        # A move that had been executed would have the axis on its way by now.
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            signed.handle(0.05)
        state = signed.axis_states().get(args.axis)
        verified = f"(signed by a gateway, {signed.forged_states} refused)" if signed.states_verified else "(unverified)"
        print(f"after: {args.axis} = {state.position:.6g} {verified}" if state else f"after: no state of {args.axis}")
    sys.stdout.flush()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
