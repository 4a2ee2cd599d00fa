"""A real, independently written vehicle side for tests and benchmarks: MAVSDK (PyPI
`mavsdk` 4.x, the C++ library through ctypes) in-process as an autopilot
(ComponentType.AUTOPILOT) with its MissionRawServer plugin, on a loopback port. It stores
uploaded missions, serves them back on download, and re-requests missing items after about
0.5 s. It does not verify MAVLink signatures."""

from __future__ import annotations

import socket
import threading
import time
from typing import Any


def free_port(kind: int = socket.SOCK_DGRAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class MavsdkVehicle:
    """`with MavsdkVehicle("udpin") as v:` then connect a ground station to v.connect_string
    (udpout:127.0.0.1:PORT, or tcp:127.0.0.1:PORT for kind="tcpin"); kind="serial" opens
    `serial_device` at 57600 baud."""

    def __init__(self, kind: str = "udpin", port: int | None = None,
                 serial_device: str | None = None) -> None:
        from mavsdk import ComponentType, Configuration, Mavsdk, log_subscribe
        from mavsdk.plugins.mission_raw_server.mission_raw_server import MissionRawServer

        self.log: list[str] = []  # MAVSDK's own log lines, kept off the console
        def keep(level: Any, message: str, _file: str, _line: int) -> None:
            self.log.append(f"{level.name}: {message}")

        log_subscribe(keep)

        self.port = port or free_port(socket.SOCK_STREAM if kind == "tcpin" else
                                      socket.SOCK_DGRAM)
        self._mavsdk = Mavsdk(Configuration.create_with_component_type(ComponentType.AUTOPILOT))
        url = (f"serial://{serial_device}:57600" if kind == "serial"
               else f"{kind}://127.0.0.1:{self.port}")
        result = self._mavsdk.add_any_connection(url)
        if result.name != "SUCCESS":
            raise RuntimeError(f"mavsdk: cannot open {url}: {result}")
        self.connect_string = {"udpin": f"udpout:127.0.0.1:{self.port}",
                               "tcpin": f"tcp:127.0.0.1:{self.port}"}.get(kind, "")
        self._server = MissionRawServer(self._mavsdk.server_component(0))
        self._lock = threading.Lock()
        self.missions: list[list[Any]] = []
        self.failed_transfers: list[str] = []
        self._server.subscribe_incoming_mission(self._on_mission)

    def _on_mission(self, result: Any, plan: Any, _user: Any) -> None:
        with self._lock:  # an abandoned transfer is reported too, with an empty plan
            if result.name == "SUCCESS":
                self.missions.append(list(plan.mission_items))
            else:
                self.failed_transfers.append(result.name)

    def wait_for_mission(self, count: int = 1, timeout_s: float = 5.0) -> list[Any]:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self._lock:
                if len(self.missions) >= count:
                    return self.missions[count - 1]
            time.sleep(0.01)
        raise TimeoutError(f"mavsdk vehicle: no mission #{count} within {timeout_s} s")

    def __enter__(self) -> MavsdkVehicle:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self._server.destroy()
        self._mavsdk.destroy()
