"""Signed requests (README "Security"), byte-identical to the C++ client (services/security):
a request_t inside a signed_request_t on <prefix>SREQUEST, signed with an Ed25519 key written by
``motionctl keygen``. Ed25519 is python3-nacl's (libsodium, as in C++); nothing here is
cryptography of our own, only the layout of the signed bytes.

The signature covers, concatenated (lcmtypes/signed_request_t.lcm):
  b"motionbus signed_request_t v1" NUL, channel prefix, NUL, key_id (8 bytes),
  counter (int64 big-endian), utime (int64 big-endian), payload_size (int32 big-endian), payload.

The coordinator's own messages (replies, events, triggers) come signed in a signed_message_t on
<prefix>S<channel> (lcmtypes/signed_message_t.lcm); MessageVerifier checks them with the
coordinator's public key (its .pub file, load_public_key), MessageSigner makes them (tests). The
signature covers b"motionbus signed_message_t v1" NUL, prefix, NUL, channel, NUL, key_id, counter,
utime, message_size, message (the same layout).

Gateways sign their axis states the same way (signed_message_t on <prefix>SAXIS_STATE) with a key
of role ``gateway`` in authorized_keys: load_gateway_keys reads those keys (and the buses a line's
``buses=`` binds each to), and a MessageVerifier of several signers checks the states against them,
keeping the counter per key and bus (Client.verify_states_with).

Thread contract: a RequestSigner, MessageSigner or MessageVerifier belongs to one thread; the
functions are pure.
"""

from __future__ import annotations

import os
import stat
import struct
from typing import Callable, Dict, List, Optional, Sequence, Tuple, Union

REQUEST_DOMAIN = b"motionbus signed_request_t v1"
MESSAGE_DOMAIN = b"motionbus signed_message_t v1"
PRIVATE_TAG = "motionbus-ed25519-private-key"
KEY_ID_BYTES = 8


class KeyFileError(ValueError):
    """A private key file that cannot be used (the text names the file, line and cause)."""


def _nacl_signing():
    try:
        import nacl.signing
        return nacl.signing
    except ImportError as e:  # pragma: no cover - a clear message instead of a bare ImportError
        raise ImportError(f"signing needs PyNaCl (Debian: apt-get install python3-nacl) ({e})") from None


def valid_name(name: str) -> bool:
    """A principal's name: 1..64 of [A-Za-z0-9._-]."""
    return 0 < len(name) <= 64 and all(c.isascii() and (c.isalnum() or c in "._-") for c in name)


def name_owns_client_id(name: str, client_id: str) -> bool:
    return client_id == name or client_id.startswith(name + "/")


class SigningKey:
    """An Ed25519 key pair with its name (from its 32-byte seed)."""

    def __init__(self, seed: bytes, name: str):
        if len(seed) != 32:
            raise ValueError("an Ed25519 seed has 32 bytes")
        self.name = name
        self._key = _nacl_signing().SigningKey(bytes(seed))
        self.public_key = bytes(self._key.verify_key)
        self.key_id = self.public_key[:KEY_ID_BYTES]

    def sign(self, message: bytes) -> bytes:
        return self._key.sign(message).signature

    def key_id_hex(self) -> str:
        return self.key_id.hex()


