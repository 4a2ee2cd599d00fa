"""Opening a MAVLink 2 link to a vehicle: connection strings, signing, heartbeats.

Connection strings are pymavlink's: `udpout:HOST:PORT` (we send first), `udpin:HOST:PORT`
(we listen), `tcp:HOST:PORT`, `tcpin:HOST:PORT`, or a serial device `/dev/ttyUSB0` with
`baud`. Signing (MAVLink 2): a 32-byte secret key, given as 64 hex digits or derived from a
passphrase by SHA-256 (as MAVProxy and QGroundControl do); outgoing packets are signed and
incoming ones must carry a valid signature unless `accept_unsigned` is set (for vehicles
that do not sign, such as the mavsdk test peer).
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from pymavlink import mavutil

from mound.errors import InputError

if TYPE_CHECKING:
    from pymavlink.dialects.v20.ardupilotmega import MAVLink_message

GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = 190  # MAV_COMP_ID_MISSIONPLANNER
MAV_TYPE_GCS = 6
MAV_AUTOPILOT_INVALID = 8


class LinkError(RuntimeError):
    """The link or the vehicle failed (no heartbeat, no answer, a rejected mission)."""


def signing_key(hex_key: str | None = None, passphrase: str | None = None) -> bytes | None:
    if hex_key is not None and passphrase is not None:
        raise InputError("signing: give a key or a passphrase, not both")
    if passphrase is not None:
        return hashlib.sha256(passphrase.encode("utf-8")).digest()
    if hex_key is None:
        return None
    try:
        key = bytes.fromhex(hex_key)
    except ValueError as e:
        raise InputError("--signing-key: expected 64 hexadecimal digits") from e
    if len(key) != 32:
        raise InputError(f"--signing-key: expected 32 bytes (64 hex digits), got {len(key)}")
    return key


@dataclass
class Link:
    conn: Any              # pymavlink mavfile
    target_system: int
    target_component: int
    last_heartbeat_s: float = 0.0

    def heartbeat(self, every_s: float = 1.0) -> None:
        """Sends our GCS heartbeat if the last one is older than `every_s`."""
        now = time.monotonic()
        if now - self.last_heartbeat_s >= every_s:
            self.conn.mav.heartbeat_send(MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID, 0, 0, 0)
            self.last_heartbeat_s = now

    def recv(self, types: list[str], timeout_s: float) -> MAVLink_message | None:
        """The next message of `types` from the target (or None at the time-out)."""
        deadline = time.monotonic() + timeout_s
        while True:
            self.heartbeat()
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            msg = self.conn.recv_match(type=types, blocking=True, timeout=min(left, 0.25))
            if msg is None:
                continue
            if msg.get_srcSystem() != self.target_system:
                continue
            target = getattr(msg, "target_system", None)
            if target not in (None, 0, GCS_SYSTEM_ID):
                continue
            return msg

    def close(self) -> None:
        self.conn.close()


def open_conn(connect: str, key: bytes | None = None, accept_unsigned: bool = False,
              baud: int = 57600, source_system: int = GCS_SYSTEM_ID) -> mavutil.mavfile:
    """A pymavlink connection (MAVLink 2, signed if `key`)."""
    if not connect:
        raise InputError("--connect: empty connection string")
    try:
        conn = mavutil.mavlink_connection(connect, baud=baud, source_system=source_system,
                                          source_component=GCS_COMPONENT_ID, autoreconnect=False)
    except Exception as e:  # pymavlink raises bare exceptions for bad strings / ports
        raise InputError(f"--connect {connect!r}: cannot open ({e})") from e
    if key is not None:
        conn.setup_signing(key, sign_outgoing=True,
                           allow_unsigned_callback=(lambda _mav, _msg_id: True)
                           if accept_unsigned else None)
    return conn


def connect(connect: str, key: bytes | None = None, accept_unsigned: bool = False,
            timeout_s: float = 5.0, baud: int = 57600) -> Link:
    """Opens the link and waits for a vehicle's heartbeat (not a ground station's)."""
    conn = open_conn(connect, key, accept_unsigned, baud)
    link = Link(conn, 0, 0)
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        link.heartbeat(every_s=0.5)
        msg = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.25)
        if msg is not None and msg.type != MAV_TYPE_GCS:
            link.target_system = msg.get_srcSystem()
            link.target_component = msg.get_srcComponent()
            return link
    conn.close()
    signed = " (does the signing key match?)" if key is not None else ""
    raise LinkError(f"no heartbeat from a vehicle on {connect} within {timeout_s:g} s: is it "
                    f"on and is the address right?{signed}")
