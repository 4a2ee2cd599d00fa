"""The bounds of every number a user gives (a flag, or a field of an options struct or of a
file the user wrote): finite, an integer where one is meant, and within a range no real
survey reaches, checked before any work (issue 54: a 1e5 m site diameter ran past 12 GB, a
NaN stride was rounded before its check). A value past a bound is a typing slip, never a
request; the message names the flag or field and the range."""

from __future__ import annotations

import argparse
import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

from mound.errors import InputError

N = TypeVar("N", bound=float)  # the value a bound checks (an int or a float), as given


@dataclass(frozen=True)
class Bound:
    """Finite, an integer where `integer`, within [lo, hi] (lo excluded where `above`).
    `arg()` is the argparse type of a flag; `check(value, name)` the same test of a value
    built in code or read from a file (InputError naming `name`)."""

    lo: float
    hi: float
    unit: str = ""
    integer: bool = False
    above: bool = False

    def describe(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        if self.integer:
            return f"an integer {self.lo:,.0f} .. {self.hi:,.0f}{unit}"
        left = "(" if self.above else "["
        return f"a number in {left}{self.lo:g}, {self.hi:g}]{unit}"

    def ok(self, value: float) -> bool:
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            return False
        if self.integer and not isinstance(value, numbers.Integral):
            return False
        if not math.isfinite(value):
            return False
        return (value > self.lo if self.above else value >= self.lo) and value <= self.hi

    def check(self, value: N, name: str) -> N:
        """`value` if within the bound, else InputError naming `name` (flag or field)."""
        if not self.ok(value):
            raise InputError(f"{name}: expected {self.describe()}, got {value!r}")
        return value

    def parse(self, text: str) -> float | int:
        """The value of a flag's text; ArgumentTypeError (argparse names the flag)."""
        try:
            value: float | int = int(text) if self.integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected {self.describe()}, got {text[:40]!r}") from None
        if not self.ok(value):
            raise argparse.ArgumentTypeError(f"expected {self.describe()}, got {text[:40]!r}")
        return value

    def arg(self) -> Callable[[str], Any]:
        """The argparse `type=` of a flag with this bound."""
        def parse(text: str) -> float | int:
            return self.parse(text)

        parse.__name__ = "integer" if self.integer else "number"
        parse.bound = self  # type: ignore[attr-defined]  # what the tests walk
        return parse


# The bounds the command lines share (one place: the flags and the options structs that
# check them again agree). Others, of one flag each, are written where the flag is.
SEED = Bound(0, 2**31 - 1, integer=True)              # numpy's and the tools' seeds
THREADS = Bound(1, 256, integer=True)
WORKERS = Bound(1, 256, integer=True)
# The scan's scale (a tumulus's diameter): the largest tumuli, Alyattes' at Bin Tepe, are
# 355 m across; 2 km is no site a multicopter scans in one pass.
SITE_DIAMETER_M = Bound(0, 2_000, "m", above=True)
# Heights above home or ground: 120 m is the usual legal ceiling; 1,000 m is none.
HEIGHT_M = Bound(0, 1_000, "m", above=True)
# A flight's (or the survey's) distance budget: multicopters fly 5-30 km on a battery,
# fixed wings a few hundred.
BUDGET_M = Bound(0, 1_000_000, "m", above=True)
SPEED_M_S = Bound(0, 50, "m/s", above=True)
FLIGHTS = Bound(1, 64, integer=True)
CANDIDATES = Bound(1, 10_000, integer=True)
TIME_S = Bound(0, 7 * 24 * 3600, "s", above=True)      # a limit of a week
IMAGE_PX = Bound(16, 20_000, "px", integer=True)       # a side of a simulated image
# Seeds the simulator turns into mound_render's (at most 2**31 - 1): a survey's site k gets
# 1000 sim_seed + k + 1 (sim/card.py), a grid's site k 100,000 seed + k (grids/run.py).
SIM_SEED = Bound(0, 2_000_000, integer=True)
GRID_SEED = Bound(0, 21_000, integer=True)
