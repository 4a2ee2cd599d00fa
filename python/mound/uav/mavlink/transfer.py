"""The MAVLink mission protocol, ground-station side: upload, download (read-back), verify.

Upload: MISSION_COUNT; the vehicle asks for each item with MISSION_REQUEST_INT (or the
deprecated MISSION_REQUEST; we answer both with MISSION_ITEM_INT) and ends with
MISSION_ACK. The vehicle drives the transfer and re-requests what it misses (MAVSDK after
about 0.5 s, ArduPilot and PX4 similarly), so our time-out is longer (1 s by default): on a
time-out we resend MISSION_COUNT (nothing requested yet) or the last requested item; after
`retries` silent time-outs in a row the transfer is restarted from MISSION_COUNT, up to
`restarts` times. When every item has been sent and only the final ACK is missing, the
upload is not declared failed: the mission is read back and compared instead.

Download: MISSION_REQUEST_LIST -> MISSION_COUNT, then MISSION_REQUEST_INT for each
sequence number -> MISSION_ITEM_INT, then MISSION_ACK. Here we drive, and the vehicle gives
up when our next request does not come (MAVSDK resends the last item every ~0.5 s, then
aborts), so requests are retried fast: at once when the vehicle resends the previous item
(our request was lost), else after `download_timeout_s` (0.25 s by default).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from mound.uav.mavlink.link import Link, LinkError
from mound.uav.mission_items import MissionItem

MAV_MISSION_ACCEPTED = 0
MISSION_RESULT = {
    1: "MAV_MISSION_ERROR", 2: "MAV_MISSION_UNSUPPORTED_FRAME", 3: "MAV_MISSION_UNSUPPORTED",
    4: "MAV_MISSION_NO_SPACE", 5: "MAV_MISSION_INVALID", 6: "MAV_MISSION_INVALID_PARAM1",
    13: "MAV_MISSION_INVALID_SEQUENCE", 14: "MAV_MISSION_DENIED",
    15: "MAV_MISSION_OPERATION_CANCELLED",
}


@dataclass
class TransferStats:
    elapsed_s: float = 0.0
    items: int = 0
    requests: int = 0            # item requests answered (re-requests included)
    retransmissions: int = 0     # our resends after a time-out
    restarts: int = 0
    ack_lost: bool = False
    verified: bool | None = None
    notes: list[str] = field(default_factory=list)


def _item_send(link: Link, seq: int, it: MissionItem, mission_type: int) -> None:
    link.conn.mav.mission_item_int_send(
        link.target_system, link.target_component, seq, it.frame, it.command, 0,
        it.autocontinue, *it.params, it.x, it.y, it.z, mission_type)


def _count_send(link: Link, n: int, mission_type: int) -> None:
    link.conn.mav.mission_count_send(link.target_system, link.target_component, n, mission_type)


def upload(link: Link, items: list[MissionItem], timeout_s: float = 1.0, retries: int = 5,
           restarts: int = 2, mission_type: int = 0) -> TransferStats:
    """Uploads `items`; returns the statistics, raises LinkError on failure. If the final
    ACK is lost the returned stats say so (ack_lost): verify by download()."""
    stats = TransferStats(items=len(items))
    start = time.monotonic()
    n = len(items)
    for attempt in range(restarts + 1):
        stats.restarts = attempt
        _count_send(link, n, mission_type)
        last_seq: int | None = None
        highest = -1
        silent = 0
        while True:
            msg = link.recv(["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"], timeout_s)
            if msg is None:
                silent += 1
                if silent > retries:
                    break  # restart, or report a lost ACK
                stats.retransmissions += 1
                if last_seq is None:
                    _count_send(link, n, mission_type)
                else:
                    _item_send(link, last_seq, items[last_seq], mission_type)
                continue
            if getattr(msg, "mission_type", 0) != mission_type:
                continue
            silent = 0
            if msg.get_type() == "MISSION_ACK":
                if msg.type == MAV_MISSION_ACCEPTED and (highest == n - 1 or n == 0):
                    stats.elapsed_s = time.monotonic() - start
                    return stats
                if msg.type == MAV_MISSION_ACCEPTED:
                    continue  # an ACK of an earlier transfer
                name = MISSION_RESULT.get(msg.type, f"result {msg.type}")
                raise LinkError(f"the vehicle rejected the mission: {name} "
                                f"(after {highest + 1} of {n} items)")
            seq = msg.seq
            if not 0 <= seq < n:
                raise LinkError(f"the vehicle asked for item {seq} of a {n}-item mission")
            _item_send(link, seq, items[seq], mission_type)
            stats.requests += 1
            last_seq = seq
            highest = max(highest, seq)
        if highest == n - 1:
            stats.ack_lost = True
            stats.notes.append("final MISSION_ACK not received")
            stats.elapsed_s = time.monotonic() - start
            return stats
        stats.notes.append(f"attempt {attempt + 1}: the vehicle went silent after "
                           f"{highest + 1} of {n} items")
    raise LinkError(f"mission upload failed: {'; '.join(stats.notes)} "
                    f"({retries} retries of {timeout_s:g} s each, {restarts} restarts)")


def _download_once(link: Link, timeout_s: float, retries: int, mission_type: int,
                   stats: TransferStats) -> list[MissionItem]:
    conn = link.conn
    count = None
    for _ in range(retries + 1):
        conn.mav.mission_request_list_send(link.target_system, link.target_component,
                                           mission_type)
        msg = link.recv(["MISSION_COUNT"], timeout_s)
        if msg is not None and getattr(msg, "mission_type", 0) == mission_type:
            count = msg.count
            break
        stats.retransmissions += 1
    if count is None:
        raise LinkError(f"no MISSION_COUNT after {retries + 1} requests of the mission list")
    items: list[MissionItem] = []
    for seq in range(count):
        got = None
        for _ in range(retries + 1):
            conn.mav.mission_request_int_send(link.target_system, link.target_component, seq,
                                              mission_type)
            stats.requests += 1
            deadline = time.monotonic() + timeout_s
            while got is None and time.monotonic() < deadline:
                msg = link.recv(["MISSION_ITEM_INT"], deadline - time.monotonic())
                if msg is None:
                    continue
                if msg.seq == seq:
                    got = msg
                elif msg.seq == seq - 1:
                    break  # the vehicle resent the previous item: our request was lost
            if got is not None:
                break
            stats.retransmissions += 1
        if got is None:
            raise LinkError(f"item {seq} of {count} not received after {retries + 1} requests")
        items.append(MissionItem(got.command, got.frame,
                                 (got.param1, got.param2, got.param3, got.param4),
                                 got.x, got.y, got.z, got.autocontinue))
    conn.mav.mission_ack_send(link.target_system, link.target_component, MAV_MISSION_ACCEPTED,
                              mission_type)
    return items


def download(link: Link, timeout_s: float = 0.25, retries: int = 8, restarts: int = 2,
             mission_type: int = 0) -> tuple[list[MissionItem], TransferStats]:
    """Reads the vehicle's mission back; a transfer the vehicle abandons is started again
    from MISSION_REQUEST_LIST, up to `restarts` times."""
    stats = TransferStats()
    start = time.monotonic()
    for attempt in range(restarts + 1):
        stats.restarts = attempt
        try:
            items = _download_once(link, timeout_s, retries, mission_type, stats)
        except LinkError as e:
            stats.notes.append(f"read-back attempt {attempt + 1}: {e}")
            continue
        stats.items = len(items)
        stats.elapsed_s = time.monotonic() - start
        return items, stats
    raise LinkError(f"read-back failed: {'; '.join(stats.notes)}")


def first_difference(sent: list[MissionItem], got: list[MissionItem]) -> str | None:
    """None if equal item by item, else a description of the first difference."""
    if len(sent) != len(got):
        return f"the vehicle holds {len(got)} items, {len(sent)} were sent"
    for k, (a, b) in enumerate(zip(sent, got, strict=True)):
        if not a.same_as(b):
            return f"item {k} differs: sent {a}, read back {b}"
    return None


def upload_verified(link: Link, items: list[MissionItem], verify: bool = True,
                    timeout_s: float = 1.0, retries: int = 5,
                    download_timeout_s: float = 0.25) -> TransferStats:
    """Upload, then (if asked, or if the final ACK was lost) read back and compare."""
    stats = upload(link, items, timeout_s, retries)
    if verify or stats.ack_lost:
        got, down = download(link, download_timeout_s)
        stats.notes.append(f"read back {down.items} items in {down.elapsed_s:.2f} s "
                           f"({down.retransmissions} re-requests)")
        diff = first_difference(items, got)
        if diff is not None:
            raise LinkError(f"read-back check failed: {diff}")
        stats.verified = True
        if stats.ack_lost:
            stats.notes.append("read-back matches: the upload succeeded")
    return stats


def set_current(link: Link, seq: int, timeout_s: float = 0.5, retries: int = 5) -> None:
    """Makes item `seq` the vehicle's current one (MISSION_SET_CURRENT) and waits until its
    MISSION_CURRENT says so; LinkError when it never does."""
    for _ in range(retries + 1):
        link.conn.mav.mission_set_current_send(link.target_system, link.target_component, seq)
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            msg = link.recv(["MISSION_CURRENT"], left)
            if msg is not None and msg.seq == seq:
                return
    raise LinkError(f"the vehicle did not make item {seq} current after {retries + 1} "
                    "MISSION_SET_CURRENT")


def replace(link: Link, items: list[MissionItem], keep: int, timeout_s: float = 1.0,
            retries: int = 5) -> TransferStats:
    """Replaces the mission the vehicle is flying with `items`, whose items up to `keep` (the
    current one) are those it holds: uploaded, read back and compared, then item `keep` made
    current again (a vehicle may reset its current item on a new mission, as MAVSDK's
    server does). The MAVLink protocol keeps the old mission until the new one is accepted,
    so a failed transfer (LinkError) leaves the vehicle flying the old one."""
    if not 0 <= keep < len(items):
        raise ValueError(f"keep {keep}: not an item of a {len(items)}-item mission")
    stats = upload_verified(link, items, True, timeout_s, retries)
    set_current(link, keep)
    stats.notes.append(f"item {keep} current again")
    return stats
