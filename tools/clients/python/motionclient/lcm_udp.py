"""Minimal LCM UDP multicast transport in pure Python (no LCM Python binding needed).

Implements LCM's documented wire format ("LCM UDP Multicast Protocol Description"):

* small message, one datagram:
    uint32 magic 0x4c433032 ("LC02") | uint32 sequence number | channel, NUL | payload
* fragmented message, n datagrams (all big-endian):
    uint32 magic 0x4c433033 ("LC03") | uint32 sequence number | uint32 payload size |
    uint32 fragment offset | uint16 fragment number | uint16 number of fragments |
    fragment 0 only: channel, NUL | payload bytes [offset, offset + len)

  The payload offset counts payload bytes only (not the channel). As in LCM's C library, a
  message is fragmented when channel + NUL + payload exceeds SHORT_MESSAGE_MAX, and each
  fragment datagram carries at most FRAGMENT_MAX_PAYLOAD bytes after its header (the first
  one: channel + NUL + payload).

Transport: UDP to the multicast group/port of the URL ``udpm://GROUP:PORT?ttl=N`` with
IP_MULTICAST_TTL = N (0 keeps packets on this host) and multicast loopback on, so processes on
the same machine hear each other. Receiving binds GROUP:PORT with SO_REUSEADDR (several LCM
processes share the port) and joins the group.

Thread contract: single-threaded. ``handle(timeout)`` reads and dispatches; ``fileno()`` lets
callers put the socket in their own select/poll loop.
"""

from __future__ import annotations

import os
import re
import select
import socket
import struct
import time
from typing import Callable, Dict, List, Optional, Tuple
from urllib.parse import parse_qs, urlsplit

MAGIC_SHORT = 0x4C433032  # "LC02"
MAGIC_LONG = 0x4C433033  # "LC03"
SHORT_HEADER = struct.Struct(">II")  # magic, sequence number
LONG_HEADER = struct.Struct(">IIIIHH")  # magic, seqno, payload size, offset, fragment no, count
MAX_CHANNEL_LENGTH = 63  # LCM_MAX_CHANNEL_NAME_LENGTH
SHORT_MESSAGE_MAX = 1400  # channel + NUL + payload; larger messages are fragmented
FRAGMENT_MAX_PAYLOAD = 1400  # bytes after the fragment header, per datagram
MAX_MESSAGE_SIZE = 1 << 28  # refuse to reassemble anything larger
DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0"

Handler = Callable[[str, bytes], None]


class LcmUrlError(ValueError):
    """The LCM URL is not a udpm:// URL this transport understands."""


def parse_url(url: Optional[str]) -> Tuple[str, int, int]:
    """(group, port, ttl) of a ``udpm://GROUP:PORT?ttl=N`` URL.

    An empty URL means $LCM_DEFAULT_URL, then LCM's default ``udpm://239.255.76.67:7667?ttl=0``.
    """
    if not url:
        url = os.environ.get("LCM_DEFAULT_URL") or DEFAULT_URL
    parts = urlsplit(url)
    if parts.scheme != "udpm":
        raise LcmUrlError(f"unsupported LCM URL {url!r}: only udpm://GROUP:PORT?ttl=N is implemented")
    group = parts.hostname or "239.255.76.67"
    try:
        port = parts.port or 7667
        socket.inet_aton(group)
    except (ValueError, OSError) as e:
        raise LcmUrlError(f"bad LCM URL {url!r}: {e}") from None
    ttl = 0
    for key, values in parse_qs(parts.query).items():
        if key == "ttl":
            try:
                ttl = int(values[-1])
            except ValueError:
                raise LcmUrlError(f"bad ttl in LCM URL {url!r}") from None
            if not 0 <= ttl <= 255:
                raise LcmUrlError(f"ttl out of range in LCM URL {url!r}")
        # recv_buf_size and other provider options are accepted and ignored.
    return group, port, ttl


def _channel_bytes(channel: str) -> bytes:
    raw = channel.encode("utf-8")
    if len(raw) > MAX_CHANNEL_LENGTH:
        raise ValueError(f"LCM channel name longer than {MAX_CHANNEL_LENGTH} bytes: {channel!r}")
    if b"\0" in raw:
        raise ValueError(f"LCM channel name contains NUL: {channel!r}")
    return raw


