"""What the command lines share (`mound`, `python/mission.py`, the stages' verbs): an
argparse parser whose errors are one line and exit 2, and the parsers of option values
(the bounds of the numbers are in mound.bounds)."""

from __future__ import annotations

import argparse
from typing import Any, NoReturn

from mound.errors import InputError


class UsageError(InputError):
    """A command line that cannot be carried out as given (exit 2)."""


class Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # argparse exits 2 already; keep one line
        raise UsageError(f"{self.prog}: {message}")


# argparse's subcommands (its type is private to argparse)
Commands = argparse._SubParsersAction


def command_group(sub: Any, name: str, help: str,
                  parser_class: type) -> Commands[argparse.ArgumentParser]:
    """`mound NAME VERB ...`: the group NAME added to `mound`'s subcommands `sub`; its verbs
    are added to what it returns."""
    return sub.add_parser(name, help=help).add_subparsers(dest="cmd", required=True,
                                                           parser_class=parser_class)


def parse_names(text: str | None) -> list[str] | None:
    """A comma-separated list of names (`--bands red,nir`), None when not given."""
    if text is None:
        return None
    names = [t.strip() for t in text.split(",")]
    if not all(names):
        raise InputError(f"expected a comma-separated list, got {text!r}")
    return names


def parse_lat_lon(text: str | None, option: str = "--home") -> tuple[float, float] | None:
    """`LAT,LON` in WGS84 degrees, None when not given."""
    if text is None:
        return None
    try:
        lat, lon = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"{option}: expected LAT,LON in degrees, got {text!r}") from None
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise InputError(f"{option}: {text} is not a WGS84 latitude, longitude")
    return lat, lon

