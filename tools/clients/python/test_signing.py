"""Signing in the Python client against the cross-language vector (tests/vectors/signed_request_v1.txt,
the bytes the C++ code produces): key file, payload, signed bytes, signature and the encoded
signed_request_t; and the key file rules (mode 0600, one key line) and $MOTION_KEY.

    PYTHONPATH=build/lcmtypes/python:tools/clients/python python3 -m unittest -v test_signing
"""
import base64
import os
import tempfile
import time
import unittest

from motionlcm import param_t, reply_t, request_t
from motionclient.client import Client
from motionclient.signing import (KeyFileError, MessageSigner, RequestSigner, SigningKey, key_path, load_private_key,
                                  load_public_key, signed_bytes)

VECTOR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "tests", "vectors",
                      "signed_request_v1.txt")


def read_vector(path=VECTOR):
    v = {}
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.rstrip("\n")
            if line and not line.startswith("#") and " = " in line:
                name, value = line.split(" = ", 1)
                v[name] = value
    return v


class SigningVector(unittest.TestCase):
    def setUp(self):
        self.v = read_vector()
        self.dir = tempfile.TemporaryDirectory()
        self.key_file = os.path.join(self.dir.name, "vector.key")
        self.write(self.key_file, "# the vector's key\n" + self.v["key_file_line"] + "\n", 0o600)

    def tearDown(self):
        self.dir.cleanup()

    @staticmethod
    def write(path, text, mode):
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        os.chmod(path, mode)

    def request(self):
        v = self.v
        r = request_t()
        r.utime = int(v["request.utime"])
        r.client_id = v["request.client_id"]
        r.request_id = int(v["request.request_id"])
        r.kind = int(v["request.kind"])
        r.axes = v["request.axes"].split()
        r.values = [float(x) for x in v["request.values"].split()]
        r.num_axes = len(r.axes)
        r.velocity_scale = float(v["request.velocity_scale"])
        r.acceleration_scale = float(v["request.acceleration_scale"])
        r.timeout_ms = int(v["request.timeout_ms"])
        r.output_mask = int(v["request.output_mask"])
        r.output_value = int(v["request.output_value"])
        r.param = param_t()
        return r

    def test_key_file_gives_the_vectors_key(self):
        key = load_private_key(self.key_file)
        self.assertEqual(key.name, self.v["key_name"])
        self.assertEqual(key.public_key.hex(), self.v["public_key_hex"])
        self.assertEqual(key.key_id.hex(), self.v["key_id_hex"])

    def test_signer_produces_the_bytes_of_the_cpp_code(self):
        signer = RequestSigner(load_private_key(self.key_file), self.v["prefix"])
        e = signer.sign(self.request(), int(self.v["utime"]))
        self.assertEqual(str(e.counter), self.v["counter"])
        self.assertEqual(e.payload.hex(), self.v["payload_hex"])
        self.assertEqual(signed_bytes(self.v["prefix"], e.key_id, e.counter, e.utime, e.payload).hex(),
                         self.v["signed_bytes_hex"])
        self.assertEqual(bytes(e.signature).hex(), self.v["signature_hex"])
        self.assertEqual(e.encode().hex(), self.v["envelope_hex"])
        # The next request of the same run: the counter goes on even when the clock does not.
        self.assertEqual(signer.sign(self.request(), int(self.v["utime"])).counter, int(self.v["counter"]) + 1)

    def test_own_client_id(self):
        signer = RequestSigner(load_private_key(self.key_file), "MOTION_")
        self.assertEqual(signer.own_client_id("vector"), "vector")
        self.assertEqual(signer.own_client_id("vector/tool"), "vector/tool")
        self.assertEqual(signer.own_client_id("vectors"), "vector/vectors")

    def test_key_file_readable_by_others_is_refused(self):
        os.chmod(self.key_file, 0o644)
        with self.assertRaisesRegex(KeyFileError, r"is readable by group/others \(mode 0644\); chmod 600 it"):
            load_private_key(self.key_file)

    def test_public_key_file_or_two_keys_are_refused(self):
        pub = os.path.join(self.dir.name, "vector.pub")
        self.write(pub, "11qYAYKxCrfVS/7TyWQHOg7hcvPaoiMlrwIaaPcHURo= vector operate\n", 0o600)
        with self.assertRaisesRegex(KeyFileError, r"vector.pub:1: expected 'motionbus-ed25519-private-key"):
            load_private_key(pub)
        self.write(self.key_file, self.v["key_file_line"] + "\n" + self.v["key_file_line"] + "\n", 0o600)
        with self.assertRaisesRegex(KeyFileError, r":2: a second key line"):
            load_private_key(self.key_file)

    def test_key_path_is_the_option_else_motion_key(self):
        saved = os.environ.pop("MOTION_KEY", None)
        try:
            self.assertIsNone(key_path(None))
            os.environ["MOTION_KEY"] = "/env.key"
            self.assertEqual(key_path(None), "/env.key")
            self.assertEqual(key_path("/option.key"), "/option.key")
        finally:
            os.environ.pop("MOTION_KEY", None)
            if saved is not None:
                os.environ["MOTION_KEY"] = saved


if __name__ == "__main__":
    unittest.main()