def encode_datagrams(channel: str, payload: bytes, seqno: int, short_max: int = SHORT_MESSAGE_MAX,
                     fragment_max: int = FRAGMENT_MAX_PAYLOAD) -> List[bytes]:
    """The datagrams that carry one message: one LC02 datagram, or LC03 fragments."""
    ch = _channel_bytes(channel)
    seqno &= 0xFFFFFFFF
    if len(ch) + 1 + len(payload) <= short_max:
        return [SHORT_HEADER.pack(MAGIC_SHORT, seqno) + ch + b"\0" + payload]
    if fragment_max <= len(ch) + 1:
        raise ValueError("fragment size too small for the channel name")
    total = len(ch) + 1 + len(payload)  # the first fragment carries the channel too
    count = (total + fragment_max - 1) // fragment_max
    if count > 0xFFFF:
        raise ValueError(f"message too large for LCM fragmentation: {len(payload)} bytes")
    first = fragment_max - (len(ch) + 1)
    out = [LONG_HEADER.pack(MAGIC_LONG, seqno, len(payload), 0, 0, count) + ch + b"\0" + payload[:first]]
    offset = first
    number = 1
    while offset < len(payload):
        chunk = payload[offset:offset + fragment_max]
        out.append(LONG_HEADER.pack(MAGIC_LONG, seqno, len(payload), offset, number, count) + chunk)
        offset += len(chunk)
        number += 1
    assert number == count, (number, count)
    return out


class _Partial:
    __slots__ = ("channel", "data", "size", "count", "received", "started")

    def __init__(self, size: int, count: int, now: float):
        self.channel: Optional[str] = None
        self.data = bytearray(size)
        self.size = size
        self.count = count
        self.received: set = set()
        self.started = now


class Reassembler:
    """Turns received datagrams into (channel, payload) messages.

    Fragments are keyed by (sender, sequence number); a sender's partial message is dropped when
    a fragment of a different message from it arrives with a different size, or after
    ``max_age`` seconds. Malformed datagrams are counted in ``discarded`` and ignored.
    """

    def __init__(self, max_age: float = 2.0, max_partials: int = 64):
        self.max_age = max_age
        self.max_partials = max_partials
        self.discarded = 0
        self._partials: Dict[Tuple[object, int], _Partial] = {}

    def feed(self, datagram: bytes, sender: object = None, now: Optional[float] = None) -> Optional[Tuple[str, bytes]]:
        now = time.monotonic() if now is None else now
        if len(datagram) < SHORT_HEADER.size:
            self.discarded += 1
            return None
        magic, seqno = SHORT_HEADER.unpack_from(datagram)
        if magic == MAGIC_SHORT:
            end = datagram.find(b"\0", SHORT_HEADER.size)
            if end < 0 or end - SHORT_HEADER.size > MAX_CHANNEL_LENGTH:
                self.discarded += 1
                return None
            channel = datagram[SHORT_HEADER.size:end].decode("utf-8", "replace")
            return channel, bytes(datagram[end + 1:])
        if magic != MAGIC_LONG or len(datagram) < LONG_HEADER.size:
            self.discarded += 1
            return None
        _, seqno, size, offset, number, count = LONG_HEADER.unpack_from(datagram)
        if size > MAX_MESSAGE_SIZE or count == 0 or number >= count:
            self.discarded += 1
            return None
        self._expire(now)
        key = (sender, seqno)
        part = self._partials.get(key)
        if part is not None and (part.size != size or part.count != count):
            del self._partials[key]
            part = None
        if part is None:
            # A new message from this sender: forget its older unfinished ones.
            for old in [k for k in self._partials if k[0] == sender]:
                del self._partials[old]
            if len(self._partials) >= self.max_partials:
                oldest = min(self._partials, key=lambda k: self._partials[k].started)
                del self._partials[oldest]
            part = _Partial(size, count, now)
            self._partials[key] = part
        body_start = LONG_HEADER.size
        if number == 0:
            end = datagram.find(b"\0", LONG_HEADER.size)
            if end < 0 or end - LONG_HEADER.size > MAX_CHANNEL_LENGTH:
                self.discarded += 1
                del self._partials[key]
                return None
            part.channel = datagram[LONG_HEADER.size:end].decode("utf-8", "replace")
            body_start = end + 1
        body = datagram[body_start:]
        if offset + len(body) > size:
            self.discarded += 1
            del self._partials[key]
            return None
        if number in part.received:
            return None  # duplicate
        part.data[offset:offset + len(body)] = body
        part.received.add(number)
        if len(part.received) == part.count and part.channel is not None:
            del self._partials[key]
            return part.channel, bytes(part.data)
        return None

    def _expire(self, now: float) -> None:
        for key in [k for k, p in self._partials.items() if now - p.started > self.max_age]:
            del self._partials[key]
            self.discarded += 1