def load_private_key(path: str) -> SigningKey:
    """Reads a private key file as ``motionctl keygen`` writes it; refuses one that group or others
    may access (as the C++ loader does), and any other content than one key line."""
    import base64
    import binascii
    try:
        st = os.stat(path)
    except OSError as e:
        raise KeyFileError(f"cannot read key file {path}: {e.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise KeyFileError(f"key file {path} is not a regular file")
    if st.st_mode & 0o077:
        what = "readable" if st.st_mode & 0o044 else "accessible"
        raise KeyFileError(f"key file {path} is {what} by group/others (mode {st.st_mode & 0o7777:04o}); chmod 600 it")
    found = None
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            where = f"{path}:{number}: "
            if found is not None:
                raise KeyFileError(where + "a second key line (a private key file holds one key)")
            if len(fields) != 3 or fields[0] != PRIVATE_TAG:
                raise KeyFileError(where + f"expected '{PRIVATE_TAG} <base64 seed> <name>' (is this a private key file? "
                                           "a .pub file is not)")
            try:
                seed = base64.b64decode(fields[1], validate=True)
            except binascii.Error:
                seed = b""
            if len(seed) != 32:
                raise KeyFileError(where + "the seed is not base64 of 32 bytes")
            if not valid_name(fields[2]):
                raise KeyFileError(where + f"name '{fields[2]}' is not 1..64 of [A-Za-z0-9._-]")
            found = SigningKey(seed, fields[2])
    if found is None:
        raise KeyFileError(f"key file {path} holds no key line")
    return found


def key_path(option: Optional[str]) -> Optional[str]:
    """The key file to sign with: the option's value, else $MOTION_KEY (as motionctl --key); None: unsigned."""
    return option or os.environ.get("MOTION_KEY") or None


def signed_bytes(prefix: str, key_id: bytes, counter: int, utime: int, payload: bytes,
                 domain: bytes = REQUEST_DOMAIN) -> bytes:
    """What the signature covers (the layout is in lcmtypes/signed_request_t.lcm)."""
    return (domain + b"\0" + prefix.encode() + b"\0" + bytes(key_id) +
            struct.pack(">qqi", counter, utime, len(payload)) + bytes(payload))


class RequestSigner:
    """Signs a client's requests with one key for the channel prefix they go out on."""

    def __init__(self, key: SigningKey, prefix: str):
        self.key = key
        self.prefix = prefix
        self._last_counter = 0

    def own_client_id(self, client_id: str) -> str:
        """The key's own form of client_id: unchanged when it is the key's name or "<name>/...",
        else "<name>/<client_id>" (the coordinator refuses other ids from this key)."""
        return client_id if name_owns_client_id(self.key.name, client_id) else f"{self.key.name}/{client_id}"

    def sign(self, request, now_us: int):
        """The signed_request_t of `request` (a motionlcm.request_t), signed at now_us (µs since the
        epoch) with the next counter, max(last + 1, now_us)."""
        from motionlcm import signed_request_t
        env = signed_request_t()
        env.utime = now_us
        env.key_id = self.key.key_id
        self._last_counter = max(self._last_counter + 1, now_us)
        env.counter = self._last_counter
        env.payload = request.encode()
        env.payload_size = len(env.payload)
        env.signature = self.key.sign(signed_bytes(self.prefix, env.key_id, env.counter, env.utime, env.payload))
        return env


def load_public_key(path: str) -> bytes:
    """The 32-byte key of a public key file ("<base64 public key> <name> [<role>]", as motionctl
    keygen writes <name>.pub), e.g. the coordinator's (security.coordinator_public_key)."""
    import base64
    import binascii
    try:
        with open(path, encoding="utf-8") as f:
            lines = f.readlines()
    except OSError as e:
        raise KeyFileError(f"cannot read public key file {path}: {e.strerror}") from None
    for number, line in enumerate(lines, 1):
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        try:
            key = base64.b64decode(fields[0], validate=True)
        except binascii.Error:
            key = b""
        if len(key) != 32:
            raise KeyFileError(f"{path}:{number}: expected '<base64 public key> <name> [<role>]' (is this a .pub file?)")
        return key
    raise KeyFileError(f"public key file {path} holds no key line")


def _message_bytes(prefix: str, channel: str, env) -> bytes:
    return signed_bytes(prefix + "\0" + channel, env.key_id, env.counter, env.utime, env.message, domain=MESSAGE_DOMAIN)


class MessageSigner:
    """Signs messages of the coordinator's channels into signed_message_t (as the C++
    security::MessageSigner; the coordinator's job, here for tests and tools)."""

    def __init__(self, key: SigningKey, prefix: str):
        self.key = key
        self.prefix = prefix
        self._last_counter = 0

    def sign(self, channel: str, message, now_us: int):
        from motionlcm import signed_message_t
        env = signed_message_t()
        env.utime = now_us
        env.key_id = self.key.key_id
        self._last_counter = max(self._last_counter + 1, now_us)
        env.counter = self._last_counter
        env.channel = channel
        env.message = message.encode()
        env.message_size = len(env.message)
        env.signature = self.key.sign(_message_bytes(self.prefix, channel, env))
        return env


ROLES = ("observe", "operate", "configure", "admin", "gateway")
BUSES_TOKEN = "buses="


class GatewayKey:
    """A key of role `gateway` in authorized_keys: its 32 bytes, its name and the buses it may vouch
    for (the line's optional ``buses=can0,rs485a``; None: every bus)."""

    def __init__(self, public_key: bytes, name: str, buses: Optional[Sequence[str]] = None):
        self.public_key = bytes(public_key)
        self.key_id = self.public_key[:KEY_ID_BYTES]
        self.name = name
        self.buses = tuple(buses) if buses is not None else None

    def vouches_for(self, bus: str) -> bool:
        return self.buses is None or bus in self.buses


def parse_authorized_keys(text: str, file_name: str) -> List[Tuple[bytes, str, str, Optional[Tuple[str, ...]]]]:
    """The principals of an authorized_keys file, (public key, name, role, buses) per line, as the
    C++ security::AuthorizedKeys reads it: "<base64 public key> <name> <role> [buses=<bus>,...]",
    blank lines and # comments ignored. Raises KeyFileError listing every bad line ("file:line: what")."""
    import base64
    import binascii
    out, errors, key_lines, name_lines = [], [], {}, {}
    for number, line in enumerate(text.splitlines(), 1):
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        where = f"{file_name}:{number}: "
        if len(fields) not in (3, 4):
            errors.append(where + f"expected '<base64 public key> <name> <role> [{BUSES_TOKEN}<bus>,...]', got "
                                  f"{len(fields)} field{'' if len(fields) == 1 else 's'}")
            continue
        try:
            key = base64.b64decode(fields[0], validate=True)
        except binascii.Error:
            key = b""
        if len(key) != 32:
            errors.append(where + f"'{fields[0][:16]}{'...' if len(fields[0]) > 16 else ''}' is not a base64 Ed25519 "
                                  "public key (32 bytes)")
            continue
        name, role = fields[1], fields[2]
        if not valid_name(name):
            errors.append(where + f"name '{name}' is not 1..64 of [A-Za-z0-9._-]")
            continue
        if role not in ROLES:
            errors.append(where + f"unknown role '{role}' ({', '.join(ROLES)})")
            continue
        buses = None
        if len(fields) == 4:
            buses = tuple(fields[3][len(BUSES_TOKEN):].split(","))
            if not fields[3].startswith(BUSES_TOKEN) or not all(buses):
                errors.append(where + f"expected '{BUSES_TOKEN}<bus>[,<bus>...]' after the role, got '{fields[3][:64]}'")
                continue
            if role != "gateway":
                errors.append(where + f"{BUSES_TOKEN} binds a key of role gateway to buses; '{name}' has role {role}")
                continue
        if key[:KEY_ID_BYTES] in key_lines:  # key ids are 8 bytes of the key
            errors.append(where + f"key of '{name}' is already listed at line {key_lines[key[:KEY_ID_BYTES]]} "
                                  f"(same key id {key[:KEY_ID_BYTES].hex()})")
            continue
        if name in name_lines:
            errors.append(where + f"name '{name}' is already used at line {name_lines[name]}")
            continue
        key_lines[key[:KEY_ID_BYTES]] = number
        name_lines[name] = number
        out.append((key, name, role, buses))
    if errors:
        raise KeyFileError("\n".join(errors))
    return out


def load_gateway_keys(path: str) -> List[GatewayKey]:
    """The keys of role `gateway` of an authorized_keys file (security.authorized_keys), with the
    buses each may vouch for; what gateways sign their axis states with (Client.verify_states_with)."""
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError as e:
        raise KeyFileError(f"cannot read authorized keys file {path}: {e.strerror}") from None
    keys = [GatewayKey(key, name, buses) for key, name, role, buses in parse_authorized_keys(text, path)
            if role == "gateway"]
    if not keys:
        raise KeyFileError(f"authorized keys file {path} has no key of role gateway")
    return keys


class MessageVerifier:
    """Takes a signed_message_t of one channel when its signer is one of `signers`, its signature
    verifies, it is fresh (utime within window_ms of now and not before the verifier was made) and
    its counter is above the last one taken from that signer (for that bus), as the C++
    security::MessageVerifier. `signers`: the coordinator's public key (bytes), or a list of keys
    (bytes or GatewayKey) any of which may sign, e.g. load_gateway_keys(); `signers_are` names them
    in a refusal. verify() returns (message bytes, "") or (None, why); verify_message() the decoded
    message."""

    def __init__(self, signers: Union[bytes, Sequence[Union[bytes, GatewayKey]]], prefix: str, channel: str,
                 window_ms: int = 2000, not_before_us: Optional[int] = None, signers_are: Optional[str] = None):
        import time
        if isinstance(signers, (bytes, bytearray)):
            signers = [bytes(signers)]
            signers_are = signers_are or f"the coordinator's ({bytes(signers[0])[:KEY_ID_BYTES].hex()})"
        self._signers = {}  # key id -> (VerifyKey, GatewayKey or None)
        for s in signers:
            public = s.public_key if isinstance(s, GatewayKey) else bytes(s)
            self._signers[public[:KEY_ID_BYTES]] = (_nacl_signing().VerifyKey(public),
                                                    s if isinstance(s, GatewayKey) else None)
        self.signers_are = signers_are or "a key of the list"
        self.prefix = prefix
        self.channel = channel
        self.window_us = window_ms * 1000
        self.not_before_us = int(time.time() * 1e6) if not_before_us is None else not_before_us
        self._last_counter: Dict[Tuple[bytes, str], int] = {}  # per (signer, bus)

    def _check(self, env, now_us: int):
        """(key id, signer entry, "") when channel, signer, signature and freshness pass; else (None, None, why)."""
        what = f"signed {self.channel} refused: "
        if env.channel != self.channel:
            return None, None, what + f"it was signed for channel '{env.channel[:64]}'"
        key_id = bytes(env.key_id)
        signer = self._signers.get(key_id)
        if signer is None:
            return None, None, what + f"key {key_id.hex()} is not {self.signers_are}"
        try:
            signer[0].verify(_message_bytes(self.prefix, self.channel, env), bytes(env.signature))
        except Exception:  # nacl.exceptions.BadSignatureError, or a malformed signature
            return None, None, what + "bad signature (forged or altered in transit)"
        if env.utime < self.not_before_us:
            return None, None, what + "stale timestamp: signed before this client started (a replay?)"
        if abs(now_us - env.utime) > self.window_us:
            return None, None, what + (f"stale timestamp: signed {abs(now_us - env.utime) // 1000} ms "
                                       f"{'ago' if now_us >= env.utime else 'in the future'}, outside the window of "
                                       f"{self.window_us // 1000} ms (clocks out of sync, or a replay)")
        return key_id, signer, ""

    def _take_counter(self, key_id: bytes, bus: str, counter: int) -> str:
        last = self._last_counter.get((key_id, bus), 0)
        if counter <= last:
            return (f"signed {self.channel} refused: replayed counter {counter} (last accepted {last}"
                    f"{' for ' + bus[:64] if bus else ''})")
        self._last_counter[(key_id, bus)] = counter
        return ""

    def verify(self, env, now_us: int):
        key_id, _signer, why = self._check(env, now_us)
        if key_id is None:
            return None, why
        why = self._take_counter(key_id, "", env.counter)
        return (None, why) if why else (bytes(env.message), "")

    def verify_message(self, env, now_us: int, lcm_type, bus_of: Optional[Callable] = None):
        """The message decoded as `lcm_type`, or (None, why). With `bus_of` (e.g. the axis_state_t's
        bus) the counter is kept per signer and bus, and a GatewayKey bound to buses vouches only
        for a message of one of them (checked before the counter, which a refused message leaves)."""
        key_id, signer, why = self._check(env, now_us)
        if key_id is None:
            return None, why
        try:
            message = lcm_type.decode(bytes(env.message))
        except Exception as e:  # wrong fingerprint or truncated
            return None, f"signed {self.channel} refused: malformed message: {e}"
        bus = bus_of(message) if bus_of else ""
        gateway = signer[1]
        if bus_of and gateway is not None and not gateway.vouches_for(bus):
            return None, (f"signed {self.channel} refused: key {key_id.hex()} ('{gateway.name}') may vouch only for "
                          f"bus {','.join(gateway.buses)}, not for bus {bus[:64]}")
        why = self._take_counter(key_id, bus, env.counter)
        return (None, why) if why else (message, "")


__all__ = ["KeyFileError", "SigningKey", "RequestSigner", "MessageSigner", "MessageVerifier", "GatewayKey",
           "load_private_key", "load_public_key", "load_gateway_keys", "parse_authorized_keys", "key_path", "signed_bytes",
           "name_owns_client_id", "valid_name", "REQUEST_DOMAIN", "MESSAGE_DOMAIN"]
