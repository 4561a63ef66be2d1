"""Python client of the motion system: requests and their terminal replies, axis state, events,
heartbeats. Mirrors the C++ client (services/client): every request gets replies on REPLY that end
in exactly one terminal status (DONE, REJECTED, ABORTED, FAILED); ``request()`` waits for it.

Needs the lcm-gen Python types (``build/lcmtypes/python`` on sys.path / PYTHONPATH); their
encode()/decode() are pure Python. Transport: motionclient.lcm_udp (no LCM binding needed).

Signing (README "Security"): after ``sign_with(key)`` (or ``Client(..., key=...)``) every request
goes out signed on SREQUEST (motionclient.signing, byte-identical to the C++ client). A SECURITY
event of the coordinator naming a pending request (unsigned, unknown key, bad signature...: the
coordinator sends no reply) ends it at once with a local REJECTED, code 19 (unauthorized).

Axis states: after ``verify_states_with(load_gateway_keys(authorized_keys))`` only states signed by a
key of role gateway count (signed_message_t on SAXIS_STATE; channel, key, signature, window, counter
per key and bus, a key bound to buses only for those), as in the C++ client; plain AXIS_STATEs are
ignored and signed ones that do not verify are counted (``forged_states``). Without it the plain
states are taken, unverified (``states_verified`` is False: say so where they are shown).

Thread contract: single-threaded. Callbacks run inside ``handle()``, ``request()`` and
``wait_until()``, which pump the LCM socket.
"""

from __future__ import annotations

import os
import socket
import sys
import time
from typing import Callable, Dict, Iterable, Mapping, Optional, Sequence, Union

from .lcm_udp import LcmUdp
from .signing import GatewayKey, MessageVerifier, RequestSigner, SigningKey

try:
    import motionlcm
    from motionlcm import axis_state_t, event_t, health_t, param_t, reply_t, request_t, signed_message_t
except ImportError as e:  # pragma: no cover - a clear message instead of a bare ImportError
    raise ImportError("motionclient needs the generated LCM types: put build/lcmtypes/python on PYTHONPATH "
                      f"(build the motion_lcmtypes_scripts target) ({e})") from None

UNAUTHORIZED = 19  # reply error code (services/lcm reply_error.hpp: kUnauthorized)
# The coordinator answers every request at once; no reply within this many seconds means no
# coordinator is listening (the same bound as the C++ client's kAcceptTimeout).
ACCEPT_TIMEOUT = 2.0
# Lost datagrams (README "Safety and faults"): while request() waits, a request of which nothing
# has been heard for RESEND_AFTER s (before its first reply) or QUIET_RESEND s (after) is sent
# again, unchanged but for its send time and signature; the coordinator answers a repeat with its
# latest reply to it, word for word, and runs nothing twice (as the C++ Client::follow).
RESEND_AFTER = 0.5
QUIET_RESEND = 1.0
# Seconds a request waits for its terminal reply by default: the same in every client (C++
# Client::kRequestTimeout, Java MotionClient.REQUEST_TIMEOUT_MS, Lua M.REQUEST_TIMEOUT).
REQUEST_TIMEOUT = 60.0
TERMINAL = (reply_t.DONE, reply_t.REJECTED, reply_t.ABORTED, reply_t.FAILED)
_STATUS_NAMES = {reply_t.ACCEPTED: "accepted", reply_t.STARTED: "started", reply_t.PROGRESS: "progress",
                 reply_t.DONE: "done", reply_t.REJECTED: "rejected", reply_t.ABORTED: "aborted",
                 reply_t.FAILED: "failed"}
KINDS = {name.lower(): getattr(request_t, name) for name in (
    "MOVE_ABSOLUTE", "MOVE_RELATIVE", "JOG", "STOP", "ESTOP", "HOME", "ENABLE", "DISABLE", "FAULT_RESET",
    "SET_OUTPUTS", "PARAM_READ", "PARAM_WRITE", "SET_POSITION")}
HEALTH_STATES = {health_t.STARTING: "STARTING", health_t.OK: "OK", health_t.DEGRADED: "DEGRADED",
                 health_t.FAULT: "FAULT", health_t.STOPPING: "STOPPING"}


