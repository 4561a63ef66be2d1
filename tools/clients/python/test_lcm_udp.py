"""Unit tests of motionclient.lcm_udp against byte vectors written out by hand from LCM's
"UDP Multicast Protocol Description" (not produced by the module's own struct formats).

    python3 -m unittest test_lcm_udp      (from tools/clients/python; ctest: clients_python_wire_format)

The C++ side (liblcm) hearing Python and Python hearing liblcm, for both LC02 and LC03, is checked by
ctest test_clients (Clients.PythonWireFormatInteroperatesWithLiblcm, using loopback.py).
"""
import os
import random
import socket
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from motionclient.lcm_udp import (FRAGMENT_MAX_PAYLOAD, SHORT_MESSAGE_MAX, LcmUdp, LcmUrlError,  # noqa: E402
                                  Reassembler, encode_datagrams, parse_url)

# LC02, sequence number 0x01020304, channel "ABC", payload 01 02.
LC02_VECTOR = bytes([0x4C, 0x43, 0x30, 0x32,  # "LC02"
                     0x01, 0x02, 0x03, 0x04,  # sequence number, big-endian
                     0x41, 0x42, 0x43, 0x00,  # "ABC" NUL
                     0x01, 0x02])  # payload

# LC03: channel "CH", payload 00..09 (10 bytes), sequence number 7, at most 6 bytes after each
# fragment header: fragment 0 = "CH\0" + payload[0:3], fragment 1 = payload[3:9], 2 = payload[9:10].
PAYLOAD10 = bytes(range(10))
LC03_VECTOR = [
    bytes([0x4C, 0x43, 0x30, 0x33,  # "LC03"
           0, 0, 0, 7,  # sequence number
           0, 0, 0, 10,  # payload size (without the channel)
           0, 0, 0, 0,  # fragment offset in the payload
           0, 0,  # fragment number
           0, 3,  # number of fragments
           0x43, 0x48, 0x00,  # "CH" NUL, first fragment only
           0, 1, 2]),
    bytes([0x4C, 0x43, 0x30, 0x33, 0, 0, 0, 7, 0, 0, 0, 10, 0, 0, 0, 3, 0, 1, 0, 3, 3, 4, 5, 6, 7, 8]),
    bytes([0x4C, 0x43, 0x30, 0x33, 0, 0, 0, 7, 0, 0, 0, 10, 0, 0, 0, 9, 0, 2, 0, 3, 9]),
]


class SmallMessages(unittest.TestCase):
    def test_encode_matches_the_spec_vector(self):
        self.assertEqual(encode_datagrams("ABC", b"\x01\x02", 0x01020304), [LC02_VECTOR])

    def test_decode_the_spec_vector(self):
        self.assertEqual(Reassembler().feed(LC02_VECTOR, "a"), ("ABC", b"\x01\x02"))

    def test_empty_payload(self):
        self.assertEqual(encode_datagrams("X", b"", 0), [b"LC02\x00\x00\x00\x00X\x00"])
        self.assertEqual(Reassembler().feed(b"LC02\x00\x00\x00\x00X\x00", "a"), ("X", b""))

    def test_sequence_number_wraps_at_32_bits(self):
        self.assertEqual(encode_datagrams("A", b"", 2 ** 32 + 5)[0][4:8], b"\x00\x00\x00\x05")

    def test_largest_small_message_and_first_fragmented_one(self):
        channel = "MOTION_REQUEST"
        fits = bytes(SHORT_MESSAGE_MAX - len(channel) - 1)
        self.assertEqual(len(encode_datagrams(channel, fits, 1)), 1)
        self.assertEqual(encode_datagrams(channel, fits, 1)[0][:4], b"LC02")
        over = encode_datagrams(channel, fits + b"\x00", 1)
        self.assertEqual([d[:4] for d in over], [b"LC03", b"LC03"])
        self.assertTrue(all(len(d) <= 20 + FRAGMENT_MAX_PAYLOAD for d in over))

    def test_channel_name_limits(self):
        encode_datagrams("C" * 63, b"", 0)
        with self.assertRaises(ValueError):
            encode_datagrams("C" * 64, b"", 0)

    def test_malformed_datagrams_are_discarded(self):
        r = Reassembler()
        for bad in (b"LC0", b"XXXX\x00\x00\x00\x00A\x00", b"LC02\x00\x00\x00\x00NO-NUL", b"LC02\x00\x00\x00\x00" + b"C" * 64 + b"\x00"):
            self.assertIsNone(r.feed(bad, "a"))
        self.assertEqual(r.discarded, 4)


