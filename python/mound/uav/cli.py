"""`mound mission build | upload`: the UAV mission stage of the command line."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from mound.args import command_group
from mound.bounds import FLIGHTS, HEIGHT_M, SITE_DIAMETER_M, SPEED_M_S, Bound
from mound.errors import InputError, NoResultError
from mound.formats.plan import Plan
from mound.geometry.flight import DEFAULT_SITE_DIAMETER_M, scan_for_site
from mound.geometry.geodesy import Origin
from mound.jsonio import write_all_atomic
from mound.uav import upload


def cmd_build(args: argparse.Namespace) -> int:
    from mound.uav import files as mission_files
    from mound.uav import mission, mission_format, mission_items

    plan = Plan.read(args.plan)
    if args.origin:
        origin = Origin.parse(args.origin)
    elif plan.origin is not None:
        origin = plan.origin
    else:
        raise InputError(f"origin: {args.plan} has no origin; give --origin LAT,LON[,ALT]")
    scan = plan.scan()
    given = (args.pattern, args.site_diameter_m, args.altitude, args.transit_altitude)
    if scan is None or any(v is not None for v in given):
        # No scan in the plan, or options that override it: the flight check below then
        # tells whether the plan's scan costs still cover it.
        scan = scan_for_site(
            args.site_diameter_m if args.site_diameter_m is not None else DEFAULT_SITE_DIAMETER_M,
            args.pattern or "raster", args.altitude, args.transit_altitude)
    spec = mission_items.MissionSpec(scan=scan, cruise_speed_m_s=args.cruise_speed,
                                     scan_speed_m_s=args.scan_speed)
    terrain = None
    if args.dem:
        from mound.flightplan import terrain as terrain_mod

        terrain = mission_items.TerrainInput(args.dem, args.dem_vertical,
                                             terrain_mod.spec_from_args(args))
    flights = mission_items.flight_plans(plan)
    if args.flight is not None:
        flights = [(k, f) for k, f in flights if k == args.flight]
        if not flights:
            raise InputError(f"--flight: the plan has no flight {args.flight} that visits a site")
    if not flights:
        raise InputError("flights: the plan visits no site, there is nothing to fly")
    # Each format asked for by its option (the registry's: --out, --wpl, --dji-kmz, ...).
    asked = {f.name: getattr(args, mission_format.option_dest(f))
             for f in mission_format.registry() if getattr(args, mission_format.option_dest(f))}
    if not asked:
        raise InputError("mission build: no output: give " + ", ".join(
            f.option for f in mission_format.registry()))
    opts = mission_format.WriteOptions(args.firmware, args.aircraft, args.dji_heights,
                                       bool(args.dem))
    mission_format.check(asked, opts)
    # Several flights: one mission each, named OUT_1.plan, OUT_2.plan, ... (and the other
    # formats alike); all are made and checked before any file is written. A file that a
    # limit of its format refuses is not written: the others are, the refusal is recorded
    # in the .plan's `mound.formats` and said on stdout, and the exit is 3.
    several = len(flights) > 1
    outputs: list[tuple[str | Path, str | bytes]] = []
    missions = []
    refusals: list[str] = []
    crew: set[str] = set()
    for number, f in flights:
        m = mission.build(f, origin, spec, terrain)
        flight = number if several else None
        paths = {name: mission_files.flight_path(p, flight) for name, p in asked.items()}
        files, record = mission_format.write_flight(m, paths, opts)
        outputs += files
        crew |= {str(e.about["crew"]) for e in record.values() if "crew" in e.about}
        refusals += [f"{'' if flight is None else f'flight {flight}: '}{r}"
                     for r in mission_format.refusals(record)]
        first = next((str(p) for p, _ in reversed(files)), "-")
        missions.append((number, first, m))
    if not outputs:
        raise NoResultError("; ".join(refusals))
    # All files or none: every file is made and staged before any is put in place.
    write_all_atomic(outputs)
    for flight, out, m in missions:
        _report(m, out, flight if several else None)
    shown = {str(p) for _, p, _ in missions}
    for path, _ in outputs:
        if str(path) not in shown:
            print(f"  -> {path}")
    for text in sorted(crew):
        print(f"  Litchi: {text}")
    if refusals:
        for r in refusals:
            print(f"  {r}")
        raise NoResultError(f"{len(refusals)} file(s) refused by their format's limits, the "
                            f"others written: {refusals[0]}")
    return 0


def _report(m: Any, out: str, flight: int | None) -> None:
    what = f"flight {flight}: " if flight is not None else ""
    print(f"{what}{len(m.items)} mission items for {len(m.sites)} sites, flight distance "
          f"{m.flight_distance_m:.1f} m of budget {m.budget_m:g} m -> {out}")
    if m.terrain is None:
        print("  terrain not checked (no --dem): heights above home")
    else:
        t = m.terrain
        print(f"  over {t.dem}: home ground {t.home_amsl_m:.1f} m AMSL, energy "
              f"{t.energy_m:.1f} m (climbed {t.climbed_m:.0f} m, descended "
              f"{t.descended_m:.0f} m), lowest transit clearance "
              f"{t.lowest_clearance_m or 0:.1f} m")
    for s in m.sites:
        print(f"  {s.id}: scan {s.scan_length_m:.0f} m, {s.images} images "
              f"(plan's scan_cost_m {s.scan_cost_m:g})")


def cmd_show(args: argparse.Namespace) -> int:
    from mound.uav import mission_format

    print(mission_format.show(args.mission))
    return 0


def cmd_formats(args: argparse.Namespace) -> int:
    from mound.uav import mission_format

    print(mission_format.listing())
    return 0


def cmd_upload(args: argparse.Namespace) -> int:
    r = upload.upload_mission(args.mission, args.connect, verify=args.verify,
                              firmware=args.firmware, signing_key=args.signing_key,
                              signing_passphrase=args.signing_passphrase,
                              accept_unsigned=args.accept_unsigned,
                              heartbeat_timeout_s=args.heartbeat_timeout, baud=args.baud,
                              timeout_s=args.timeout, retries=args.retries)
    check = "read back and identical" if r.verified else "not read back (no --verify)"
    print(f"uploaded {r.items} items to system {r.target_system} in "
          f"{r.elapsed_s:.2f} s ({r.retransmissions} retransmissions, {r.restarts} "
          f"restarts); {check}")
    for note in r.notes:
        print(f"  {note}")
    return 0


def add_parser(sub: Any, parser_class: type) -> None:
    grp = command_group(sub, "mission", "UAV mission: build files, upload over MAVLink",
                        parser_class)
    b = grp.add_parser("build", help="plan.json -> QGroundControl .plan (+ WPL, GeoJSON)")
    b.add_argument("plan")
    b.add_argument("--origin", help="LAT,LON[,ALT] of the plan's ENU origin (default: "
                   "the plan's origin)")
    from mound.uav import mission_format

    for fmt in mission_format.registry():
        b.add_argument(fmt.option, metavar=f"OUT{fmt.suffix}",
                       dest=mission_format.option_dest(fmt), help=fmt.help)
    b.add_argument("--aircraft", default="m3e",
                   help="--dji-kmz: the aircraft, one of m3e, m3t, m30, m300, m350, m4e "
                   "(default m3e; mini4pro and air3 fly with --litchi)")
    b.add_argument("--dji-heights", choices=("relative", "wgs84"), default="relative",
                   help="--dji-kmz heights: above the take-off point's ground (default; the "
                   "barometer zeroed at take-off) or WGS84 ellipsoidal (needs --dem; for RTK)")
    b.add_argument("--pattern", choices=("raster", "orbit", "both"),
                   help="scan pattern (default: the plan's scan, else raster); any of these "
                   "four options replaces the plan's scan")
    b.add_argument("--site-diameter", dest="site_diameter_m", metavar="D",
                   type=SITE_DIAMETER_M.arg(),
                   help="scan layout scale, m (the simulator's mound diameter; default 60)")
    b.add_argument("--altitude", type=HEIGHT_M.arg(), help="raster height above home, m")
    b.add_argument("--transit-altitude", type=HEIGHT_M.arg(), help="m (default: the scan height)")
    b.add_argument("--cruise-speed", type=SPEED_M_S.arg(), default=12.0, help="m/s")
    b.add_argument("--scan-speed", type=SPEED_M_S.arg(), default=5.0, help="m/s")
    b.add_argument("--firmware", choices=("px4", "ardupilot"), default="px4")
    b.add_argument("--flight", type=FLIGHTS.arg(), help="only this flight of a plan with several "
                   "(default: every flight, written as OUT_1.plan, OUT_2.plan, ...)")
    from mound.flightplan.terrain import add_arguments as add_terrain_arguments

    add_terrain_arguments(b)
    b.set_defaults(func=cmd_build)
    sh = grp.add_parser("show", help="the waypoints of a mission file (" + ", ".join(
        mission_format.readable_suffixes()) + ") as a table")
    sh.add_argument("mission")
    sh.set_defaults(func=cmd_show)
    fm = grp.add_parser("formats", help="the mission file formats: option, limits")
    fm.set_defaults(func=cmd_formats)
    u = grp.add_parser("upload", help="upload a .plan or WPL mission over MAVLink")
    u.add_argument("mission")
    u.add_argument("--connect", required=True,
                   help="udpout:HOST:PORT, udpin:HOST:PORT, tcp:HOST:PORT, or a serial device")
    u.add_argument("--baud", type=Bound(300, 10_000_000, integer=True).arg(), default=57600)
    u.add_argument("--verify", action="store_true", help="read the mission back and compare")
    u.add_argument("--signing-key", help="MAVLink 2 signing key, 64 hex digits")
    u.add_argument("--signing-passphrase", help="signing key = SHA-256 of this")
    u.add_argument("--accept-unsigned", action="store_true",
                   help="with signing: accept unsigned packets from the vehicle")
    u.add_argument("--timeout", type=Bound(0, 600, "s", above=True).arg(),
                   default=1.0, help="per message, s")
    u.add_argument("--retries", type=Bound(0, 1_000, integer=True).arg(), default=5)
    u.add_argument("--heartbeat-timeout", type=Bound(0, 3_600, "s", above=True).arg(),
                   default=5.0, help="s")
    u.add_argument("--firmware", choices=("px4", "ardupilot"),
                   help="ardupilot: item 0 is home (default: the .plan's firmwareType; "
                   "ardupilot for a WPL file)")
    u.set_defaults(func=cmd_upload)
