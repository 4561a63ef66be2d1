"""Gateway-signed axis states in the Python client (ctest clients_python_state_verification):
 1. the gateway's signed state of tests/vectors/signed_state_v1.txt (the bytes the C++
    MessageSigner produces) verifies here, byte for byte, under a key for every bus and a key bound
    to buses including the state's, and is refused from a key bound to another bus, replayed,
    altered, stale or under a key that is not a gateway key;
 2. load_gateway_keys reads only the gateway keys of an authorized_keys file, with their buses, and
    names every bad line;
 3. a Client after verify_states_with(keys): a plain forged state, one signed with a stranger's
    key, a tampered one, a replayed one and one from a key bound to another bus change nothing
    (the signed ones are counted in forged_states); the gateways' signed states are taken; without
    verify_states_with the plain state is taken and states_verified is False.

    PYTHONPATH=build/lcmtypes/python:tools/clients/python python3 -m unittest -v test_state_verification
"""
import os
import tempfile
import time
import unittest

from motionlcm import axis_state_t, signed_message_t
from motionclient.client import Client
from motionclient.signing import (KeyFileError, MessageSigner, MessageVerifier, SigningKey, _message_bytes,
                                  load_gateway_keys, load_private_key)
from test_signing import FakeLcm, read_vector

VECTOR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "tests", "vectors",
                      "signed_state_v1.txt")
OPERATOR_LINE = "A6EHv/POEL4dcN0Y50vAmWfk1jCbpQ1fHdyGZBJVMbg= alice operate"


def bus_of(state):
    return state.bus


class StateVector(unittest.TestCase):
    def setUp(self):
        self.v = read_vector(VECTOR)
        self.dir = tempfile.TemporaryDirectory()
        self.envelope = signed_message_t.decode(bytes.fromhex(self.v["envelope_hex"]))
        self.at = int(self.v["utime"])

    def tearDown(self):
        self.dir.cleanup()

    def keys(self, *lines):
        path = os.path.join(self.dir.name, "authorized_keys")
        with open(path, "w", encoding="utf-8") as f:
            f.write("# the lab's principals\n" + OPERATOR_LINE + "\n" + "\n".join(lines) + "\n")
        return load_gateway_keys(path)

    def verifier(self, keys, not_before_us=None):
        return MessageVerifier(keys, self.v["prefix"], "AXIS_STATE", 2000,
                               self.at - 1000 if not_before_us is None else not_before_us, signers_are="a gateway key")

    def test_python_signs_the_bytes_of_the_cpp_gateway(self):
        path = os.path.join(self.dir.name, "vector.key")
        with open(path, "w", encoding="utf-8") as f:
            f.write(self.v["key_file_line"] + "\n")
        os.chmod(path, 0o600)
        key = load_private_key(path)
        self.assertEqual(key.public_key.hex(), self.v["public_key_hex"])
        state = axis_state_t.decode(bytes.fromhex(self.v["message_hex"]))
        e = MessageSigner(key, self.v["prefix"]).sign("AXIS_STATE", state, self.at)
        self.assertEqual(_message_bytes(self.v["prefix"], "AXIS_STATE", e).hex(), self.v["signed_bytes_hex"])
        self.assertEqual(e.encode().hex(), self.v["envelope_hex"])

    def test_the_cpp_gateways_state_verifies_from_a_key_of_every_bus_or_of_its_bus(self):
        for line in ("authorized_every_bus", "authorized_bound"):
            verifier = self.verifier(self.keys(self.v[line]))
            state, why = verifier.verify_message(self.envelope, self.at + 500, axis_state_t, bus_of)
            self.assertIsNotNone(state, f"{line}: {why}")
            self.assertEqual((state.axis, state.bus, state.position, state.inputs), ("x", "can0", 10.5, 3))
            self.assertEqual(state.encode().hex(), self.v["message_hex"])
            again, why = verifier.verify_message(self.envelope, self.at + 600, axis_state_t, bus_of)
            self.assertIsNone(again)
            self.assertEqual(why, self.v["refused_replayed"])

    def test_a_key_bound_to_another_bus_vouches_for_nothing_of_this_bus(self):
        verifier = self.verifier(self.keys(self.v["authorized_other_bus"]))
        state, why = verifier.verify_message(self.envelope, self.at + 500, axis_state_t, bus_of)
        self.assertIsNone(state)
        self.assertEqual(why, self.v["refused_other_bus"])

    def test_altered_stale_and_foreign_states_are_refused(self):
        keys = self.keys(self.v["authorized_every_bus"])
        altered = signed_message_t.decode(bytes.fromhex(self.v["envelope_hex"]))
        altered.message = altered.message[:-20] + bytes([altered.message[-20] ^ 1]) + altered.message[-19:]
        _, why = self.verifier(keys).verify_message(altered, self.at, axis_state_t, bus_of)
        self.assertEqual(why, "signed AXIS_STATE refused: bad signature (forged or altered in transit)")
        _, why = self.verifier(keys, 0).verify_message(self.envelope, self.at + 2_500_000, axis_state_t, bus_of)
        self.assertEqual(why, "signed AXIS_STATE refused: stale timestamp: signed 2500 ms ago, outside the window of "
                              "2000 ms (clocks out of sync, or a replay)")
        stranger = SigningKey(bytes(32), "stranger")
        _, why = self.verifier([stranger.public_key]).verify_message(self.envelope, self.at, axis_state_t, bus_of)
        self.assertEqual(why, f"signed AXIS_STATE refused: key {self.v['public_key_hex'][:16]} is not a gateway key")

    def test_only_gateway_keys_are_loaded_with_their_buses(self):
        keys = self.keys(self.v["authorized_bound"], "O2onvM62pC1io6jQKm8Nc2UyFXcd4kOmOsBIoYtZ2ik= gw2 gateway")
        self.assertEqual([(k.name, k.buses) for k in keys], [("vector", ("rs485a", "can0")), ("gw2", None)])
        self.assertTrue(keys[0].vouches_for("can0") and not keys[0].vouches_for("can1") and keys[1].vouches_for("can1"))

    def test_bad_lines_are_named(self):
        with self.assertRaises(KeyFileError) as e:
            self.keys(self.v["authorized_every_bus"] + " extra more", OPERATOR_LINE.replace("alice", "bob") + " buses=can0",
                      self.v["authorized_other_bus"].replace("rs485a", "").replace("vector", "v2"),
                      "O2onvM62pC1io6jQKm8Nc2UyFXcd4kOmOsBIoYtZ2ik= gw2 gateway busses=can0")
        lines = str(e.exception).splitlines()
        self.assertEqual(len(lines), 4, str(e.exception))
        self.assertTrue(lines[0].endswith(":3: expected '<base64 public key> <name> <role> [buses=<bus>,...]', "
                                          "got 5 fields"), lines[0])
        self.assertTrue(lines[1].endswith(":4: buses= binds a key of role gateway to buses; 'bob' has role operate"),
                        lines[1])
        self.assertTrue(lines[2].endswith(":5: expected 'buses=<bus>[,<bus>...]' after the role, got 'buses='"), lines[2])
        self.assertTrue(lines[3].endswith(":6: expected 'buses=<bus>[,<bus>...]' after the role, got 'busses=can0'"),
                        lines[3])
        with self.assertRaisesRegex(KeyFileError, "has no key of role gateway"):
            self.keys()


