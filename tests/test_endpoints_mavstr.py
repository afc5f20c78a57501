"""common.mavlink.endpoints (pymavlink connection strings) and common.mavlink.mavstr (MAVLink char[] fields)."""
from __future__ import annotations

import pytest

from common.mavlink.endpoints import parse_connection
from common.mavlink.mavstr import mav_str
from vehicle.link.endpoints import parse_endpoint


@pytest.mark.parametrize("url, want", [
    ("udpin:127.0.0.1:14560", ("udpin", "127.0.0.1", 14560)),
    ("udp:0.0.0.0:14550", ("udpin", "0.0.0.0", 14550)),          # pymavlink's alias
    ("UDPOUT:10.0.0.2:14550", ("udpout", "10.0.0.2", 14550)),
    ("tcp:localhost:5760", ("tcp", "localhost", 5760)),
    ("tcpin::5760", ("tcpin", "127.0.0.1", 5760)),               # empty host: the default
])
def test_parse_connection(url, want):
    assert parse_connection(url) == want


@pytest.mark.parametrize("url, says", [
    ("udpin:127.0.0.1", "bad connection string 'udpin:127.0.0.1'"),
    ("udpin:127.0.0.1:port", "bad connection string"),
    ("serial:/dev/ttyUSB0:57600", "unsupported connection kind 'serial'"),
    ("udpin:127.0.0.1:0", "bad port"),
    ("udpin:127.0.0.1:70000", "bad port"),
])
def test_parse_connection_errors_are_value_errors_that_teach(url, says):
    with pytest.raises(ValueError, match=says) as e:
        parse_connection(url)
    assert "udpin:HOST:PORT" in str(e.value) or "ports are" in str(e.value)


def test_vehicle_serves_its_own_kinds_and_listens_on_all_interfaces_by_default():
    assert parse_endpoint("tcpin::5760") == ("tcpin", "0.0.0.0", 5760)
    with pytest.raises(ValueError, match="unsupported connection kind 'tcp'"):
        parse_endpoint("tcp:127.0.0.1:5760")    # a vehicle does not dial out over TCP


@pytest.mark.parametrize("raw, want", [
    (b"WPNAV_SPEED\x00\x00\x00\x00\x00", "WPNAV_SPEED"),
    ("drone_yaw\x00junk", "drone_yaw"),              # whatever follows the NUL is not the string
    (bytearray(b"tower"), "tower"),
    (b"SIXTEEN_CHARS_ID", "SIXTEEN_CHARS_ID"),        # a full field has no NUL at all
    (b"bad\xffbyte\x00", "bad\ufffdbyte"),             # never raises on bad UTF-8
    ("", ""),
])
def test_mav_str(raw, want):
    assert mav_str(raw) == want