def is_terminal(status: int) -> bool:
    return status in TERMINAL


def status_name(status: int) -> str:
    return _STATUS_NAMES.get(status, "unknown")


def kind_value(kind: Union[int, str]) -> int:
    """request_t kind from its number or name ("move_absolute", "ENABLE", "move-relative")."""
    if isinstance(kind, int):
        return kind
    try:
        return KINDS[kind.lower().replace("-", "_")]
    except KeyError:
        raise ValueError(f"unknown request kind {kind!r} (kinds: {', '.join(KINDS)})") from None


class RequestFailed(Exception):
    """A request ended in a terminal status other than DONE (raised by request(check=True))."""

    def __init__(self, reply):
        self.reply = reply
        super().__init__(f"{status_name(reply.status)} (error {reply.error_code}): {reply.reason}")


class Client:
    """``Client(url, prefix="MOTION_", client_id=...)``; use as a context manager or call close()."""

    def __init__(self, url: Optional[str] = None, prefix: str = "MOTION_", client_id: Optional[str] = None,
                 lcm: Optional[LcmUdp] = None, key: Optional[SigningKey] = None):
        self.lcm = lcm or LcmUdp(url)
        self.url = self.lcm.url
        self.prefix = prefix
        self.id = client_id or f"py:{socket.gethostname()}:{os.getpid()}"
        # Request ids start at the wall clock so a restarted client never reuses a live id.
        self._next_request_id = int(time.time() * 1e6)
        self._pending: Dict[int, Optional[Callable]] = {}
        self._sent: Dict[int, request_t] = {}         # pending requests as sent, to send again
        self._last_heard: Dict[int, float] = {}       # request id -> time.monotonic() sent or answered
        self._answered: set = set()                   # request ids with a reply heard
        self.resent = 0                               # requests sent again so far
        self._labels: Dict[int, str] = {}  # " request <id> of client '<id>'": how SECURITY events name it
        self.signer: Optional[RequestSigner] = None
        self._axes: Dict[str, axis_state_t] = {}
        self._heartbeats: Dict[str, health_t] = {}
        self._state_handler: Optional[Callable] = None
        self._event_handler: Optional[Callable] = None
        self._health_handler: Optional[Callable] = None
        self.lcm.subscribe(self.channel("REPLY"), self._on_reply)
        self.lcm.subscribe(self.channel("AXIS_STATE"), self._on_axis_state)
        self.lcm.subscribe(self.channel("EVENT"), self._on_event)
        self.lcm.subscribe(self.channel("HEALTH"), self._on_health)
        self._reply_verifier: Optional[MessageVerifier] = None
        self._event_verifier: Optional[MessageVerifier] = None
        self.forged_replies = 0  # signed replies for pending requests that did not verify
        self._state_verifier: Optional[MessageVerifier] = None
        self.forged_states = 0  # signed axis states that did not verify (verify_states_with)
        if key is not None:
            self.sign_with(key)

    @classmethod
    def from_config(cls, path: str, url: Optional[str] = None, prefix: Optional[str] = None, **kw) -> "Client":
        """A client on the LCM URL and with the channel prefix of a motionbus configuration file
        (lcm.url, lcm.channel_prefix), as every program reads them; `url` and `prefix` override
        the file's. Needs PyYAML (Debian python3-yaml)."""
        import yaml  # only this constructor needs it
        with open(path) as f:
            config = yaml.safe_load(f) or {}
        lcm = config.get("lcm") or {}
        return cls(url or lcm.get("url"), prefix=prefix or lcm.get("channel_prefix", "MOTION_"), **kw)

    def channel(self, name: str) -> str:
        return self.prefix + name

    def sign_with(self, key: SigningKey) -> None:
        """Signs every request from now on with `key` (motionclient.signing.load_private_key); the
        client id becomes the key's own ("<name>/<id>"), as the coordinator requires."""
        self.signer = RequestSigner(key, self.prefix)
        self.id = self.signer.own_client_id(self.id)

    def verify_with(self, coordinator: bytes, window_ms: int = 2000) -> None:
        """From now on only replies and SECURITY events signed by the coordinator count (SREPLY,
        SEVENT; `coordinator`: its public key, motionclient.signing.load_public_key of
        security.coordinator_public_key), as in the C++ client: a plain REPLY is ignored (the
        coordinator's own come signed too), a signed one that does not verify is a forgery: the
        request goes on waiting and forged_replies counts it."""
        subscribed = self._reply_verifier is not None
        self._reply_verifier = MessageVerifier(coordinator, self.prefix, "REPLY", window_ms)
        self._event_verifier = MessageVerifier(coordinator, self.prefix, "EVENT", window_ms)
        if not subscribed:
            self.lcm.subscribe(self.channel("SREPLY"), self._on_signed_reply)
            self.lcm.subscribe(self.channel("SEVENT"), self._on_signed_event)

    def verify_states_with(self, gateways: Sequence[GatewayKey], window_ms: int = 2000) -> None:
        """From now on axis_states() and on_axis_state() take only states signed by one of `gateways`
        (motionclient.signing.load_gateway_keys of security.authorized_keys) that verify: channel
        AXIS_STATE, signature, utime within window_ms and not before now, counter above the last
        one of that key and bus, and the state's bus one the key may vouch for. A plain AXIS_STATE
        is ignored (gateways send plain copies for observers); a signed one that does not verify
        is counted in forged_states (the first 10 are printed on stderr). Forgets the states taken
        unverified so far."""
        subscribed = self._state_verifier is not None
        self._state_verifier = MessageVerifier(list(gateways), self.prefix, "AXIS_STATE", window_ms,
                                               signers_are="a gateway key")
        self._axes.clear()
        if not subscribed:
            self.lcm.subscribe(self.channel("SAXIS_STATE"), self._on_signed_axis_state)

    @property
    def states_verified(self) -> bool:
        """Whether axis states are taken only signed by a gateway key (verify_states_with)."""
        return self._state_verifier is not None

    # ------------------------------------------------------------------ requests

    def send(self, kind: Union[int, str], axes: Sequence[str] = (), values: Optional[Sequence[float]] = None,
             on_reply: Optional[Callable] = None, **fields) -> int:
        """Publishes a request and returns its request_id; every reply goes to on_reply(reply).
        ``fields``: velocity_scale, acceleration_scale, timeout_ms, output_mask, output_value, param."""
        msg = request_t()
        msg.utime = int(time.time() * 1e6)
        msg.client_id = self.id
        msg.request_id = self._next_request_id
        self._next_request_id += 1
        msg.kind = kind_value(kind)
        msg.axes = list(axes)
        msg.num_axes = len(msg.axes)
        vals = [float(v) for v in (values or [])]
        msg.values = (vals + [0.0] * msg.num_axes)[:msg.num_axes]
        msg.param = param_t()
        for key, value in fields.items():
            if key not in ("velocity_scale", "acceleration_scale", "timeout_ms", "output_mask", "output_value", "param"):
                raise TypeError(f"unknown request field {key!r}")
            setattr(msg, key, value)
        self._pending[msg.request_id] = on_reply
        self._labels[msg.request_id] = f" request {msg.request_id} of client '{msg.client_id}'"
        self._sent[msg.request_id] = msg
        self._publish(msg)
        return msg.request_id

    def _publish(self, msg) -> None:
        msg.utime = int(time.time() * 1e6)
        self._last_heard[msg.request_id] = time.monotonic()
        if self.signer is not None:
            self.lcm.publish(self.channel("SREQUEST"), self.signer.sign(msg, msg.utime).encode())
        else:
            self.lcm.publish(self.channel("REQUEST"), msg.encode())

    def follow(self, request_id: int, done: Callable[[], bool], timeout: float) -> bool:
        """wait_until(), sending request `request_id` again while it is pending and nothing has been
        heard of it for RESEND_AFTER (before its first reply) or QUIET_RESEND seconds (after)."""
        def done_or_resend() -> bool:
            if done():
                return True
            msg = self._sent.get(request_id)
            quiet = QUIET_RESEND if request_id in self._answered else RESEND_AFTER
            if msg is not None and time.monotonic() - self._last_heard[request_id] >= quiet:
                self.resent += 1
                self._publish(msg)
            return False
        return self.wait_until(done_or_resend, timeout)

    def request(self, kind: Union[int, str], axes: Sequence[str] = (), values: Optional[Sequence[float]] = None,
                timeout: float = REQUEST_TIMEOUT, on_progress: Optional[Callable] = None, check: bool = False, **fields):
        """Sends and waits for the terminal reply (a motionlcm.reply_t). When none comes within
        `timeout` seconds, returns a local FAILED reply saying so (the coordinator may be down).
        check=True raises RequestFailed unless the reply is DONE."""
        result = []
        answered = []

        def on_reply(r):
            answered.append(True)
            if is_terminal(r.status):
                result.append(r)
            elif on_progress:
                on_progress(r)

        request_id = self.send(kind, axes, values, on_reply, **fields)
        # The coordinator answers every request at once (ACCEPTED or REJECTED): silence within
        # ACCEPT_TIMEOUT means nobody listens, and the caller learns it then, not after `timeout`.
        first_wait = min(timeout, ACCEPT_TIMEOUT)
        heard = self.follow(request_id, lambda: bool(answered), first_wait)
        if not heard or not self.follow(request_id, lambda: bool(result), timeout - first_wait):
            self._forget(request_id)
            r = reply_t()
            r.utime = int(time.time() * 1e6)
            r.client_id = self.id
            r.request_id = request_id
            r.status = reply_t.FAILED
            r.error_code = 13  # timeout
            where = f"{self.url}, channel {self.channel('SREQUEST' if self.signer else 'REQUEST')}"
            r.reason = (f"no terminal reply from the coordinator within {int(timeout * 1000)} ms ({where})" if heard else
                        f"no reply from the coordinator within {int(first_wait * 1000)} ms: "
                        f"is motion-coordinator running on {where}?")
            r.param = param_t()
            result.append(r)
        if check and result[0].status != reply_t.DONE:
            raise RequestFailed(result[0])
        return result[0]

    # Convenience wrappers (all return the terminal reply).
    def enable(self, axes: Iterable[str], **kw):
        return self.request(request_t.ENABLE, list(axes), **kw)

    def disable(self, axes: Iterable[str], **kw):
        return self.request(request_t.DISABLE, list(axes), **kw)

    def stop(self, axes: Iterable[str] = (), emergency: bool = False, **kw):
        return self.request(request_t.ESTOP if emergency else request_t.STOP, list(axes), **kw)

    def move(self, targets: Mapping[str, float], relative: bool = False, **kw):
        """Synchronized move of several axes: {"x": 10.0, "y": 5.0} in user units."""
        kind = request_t.MOVE_RELATIVE if relative else request_t.MOVE_ABSOLUTE
        return self.request(kind, list(targets.keys()), list(targets.values()), **kw)

    # ------------------------------------------------------------------ state, events, health

    def axis_states(self) -> Dict[str, axis_state_t]:
        """Latest state of every axis heard so far."""
        return dict(self._axes)

    def heartbeats(self) -> Dict[str, health_t]:
        """Latest heartbeat of every process heard so far, by process name."""
        return dict(self._heartbeats)

    def on_axis_state(self, handler: Optional[Callable]) -> None:
        self._state_handler = handler

    def on_event(self, handler: Optional[Callable]) -> None:
        self._event_handler = handler

    def on_health(self, handler: Optional[Callable]) -> None:
        self._health_handler = handler

    def handle(self, timeout: Optional[float] = 0.1) -> bool:
        return self.lcm.handle(timeout)

    def wait_until(self, done: Callable[[], bool], timeout: float) -> bool:
        """Pumps LCM until done() or the timeout (seconds); False on timeout."""
        deadline = time.monotonic() + timeout
        while not done():
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return False
            self.lcm.handle(min(remaining, 0.05))
        return True

    def wait_for_heartbeat(self, process: str, timeout: float = 10.0) -> Optional[health_t]:
        if self.wait_until(lambda: process in self._heartbeats, timeout):
            return self._heartbeats[process]
        return None

    def close(self) -> None:
        self.lcm.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ LCM handlers

    @staticmethod
    def _decode(cls, payload: bytes):
        try:
            return cls.decode(payload)
        except Exception:  # wrong fingerprint or truncated: not ours to crash on
            return None

    def _forget(self, request_id: int) -> None:
        self._pending.pop(request_id, None)
        self._labels.pop(request_id, None)
        self._sent.pop(request_id, None)
        self._last_heard.pop(request_id, None)
        self._answered.discard(request_id)

    def _on_reply(self, _channel: str, payload: bytes) -> None:
        if self._reply_verifier is None:
            self._take_reply(self._decode(reply_t, payload))

    def _on_signed_reply(self, _channel: str, payload: bytes) -> None:
        env = self._decode(signed_message_t, payload)
        if env is None:
            return
        message, _why = self._reply_verifier.verify(env, int(time.time() * 1e6))
        if message is not None:
            self._take_reply(self._decode(reply_t, message))
            return
        claimed = self._decode(reply_t, bytes(env.message))
        if claimed is not None and claimed.client_id == self.id and claimed.request_id in self._pending:
            self.forged_replies += 1

    def _on_signed_event(self, _channel: str, payload: bytes) -> None:
        env = self._decode(signed_message_t, payload)
        if env is None:
            return
        message, _why = self._event_verifier.verify(env, int(time.time() * 1e6))
        e = self._decode(event_t, message) if message is not None else None
        if e is not None and e.kind == event_t.SECURITY:
            self._on_security_event(e)

    def _take_reply(self, r) -> None:
        if r is None or r.client_id != self.id or r.request_id not in self._pending:
            return
        handler = self._pending[r.request_id]
        self._answered.add(r.request_id)
        self._last_heard[r.request_id] = time.monotonic()
        if is_terminal(r.status):
            self._forget(r.request_id)
        if handler:
            handler(r)

    def _on_security_event(self, e) -> None:
        """The coordinator refused a request of ours without a reply (its ids could not be trusted):
        end it now with a local REJECTED (code 19) carrying the event's text, as the C++ client does."""
        refused = [rid for rid, label in self._labels.items() if label in e.text]
        for rid in refused:
            handler = self._pending.get(rid)
            self._forget(rid)
            r = reply_t()
            r.utime = e.utime
            r.client_id = self.id
            r.request_id = rid
            r.status = reply_t.REJECTED
            r.error_code = UNAUTHORIZED
            r.reason = "refused by the coordinator's security (SECURITY event, no reply): " + e.text
            r.param = param_t()
            if handler:
                handler(r)

    def _on_axis_state(self, _channel: str, payload: bytes) -> None:
        if self._state_verifier is None:  # while verifying only the signed copies count
            self._take_state(self._decode(axis_state_t, payload))

    def _on_signed_axis_state(self, _channel: str, payload: bytes) -> None:
        env = self._decode(signed_message_t, payload)
        if env is None:
            return
        s, why = self._state_verifier.verify_message(env, int(time.time() * 1e6), axis_state_t, lambda m: m.bus)
        if s is not None:
            self._take_state(s)
            return
        self.forged_states += 1
        if self.forged_states <= 10:
            print(f"motionclient: SECURITY: an axis state is ignored: {why}", file=sys.stderr)

    def _take_state(self, s) -> None:
        if s is None:
            return
        self._axes[s.axis] = s
        if self._state_handler:
            self._state_handler(s)

    def _on_event(self, _channel: str, payload: bytes) -> None:
        e = self._decode(event_t, payload)
        if e is None:
            return
        if e.kind == event_t.SECURITY and self._event_verifier is None:
            self._on_security_event(e)
        if self._event_handler:
            self._event_handler(e)

    def _on_health(self, _channel: str, payload: bytes) -> None:
        h = self._decode(health_t, payload)
        if h is None:
            return
        self._heartbeats[h.process] = h
        if self._health_handler:
            self._health_handler(h)


__all__ = ["Client", "UNAUTHORIZED", "RequestFailed", "is_terminal", "status_name", "kind_value", "KINDS", "HEALTH_STATES",
           "TERMINAL"]
