"""A real, independently written vehicle side for tests and benchmarks: MAVSDK (PyPI
`mavsdk` 4.x, the C++ library through ctypes) in-process as an autopilot
(ComponentType.AUTOPILOT) with its MissionRawServer plugin, on a loopback port. It stores
uploaded missions, serves them back on download, and re-requests missing items after about
0.5 s. It does not verify MAVLink signatures.

`fly()` adds an aircraft: it flies the mission it holds at a set speed, completing items
through the server (MISSION_ITEM_REACHED, MISSION_CURRENT), and publishes BATTERY_STATUS
through MAVSDK's telemetry server, the charge falling with the distance flown. MAVSDK's
server resets the current item to 0 when a new mission arrives; the aircraft then holds
where it is until the ground station sets the current item (or 2 s pass), as a ground
station replacing a mission in flight must."""

from __future__ import annotations

import math
import socket
import threading
import time
from typing import Any

NAV_WAYPOINT, NAV_RTL, NAV_LAND, NAV_TAKEOFF = 16, 20, 21, 22
EARTH_RADIUS_M = 6_378_137.0


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
        self.current = 0               # the current item, as the server last said
        self._reset_pending = False    # a new mission: the server's reset to 0 comes next
        self._hold_until: float | None = None
        self._flight: _Flight | None = None
        self._server.subscribe_incoming_mission(self._on_mission)
        self._server.subscribe_current_item_changed(self._on_current)

    def _on_mission(self, result: Any, plan: Any, _user: Any) -> None:
        with self._lock:  # an abandoned transfer is reported too, with an empty plan
            if result.name == "SUCCESS":
                self.missions.append(list(plan.mission_items))
                self._reset_pending = True
                self._hold_until = time.monotonic() + 2.0
            else:
                self.failed_transfers.append(result.name)

    def _on_current(self, item: Any, _user: Any) -> None:
        with self._lock:
            self.current = int(item.seq)
            if self._reset_pending and item.seq == 0:
                self._reset_pending = False  # the server's own reset: hold on
            elif self._hold_until is not None:
                self._hold_until = None      # the ground station set it

    def fly(self, home_lat_deg: float, home_lon_deg: float, range_m: float,
            speed_m_s: float = 1000.0, tick_s: float = 0.02) -> _Flight:
        """Starts the aircraft at home, on the ground, with a full battery good for
        `range_m` of flight; it flies whatever mission it holds (simulated time runs
        `speed_m_s` metres to a second of wall time)."""
        from mavsdk.plugins.telemetry_server.telemetry_server import TelemetryServer

        telemetry = TelemetryServer(self._mavsdk.server_component(0))
        self._flight = _Flight(self, telemetry, home_lat_deg, home_lon_deg, range_m,
                               speed_m_s, tick_s)
        self._flight.start()
        return self._flight

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
        if self._flight is not None:
            self._flight.stop()
        self._server.destroy()
        self._mavsdk.destroy()


class _Flight(threading.Thread):
    """The stand-in aircraft: local east/north/up metres about home, flown straight to each
    navigation item of the mission it holds; command items are done on reaching them."""

    def __init__(self, vehicle: MavsdkVehicle, telemetry: Any, lat0: float, lon0: float,
                 range_m: float, speed_m_s: float, tick_s: float) -> None:
        super().__init__(daemon=True)
        self.vehicle, self.telemetry = vehicle, telemetry
        self.lat0, self.lon0, self.range_m = lat0, lon0, range_m
        self.speed_m_s, self.tick_s = speed_m_s, tick_s
        self.pos = [0.0, 0.0, 0.0]
        self.flown_m = 0.0
        self.drained = 0.0           # charge lost beyond the distance flown (a fault)
        self.landed = False
        self.done: list[tuple[int, int]] = []  # (mission number, item) in the order done
        self.track: list[tuple[float, float, float]] = [(0.0, 0.0, 0.0)]  # at each item done
        self._stop_event = threading.Event()

    def drain(self, fraction: float) -> None:
        """A fault: the battery loses `fraction` of its charge at once."""
        self.drained += fraction

    def charge(self) -> float:
        return max(0.0, 1.0 - self.flown_m / self.range_m - self.drained)

    def stop(self) -> None:
        self._stop_event.set()
        self.join(timeout=2)

    def _goal(self, item: Any) -> list[float] | None:
        if item.command == NAV_RTL:
            return [0.0, 0.0, 0.0]
        if item.command not in (NAV_WAYPOINT, NAV_LAND, NAV_TAKEOFF):
            return None
        lat, lon = item.x * 1e-7, item.y * 1e-7
        if item.command == NAV_TAKEOFF:
            return [self.pos[0], self.pos[1], float(item.z)]
        d = math.pi / 180 * EARTH_RADIUS_M
        return [(lon - self.lon0) * d * math.cos(math.radians(self.lat0)),
                (lat - self.lat0) * d, 0.0 if item.command == NAV_LAND else float(item.z)]

    def _battery(self) -> None:
        """BATTERY_STATUS, and where the aircraft is (GLOBAL_POSITION_INT)."""
        from mavsdk.plugins.telemetry_server.telemetry_server import (
            Battery,
            Heading,
            Position,
            VelocityNed,
        )

        b = Battery()
        b.voltage_v = 15.2
        b.remaining_percent = round(self.charge(), 3)
        self.telemetry.publish_battery(b)
        d = math.pi / 180 * EARTH_RADIUS_M
        lat = self.lat0 + self.pos[1] / d
        lon = self.lon0 + self.pos[0] / (d * math.cos(math.radians(self.lat0)))
        self.telemetry.publish_position(Position(lat, lon, self.pos[2], self.pos[2]),
                                        VelocityNed(0.0, 0.0, 0.0), Heading(0.0))

    def run(self) -> None:
        v = self.vehicle
        next_battery = 0.0
        while not self._stop_event.is_set() and not self.landed:
            now = time.monotonic()
            if now >= next_battery:
                self._battery()
                next_battery = now + 0.1
            with v._lock:
                mission = v.missions[-1] if v.missions else None
                number = len(v.missions)
                seq = v.current
                hold = v._hold_until is not None and now < v._hold_until
                if v._hold_until is not None and not hold:
                    v._hold_until = None
            if mission is None or hold or seq >= len(mission) or self.charge() <= 0:
                time.sleep(self.tick_s)
                continue
            item = mission[seq]
            target = self._goal(item)
            step = self.speed_m_s * self.tick_s
            if target is not None:
                gap = math.dist(self.pos, target)
                move = min(step, gap)
                if gap > 0:
                    self.pos = [p + (t - p) * move / gap for p, t in zip(self.pos, target,
                                                                          strict=True)]
                    self.flown_m += move
                if move < gap:
                    time.sleep(self.tick_s)
                    continue
            last = seq == len(mission) - 1
            with v._lock:
                if len(v.missions) != number or v.current != seq:
                    continue  # replaced meanwhile: fly what it holds now
                v.current = seq + 1 if not last else seq
            self.done.append((number, seq))
            self.track.append((self.pos[0], self.pos[1], self.pos[2]))
            v._server.set_current_item_complete()
            if last and item.command in (NAV_RTL, NAV_LAND):
                self.landed = True
            elif target is not None:
                time.sleep(self.tick_s)
        self._battery()