class ClientStates(unittest.TestCase):
    """A client holding the gateway keys takes only states they signed, for their buses."""

    def setUp(self):
        self.gateway = SigningKey(bytes([4]) * 32, "gateway-can0")
        self.rs485 = SigningKey(bytes([5]) * 32, "gateway-rs485a")
        self.dir = tempfile.TemporaryDirectory()
        path = os.path.join(self.dir.name, "authorized_keys")
        import base64
        with open(path, "w", encoding="utf-8") as f:
            for key, buses in ((self.gateway, "can0"), (self.rs485, "rs485a")):
                f.write(f"{base64.b64encode(key.public_key).decode()} {key.name} gateway buses={buses}\n")
        self.keys = load_gateway_keys(path)
        self.lcm = FakeLcm()
        self.client = Client(lcm=self.lcm, client_id="py-test")
        self.seen = []
        self.client.on_axis_state(self.seen.append)

    def tearDown(self):
        self.dir.cleanup()

    @staticmethod
    def state(position, fault=False, bus="can0"):
        s = axis_state_t()
        s.utime = s.sample_utime = int(time.time() * 1e6)
        s.axis, s.family, s.bus, s.fault_text = "x", "uim342", bus, ""
        s.position, s.fault = position, fault
        return s

    def signed(self, key, state):
        return MessageSigner(key, "MOTION_").sign("AXIS_STATE", state, int(time.time() * 1e6))

    def test_without_verifying_plain_states_are_taken_unverified(self):
        self.lcm.deliver("MOTION_AXIS_STATE", self.state(1.0).encode())
        self.assertFalse(self.client.states_verified)
        self.assertEqual(self.client.axis_states()["x"].position, 1.0)

    def test_only_states_a_gateway_key_signed_for_its_bus_are_taken(self):
        self.lcm.deliver("MOTION_AXIS_STATE", self.state(1.0).encode())  # taken before verifying: forgotten
        self.client.verify_states_with(self.keys, window_ms=2000)
        self.assertTrue(self.client.states_verified)
        self.assertEqual(self.client.axis_states(), {})
        del self.seen[:]
        genuine = self.signed(self.gateway, self.state(2.0))
        self.lcm.deliver("MOTION_SAXIS_STATE", genuine.encode())
        self.assertEqual([s.position for s in self.seen], [2.0])
        lie = self.state(99.0, fault=True)
        self.lcm.deliver("MOTION_AXIS_STATE", lie.encode())  # plain forged: ignored, like every plain copy
        self.lcm.deliver("MOTION_SAXIS_STATE", self.signed(SigningKey(bytes([9]) * 32, "gateway-can0"), lie).encode())
        tampered = self.signed(self.gateway, lie)
        tampered.signature = bytes(tampered.signature[:7]) + bytes([tampered.signature[7] ^ 0x20]) + \
            bytes(tampered.signature[8:])
        self.lcm.deliver("MOTION_SAXIS_STATE", tampered.encode())
        self.lcm.deliver("MOTION_SAXIS_STATE", genuine.encode())  # replayed
        self.lcm.deliver("MOTION_SAXIS_STATE", self.signed(self.rs485, lie).encode())  # rs485a's key, bus can0
        self.assertEqual([s.position for s in self.seen], [2.0])
        self.assertEqual(self.client.axis_states()["x"].position, 2.0)
        self.assertEqual(self.client.forged_states, 4)
        # The rs485a gateway's key vouches for its own bus, and can0's goes on after its refusals.
        self.lcm.deliver("MOTION_SAXIS_STATE", self.signed(self.rs485, self.state(3.0, bus="rs485a")).encode())
        self.lcm.deliver("MOTION_SAXIS_STATE", self.signed(self.gateway, self.state(4.0)).encode())
        self.assertEqual([(s.bus, s.position) for s in self.seen], [("can0", 2.0), ("rs485a", 3.0), ("can0", 4.0)])
        self.assertEqual(self.client.forged_states, 4)


if __name__ == "__main__":
    unittest.main()