class FragmentedMessages(unittest.TestCase):
    def test_encode_matches_the_spec_vector(self):
        self.assertEqual(encode_datagrams("CH", PAYLOAD10, 7, short_max=8, fragment_max=6), LC03_VECTOR)

    def test_decode_in_order(self):
        r = Reassembler()
        self.assertIsNone(r.feed(LC03_VECTOR[0], "a"))
        self.assertIsNone(r.feed(LC03_VECTOR[1], "a"))
        self.assertEqual(r.feed(LC03_VECTOR[2], "a"), ("CH", PAYLOAD10))

    def test_decode_out_of_order_with_a_duplicate(self):
        r = Reassembler()
        self.assertIsNone(r.feed(LC03_VECTOR[2], "a"))
        self.assertIsNone(r.feed(LC03_VECTOR[2], "a"))
        self.assertIsNone(r.feed(LC03_VECTOR[1], "a"))
        self.assertEqual(r.feed(LC03_VECTOR[0], "a"), ("CH", PAYLOAD10))

    def test_a_missing_fragment_delivers_nothing_and_expires(self):
        r = Reassembler(max_age=1.0)
        self.assertIsNone(r.feed(LC03_VECTOR[0], "a", now=0.0))
        self.assertIsNone(r.feed(LC03_VECTOR[2], "a", now=0.5))
        # The next message from that sender starts over; the fragment of the old one is gone.
        self.assertIsNone(r.feed(LC03_VECTOR[1], "a", now=3.0))
        self.assertGreaterEqual(r.discarded, 1)

    def test_two_senders_interleaved(self):
        r = Reassembler()
        out = []
        for a, b in zip(LC03_VECTOR, reversed(LC03_VECTOR)):
            out.append(r.feed(a, ("10.0.0.1", 1)))
            out.append(r.feed(b, ("10.0.0.2", 1)))
        self.assertEqual([m for m in out if m], [("CH", PAYLOAD10), ("CH", PAYLOAD10)])

    def test_fragment_beyond_the_payload_size_is_dropped(self):
        bad = bytearray(LC03_VECTOR[2])
        bad[15] = 10  # offset 10 + 1 byte > size 10
        r = Reassembler()
        self.assertIsNone(r.feed(bytes(bad), "a"))
        self.assertEqual(r.discarded, 1)

    def test_large_random_payloads_round_trip(self):
        rng = random.Random(1)
        r = Reassembler()
        for size in (1386, 1387, 5000, 70000, 300000):
            payload = bytes(rng.getrandbits(8) for _ in range(size))
            datagrams = encode_datagrams("MOTION_REPLY", payload, size)
            rng.shuffle(datagrams)
            results = [r.feed(d, "s") for d in datagrams]
            self.assertEqual([m for m in results if m], [("MOTION_REPLY", payload)], size)


class Urls(unittest.TestCase):
    def test_parse(self):
        self.assertEqual(parse_url("udpm://239.255.76.67:7667?ttl=0"), ("239.255.76.67", 7667, 0))
        self.assertEqual(parse_url("udpm://239.1.2.3:20001?ttl=1&recv_buf_size=100000"), ("239.1.2.3", 20001, 1))
        self.assertEqual(parse_url("udpm://"), ("239.255.76.67", 7667, 0))

    def test_refused(self):
        for bad in ("tcpq://localhost:7700", "file:///tmp/log", "udpm://239.1.2.3:7667?ttl=x", "udpm://239.1.2.3:99999"):
            with self.assertRaises(LcmUrlError, msg=bad):
                parse_url(bad)


class GeneratedTypes(unittest.TestCase):
    """The lcm-gen Python types through the transport (skipped only when they are not on the path)."""

    def test_request_round_trip_through_fragments(self):
        try:
            from motionlcm import param_t, request_t
        except ImportError:
            self.skipTest("generated motionlcm types not on PYTHONPATH")
        m = request_t()
        m.client_id, m.request_id, m.kind = "t", 42, request_t.MOVE_ABSOLUTE
        m.axes = [f"axis{i}" for i in range(200)]
        m.num_axes = len(m.axes)
        m.values = [i * 0.5 for i in range(200)]
        m.param = param_t()
        datagrams = encode_datagrams("MOTION_REQUEST", m.encode(), 9)
        self.assertGreater(len(datagrams), 1)
        r = Reassembler()
        channel, payload = [x for x in (r.feed(d, "s") for d in datagrams) if x][0]
        back = request_t.decode(payload)
        self.assertEqual((channel, list(back.axes), list(back.values), back.request_id), ("MOTION_REQUEST", m.axes, m.values, 42))


class MulticastLoopback(unittest.TestCase):
    """Two LcmUdp instances on one multicast group/port hear each other (small and fragmented)."""

    def test_publish_and_receive(self):
        port = 20000 + (os.getpid() * 7 + 3) % 40000
        url = f"udpm://239.255.76.67:{port}?ttl=0"
        got = []
        with LcmUdp(url) as rx, LcmUdp(url) as tx:
            rx.subscribe("LOOP_.*", lambda ch, data: got.append((ch, data)))
            big = bytes(range(256)) * 40
            deadline = time.monotonic() + 5
            while len(got) < 2 and time.monotonic() < deadline:
                got.clear()
                tx.publish("LOOP_SMALL", b"hello")
                tx.publish("LOOP_BIG", big)
                tx.publish("OTHER", b"not subscribed")
                end = time.monotonic() + 0.3
                while len(got) < 2 and time.monotonic() < end:
                    rx.handle(0.05)
        self.assertEqual(got, [("LOOP_SMALL", b"hello"), ("LOOP_BIG", big)])


if __name__ == "__main__":
    unittest.main()