class LcmUdp:
    """LCM over UDP multicast: publish, subscribe (channel regular expressions, as in LCM), handle."""

    def __init__(self, url: Optional[str] = None):
        self.group, self.port, self.ttl = parse_url(url)
        self.url = url or f"udpm://{self.group}:{self.port}?ttl={self.ttl}"
        self._seqno = 0
        self._subs: List[Tuple[int, "re.Pattern[str]", Handler]] = []
        self._next_sub = 1
        self._reassembler = Reassembler()
        self._send = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        self._recv = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        try:
            self._send.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, self.ttl)
            self._send.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
            self._recv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            if hasattr(socket, "SO_REUSEPORT") and os.uname().sysname != "Linux":
                self._recv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
            try:
                self._recv.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 2 * 1024 * 1024)
            except OSError:
                pass
            # Binding the group address (not INADDR_ANY) keeps other groups on this port out.
            self._recv.bind((self.group, self.port))
            mreq = socket.inet_aton(self.group) + socket.inet_aton("0.0.0.0")
            self._recv.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, mreq)
            self._recv.setblocking(False)
        except OSError as e:
            self.close()
            raise OSError(e.errno, f"LCM unavailable on {self.url}: {e.strerror} "
                                   "(is there a multicast route? see LCM's multicast setup notes)") from None

    # ------------------------------------------------------------------ publish / subscribe

    def publish(self, channel: str, payload: bytes) -> None:
        for datagram in encode_datagrams(channel, bytes(payload), self._seqno):
            self._send.sendto(datagram, (self.group, self.port))
        self._seqno = (self._seqno + 1) & 0xFFFFFFFF

    def subscribe(self, channel_regex: str, handler: Handler) -> int:
        """Calls handler(channel, payload) for messages whose channel fully matches the regex."""
        sub_id = self._next_sub
        self._next_sub += 1
        self._subs.append((sub_id, re.compile(channel_regex), handler))
        return sub_id

    def unsubscribe(self, sub_id: int) -> None:
        self._subs = [s for s in self._subs if s[0] != sub_id]

    # ------------------------------------------------------------------ receive

    def fileno(self) -> int:
        return self._recv.fileno()

    def handle(self, timeout: Optional[float] = None) -> bool:
        """Waits up to `timeout` seconds (None: forever) for datagrams and dispatches every complete
        message that has arrived. True when at least one message was dispatched."""
        deadline = None if timeout is None else time.monotonic() + max(0.0, timeout)
        while True:
            remaining = None if deadline is None else max(0.0, deadline - time.monotonic())
            readable, _, _ = select.select([self._recv], [], [], remaining)
            if not readable:
                return False
            if self._drain():
                return True
            if deadline is not None and time.monotonic() >= deadline:
                return False

    def _drain(self) -> bool:
        dispatched = False
        while True:
            try:
                datagram, sender = self._recv.recvfrom(65536)
            except (BlockingIOError, InterruptedError):
                return dispatched
            message = self._reassembler.feed(datagram, sender)
            if message is None:
                continue
            channel, payload = message
            for _, pattern, handler in list(self._subs):
                if pattern.fullmatch(channel):
                    handler(channel, payload)
                    dispatched = True

    @property
    def discarded(self) -> int:
        return self._reassembler.discarded

    def close(self) -> None:
        for s in (self._send, self._recv):
            try:
                s.close()
            except OSError:
                pass

    def __enter__(self) -> "LcmUdp":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