class FakeLcm:
    """Records subscriptions and publications: the test delivers messages to the handlers itself."""
    url = "fake://"

    def __init__(self):
        self.handlers = {}
        self.published = []

    def subscribe(self, channel, handler):
        self.handlers[channel] = handler
        return len(self.handlers)

    def publish(self, channel, payload):
        self.published.append((channel, payload))

    def deliver(self, channel, payload):
        self.handlers[channel](channel, payload)

    def close(self):
        pass


class ReplyVerification(unittest.TestCase):
    """A client holding the coordinator's public key takes only replies the coordinator signed
    (SREPLY): a forged REPLY, plain or signed with another key, does not end the request."""

    def setUp(self):
        self.coordinator = SigningKey(bytes([3]) * 32, "coordinator")
        self.lcm = FakeLcm()
        self.client = Client(lcm=self.lcm, client_id="py-test")
        self.client.verify_with(self.coordinator.public_key, window_ms=2000)
        self.seen = []
        self.rid = self.client.send("move_absolute", ["x"], [1.0], on_reply=self.seen.append)

    def reply(self, status, reason):
        r = reply_t()
        r.utime = int(time.time() * 1e6)
        r.client_id = "py-test"
        r.request_id = self.rid
        r.status = status
        r.reason = reason
        r.param = param_t()
        return r

    def test_forged_replies_do_not_end_the_request_and_the_coordinators_does(self):
        lie = self.reply(reply_t.FAILED, "forged")
        self.lcm.deliver("MOTION_REPLY", lie.encode())
        impostor = MessageSigner(SigningKey(bytes([9]) * 32, "coordinator"), "MOTION_")
        self.lcm.deliver("MOTION_SREPLY", impostor.sign("REPLY", lie, int(time.time() * 1e6)).encode())
        self.assertEqual(self.seen, [])
        self.assertEqual(self.client.forged_replies, 1)
        done = self.reply(reply_t.DONE, "")
        signer = MessageSigner(self.coordinator, "MOTION_")
        recorded = signer.sign("REPLY", done, int(time.time() * 1e6))
        self.lcm.deliver("MOTION_SREPLY", recorded.encode())
        self.assertEqual([r.status for r in self.seen], [reply_t.DONE])
        # Sent again (replayed counter): not a reply either, even for a request still pending.
        self.rid = self.client.send("move_absolute", ["x"], [2.0], on_reply=self.seen.append)
        self.lcm.deliver("MOTION_SREPLY", recorded.encode())
        self.assertEqual(len(self.seen), 1)

    def test_public_key_file_as_keygen_writes_it(self):
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "coordinator.pub")
            with open(path, "w", encoding="utf-8") as f:
                f.write(base64.b64encode(self.coordinator.public_key).decode() + " coordinator admin\n")
            self.assertEqual(load_public_key(path), self.coordinator.public_key)



class LossyCoordinator(FakeLcm):
    """A coordinator behind a lossy network, scripted per request copy: each REQUEST published is
    answered with the replies of `script` (one list per copy sent, in order); an empty list is a
    request (or all its replies) lost."""

    def __init__(self, script):
        super().__init__()
        self.script = list(script)
        self.requests = []
        self.queue = []

    def publish(self, channel, payload):
        super().publish(channel, payload)
        if channel.endswith("REQUEST"):
            r = request_t.decode(payload)
            self.requests.append(r)
            for status in (self.script.pop(0) if self.script else []):
                reply = reply_t()
                reply.client_id, reply.request_id, reply.status = r.client_id, r.request_id, status
                reply.param = param_t()
                self.queue.append(reply)

    def handle(self, timeout):
        if self.queue:
            self.deliver(self.reply_channel, self.queue.pop(0).encode())
            return True
        time.sleep(min(timeout, 0.01))
        return False


class LostDatagrams(unittest.TestCase):
    """request() sends a request again while nothing is heard of it, so a lost request or a lost
    terminal reply costs a fraction of a second, not the whole timeout (README "Safety and faults")."""

    def client_for(self, lcm):
        client = Client(lcm=lcm, client_id="py-test")
        lcm.reply_channel = client.channel("REPLY")
        return client

    def test_a_lost_request_is_sent_again_unchanged(self):
        lcm = LossyCoordinator([[], [reply_t.ACCEPTED, reply_t.DONE]])
        client = self.client_for(lcm)
        reply = client.request("enable", ["x"], timeout=5.0)
        self.assertEqual(reply.status, reply_t.DONE, reply.reason)
        self.assertEqual(len(lcm.requests), 2)
        first, again = lcm.requests
        self.assertEqual((again.client_id, again.request_id, again.kind, again.axes),
                         (first.client_id, first.request_id, first.kind, first.axes))
        self.assertEqual(client.resent, 1)

    def test_a_lost_terminal_reply_is_asked_for_again(self):
        lcm = LossyCoordinator([[reply_t.ACCEPTED], [reply_t.DONE]])
        client = self.client_for(lcm)
        reply = client.request("enable", ["x"], timeout=5.0)
        self.assertEqual(reply.status, reply_t.DONE, reply.reason)
        self.assertEqual(len(lcm.requests), 2)

    def test_silence_still_fails_within_the_accept_timeout(self):
        lcm = LossyCoordinator([])
        client = self.client_for(lcm)
        reply = client.request("enable", ["x"], timeout=5.0)
        self.assertEqual(reply.status, reply_t.FAILED)
        self.assertIn("no reply from the coordinator within 2000 ms", reply.reason)
        self.assertEqual(len(lcm.requests), 4)  # at 0, 0.5, 1.0 and 1.5 s
