"""A mission file onto the vehicle over MAVLink, read back and compared (`mound mission
upload` and the survey's --connect)."""

from __future__ import annotations

from pathlib import Path

from mound.errors import InputError
from mound.formats.mission import UploadRecord


def upload_mission(mission: str | Path, connect: str, *, verify: bool = True,
                   firmware: str | None = None, signing_key: str | None = None,
                   signing_passphrase: str | None = None, accept_unsigned: bool = False,
                   heartbeat_timeout_s: float = 5.0, baud: int = 57600,
                   timeout_s: float = 1.0, retries: int = 5) -> UploadRecord:
    """Uploads a .plan or WPL mission over MAVLink (and reads it back with `verify`);
    InputError when the link or the transfer fails. Returns what happened."""
    from mound.uav import files as mission_files
    from mound.uav.mavlink import link as mavlink_link
    from mound.uav.mavlink import transfer
    from mound.uav.mission_items import home_item

    items, home, file_firmware = mission_files.read_mission(mission)
    if (firmware or file_firmware) == "ardupilot":
        items = [home_item(home), *items]
    key = mavlink_link.signing_key(signing_key, signing_passphrase)
    try:
        lk = mavlink_link.connect(connect, key, accept_unsigned, heartbeat_timeout_s, baud)
    except mavlink_link.LinkError as e:
        raise InputError(str(e)) from e
    try:
        stats = transfer.upload_verified(lk, items, verify, timeout_s, retries)
    except mavlink_link.LinkError as e:
        raise InputError(str(e)) from e
    finally:
        lk.close()
    return UploadRecord(connect, Path(mission).name, len(items), lk.target_system,
                        stats.elapsed_s, stats.retransmissions, stats.restarts, stats.verified,
                        tuple(stats.notes))
