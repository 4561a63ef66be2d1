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

Thread contract: a RequestSigner, MessageSigner or MessageVerifier belongs to one thread; the
functions are pure.
"""

from __future__ import annotations

import os
import stat
import struct
from typing import Optional

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


class MessageVerifier:
    """Takes a signed_message_t of one channel when it is the coordinator's, fresh (utime within
    window_ms of now and not before the verifier was made) and its counter is above the last one
    taken (as the C++ security::MessageVerifier). verify() returns (message bytes, "") or (None, why)."""

    def __init__(self, coordinator: bytes, prefix: str, channel: str, window_ms: int = 2000,
                 not_before_us: Optional[int] = None):
        import time
        self._key = _nacl_signing().VerifyKey(bytes(coordinator))
        self.key_id = bytes(coordinator)[:KEY_ID_BYTES]
        self.prefix = prefix
        self.channel = channel
        self.window_us = window_ms * 1000
        self.not_before_us = int(time.time() * 1e6) if not_before_us is None else not_before_us
        self._last_counter = 0

    def verify(self, env, now_us: int):
        what = f"signed {self.channel} refused: "
        if env.channel != self.channel:
            return None, what + f"it was signed for channel '{env.channel[:64]}'"
        if bytes(env.key_id) != self.key_id:
            return None, what + f"key {bytes(env.key_id).hex()} is not the coordinator's ({self.key_id.hex()})"
        try:
            self._key.verify(_message_bytes(self.prefix, self.channel, env), bytes(env.signature))
        except Exception:  # nacl.exceptions.BadSignatureError
            return None, what + "bad signature (forged or altered in transit)"
        if env.utime < self.not_before_us or abs(now_us - env.utime) > self.window_us:
            return None, what + "stale timestamp (outside the window, or signed before this client started)"
        if env.counter <= self._last_counter:
            return None, what + f"replayed counter {env.counter} (last accepted {self._last_counter})"
        self._last_counter = env.counter
        return bytes(env.message), ""


__all__ = ["KeyFileError", "SigningKey", "RequestSigner", "MessageSigner", "MessageVerifier", "load_private_key",
           "load_public_key", "key_path", "signed_bytes", "name_owns_client_id", "valid_name", "REQUEST_DOMAIN",
           "MESSAGE_DOMAIN"]
