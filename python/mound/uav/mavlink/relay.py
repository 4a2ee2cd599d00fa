"""A loopback UDP relay that drops datagrams: a lossy radio link for tests and benchmarks.

The ground station sends to the relay's port; the relay forwards to the vehicle's port
from its own socket and sends the vehicle's answers back to the last ground-station
address. Each datagram is dropped with probability `loss` in either direction (seeded,
independent per direction); `drop_down_msgids` drops every vehicle-to-ground datagram with
one of those MAVLink 2 message ids (e.g. 47, MISSION_ACK). Plain sockets.
"""

from __future__ import annotations

import random
import select
import socket
import threading


def _msgid(datagram: bytes) -> int | None:
    """The message id of a datagram holding one MAVLink 2 frame (0xFD magic)."""
    if len(datagram) >= 10 and datagram[0] == 0xFD:
        return datagram[7] | datagram[8] << 8 | datagram[9] << 16
    return None


class LossyRelay:
    def __init__(self, vehicle_port: int, loss: float, seed: int = 0,
                 host: str = "127.0.0.1", drop_down_msgids: frozenset[int] = frozenset()
                 ) -> None:
        if not 0 <= loss < 1:
            raise ValueError("loss must be in [0, 1)")
        self.loss = loss
        self.drop_down_msgids = drop_down_msgids
        self.vehicle = (host, vehicle_port)
        self.gcs_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.gcs_side.bind((host, 0))
        self.vehicle_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.vehicle_side.bind((host, 0))
        self.port = self.gcs_side.getsockname()[1]
        self._rng_up = random.Random(seed)
        self._rng_down = random.Random(seed + 1)
        self._gcs_addr: tuple[str, int] | None = None
        self._stop = threading.Event()
        self.forwarded = [0, 0]  # up (to the vehicle), down
        self.dropped = [0, 0]
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self) -> LossyRelay:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        self.gcs_side.close()
        self.vehicle_side.close()

    def _run(self) -> None:
        socks = [self.gcs_side, self.vehicle_side]
        while not self._stop.is_set():
            ready, _, _ = select.select(socks, [], [], 0.05)
            for s in ready:
                data, addr = s.recvfrom(65536)
                if s is self.gcs_side:
                    self._gcs_addr = addr
                    if self._rng_up.random() < self.loss:
                        self.dropped[0] += 1
                    else:
                        self.vehicle_side.sendto(data, self.vehicle)
                        self.forwarded[0] += 1
                elif self._gcs_addr is not None:
                    if self._rng_down.random() < self.loss or _msgid(data) in \
                            self.drop_down_msgids:
                        self.dropped[1] += 1
                    else:
                        self.gcs_side.sendto(data, self._gcs_addr)
                        self.forwarded[1] += 1
