"""motionclient.Client reads a motionbus configuration as the programs do: lcm.url and
lcm.channel_prefix (ctest clients_python_config). A client on the default prefix would talk to
nobody on a lab whose configuration sets another one.

    python3 -m unittest test_client_config      (from tools/clients/python, types on PYTHONPATH)
"""
import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from motionclient import REQUEST_TIMEOUT, Client  # noqa: E402

CONFIG = """\
lcm:
  url: "udpm://239.255.76.67:%d?ttl=0"
  channel_prefix: "LAB7_"
buses:
  - {name: can0, transport: "simcan:can0"}
"""


class ClientFromConfig(unittest.TestCase):
    def setUp(self):
        self.port = 20000 + (os.getpid() * 13) % 40000
        self.dir = tempfile.TemporaryDirectory()
        self.path = os.path.join(self.dir.name, "lab.yaml")
        with open(self.path, "w") as f:
            f.write(CONFIG % self.port)

    def tearDown(self):
        self.dir.cleanup()

    def test_url_and_prefix_come_from_the_file(self):
        client = Client.from_config(self.path, client_id="t")
        try:
            self.assertEqual(client.prefix, "LAB7_")
            self.assertEqual(client.channel("REQUEST"), "LAB7_REQUEST")
            self.assertIn(":%d" % self.port, client.url)
        finally:
            client.close()

    def test_arguments_override_the_file(self):
        other = "udpm://239.255.76.67:%d?ttl=0" % (self.port + 1)
        client = Client.from_config(self.path, url=other, prefix="X_", client_id="t")
        try:
            self.assertEqual(client.prefix, "X_")
            self.assertIn(":%d" % (self.port + 1), client.url)
        finally:
            client.close()

    def test_a_missing_file_says_which(self):
        with self.assertRaises(OSError) as caught:
            Client.from_config(os.path.join(self.dir.name, "nope.yaml"))
        self.assertIn("nope.yaml", str(caught.exception))

    def test_the_default_request_timeout_is_the_one_of_every_client(self):
        self.assertEqual(REQUEST_TIMEOUT, 60.0)  # C++ Client::kRequestTimeout, Java, Lua


if __name__ == "__main__":
    unittest.main()
