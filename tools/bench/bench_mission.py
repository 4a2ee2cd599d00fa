"""Benchmark (not a test): mission upload + read-back times against MAVSDK (PyPI mavsdk
4.x as an in-process autopilot with MissionRawServer), for 20 / 200 / 1,000 items on a
clean loopback link and through a relay that drops 5 % and 10 % of datagrams each way.

Prints, per case, the upload time, the read-back time, our retransmissions, the datagrams
the relay dropped, and the ratio to the clean-link time in this same run.

    .venv/bin/python tools/bench/bench_mission.py [--sizes 20 200 1000] [--loss 0.05 0.1]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))

from mound.formats.plan import Flight, Plan
from mound.geometry.geodesy import Origin
from mound.uav import mission, mission_items
from mound.uav.mavlink import link as mavlink_link
from mound.uav.mavlink import transfer
from mound.uav.mavlink.peer import MavsdkVehicle
from mound.uav.mavlink.relay import LossyRelay


def items_of(n: int) -> list[mission_items.MissionItem]:
    sites = n // 9 + 2
    wps = [{"id": "home", "x_m": 0.0, "y_m": 0.0}]
    wps += [{"id": f"s{k}", "x_m": 300.0 * (1 + k % 10), "y_m": 300.0 * (1 + k // 10)}
            for k in range(sites)]
    tour = (*(str(w["id"]) for w in wps), "home")
    plan = Plan("bench", (Flight(tour, None, None, None),), 1e9, True,
                extra={"waypoints": wps})
    return mission.build(plan, Origin(38.5705, 27.9862, 95.0)).items[:n]


def run(vehicle: MavsdkVehicle, items: list[mission_items.MissionItem], loss: float, seed: int
        ) -> tuple[float, float, int, int]:
    def once(connect: str) -> tuple[float, float, int]:
        lk = mavlink_link.connect(connect, timeout_s=5)
        try:
            t0 = time.monotonic()
            up = transfer.upload(lk, items)
            t1 = time.monotonic()
            got, down = transfer.download(lk)
            t2 = time.monotonic()
        finally:
            lk.close()
        diff = transfer.first_difference(items, got)
        if diff:
            raise SystemExit(f"read-back differs: {diff}")
        return t1 - t0, t2 - t1, up.retransmissions + down.retransmissions

    if loss == 0:
        up, down, re = once(vehicle.connect_string)
        return up, down, re, 0
    with LossyRelay(vehicle.port, loss, seed=seed) as relay:
        up, down, re = once(f"udpout:127.0.0.1:{relay.port}")
        return up, down, re, sum(relay.dropped)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[20, 200, 1000])
    ap.add_argument("--loss", type=float, nargs="+", default=[0.05, 0.1])
    args = ap.parse_args()
    print(f"{'items':>6} {'loss':>5} {'upload s':>9} {'read-back s':>11} {'resent':>7} "
          f"{'dropped':>8} {'x clean':>8}")
    with MavsdkVehicle("udpin") as vehicle:
        for n in args.sizes:
            items = items_of(n)
            clean = None
            for loss in [0.0, *args.loss]:
                up, down, re, dropped = run(vehicle, items, loss, seed=n)
                total = up + down
                clean = clean or total
                print(f"{n:>6} {loss:>5.2f} {up:>9.3f} {down:>11.3f} {re:>7} {dropped:>8} "
                      f"{total / clean:>8.1f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
