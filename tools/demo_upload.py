"""`make demo` helper: uploads a mission to a stand-in vehicle, since no aircraft is
attached. The vehicle is MAVSDK (PyPI mavsdk 4.x) running in this process as an autopilot
with its MissionRawServer on a loopback UDP port; the upload is the real
`mound mission upload --verify` command line.

    .venv/bin/python tools/demo_upload.py MISSION.plan
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

from mound.cli import main as mound_main
from mound.uav.mavlink.peer import MavsdkVehicle


def main() -> int:
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    with MavsdkVehicle("udpin") as vehicle:
        print(f"stand-in vehicle (MAVSDK autopilot) listening on {vehicle.connect_string}")
        code = mound_main(["mission", "upload", sys.argv[1], "--connect",
                           vehicle.connect_string, "--verify"])
        if code == 0:
            print(f"the vehicle holds {len(vehicle.wait_for_mission())} mission items")
        return code


if __name__ == "__main__":
    sys.exit(main())
