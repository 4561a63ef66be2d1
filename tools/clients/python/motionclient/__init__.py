"""motionclient: Python client of the motion system over LCM UDP multicast (no LCM binding needed).

    from motionclient import Client
    with Client("udpm://239.255.76.67:7667?ttl=0") as c:
        print(c.request("enable", ["x", "y"]).reason)

Needs the lcm-gen Python types (build/lcmtypes/python) on PYTHONPATH for Client; the transport
(motionclient.lcm_udp) needs nothing but the standard library; signing (motionclient.signing)
needs python3-nacl:

    from motionclient import Client, load_private_key, key_path
    c = Client(url, key=load_private_key(key_path(None)))   # $MOTION_KEY
"""

from .lcm_udp import LcmUdp, Reassembler, encode_datagrams, parse_url  # noqa: F401
from .signing import (GatewayKey, KeyFileError, RequestSigner, SigningKey, key_path, load_gateway_keys,  # noqa: F401
                      load_private_key)

try:
    from .client import (Client, RequestFailed, UNAUTHORIZED, is_terminal, kind_value, status_name,  # noqa: F401
                         HEALTH_STATES, KINDS, TERMINAL, REQUEST_TIMEOUT)
except ImportError as _e:  # the types are missing: the transport still works, Client explains
    _import_error = _e

    def __getattr__(name):
        if name in ("Client", "RequestFailed", "UNAUTHORIZED", "is_terminal", "kind_value", "status_name", "HEALTH_STATES", "KINDS",
                    "TERMINAL", "REQUEST_TIMEOUT"):
            raise ImportError(str(_import_error))
        raise AttributeError(name)
