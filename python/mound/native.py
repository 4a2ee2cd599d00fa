"""The only place that runs the project's C++ tools as subprocesses.

Tools are called with an argument list (never a shell string), in their own session so
that an interrupt reaches the whole process group, and their exit codes are mapped to one
exception type that carries the tool name, the code and the tail of stderr
(../shared/STYLE.md: 0 ok, 2 bad input, 1 internal error, 128+N killed by signal N).
"""

from __future__ import annotations

import json
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mound.paths import build_dir

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_BAD_INPUT = 2


class ToolError(RuntimeError):
    """A project tool failed; `code` is its exit status (negative: killed by a signal)."""

    def __init__(self, tool: str, code: int, stderr: str) -> None:
        self.tool = tool
        self.code = code
        self.stderr = stderr
        tail = "\n".join(stderr.strip().splitlines()[-10:])
        super().__init__(f"{tool} failed ({describe_exit(code)}): {tail}")


def describe_exit(code: int) -> str:
    if code == EXIT_BAD_INPUT:
        return "exit 2: bad input"
    if code == EXIT_INTERNAL:
        return "exit 1: internal error"
    signal_number = -code if code < 0 else code - 128 if code > 128 else 0
    if signal_number == 9:
        return f"exit {code}: killed (out of memory?)"
    if signal_number in (6, 11):
        return f"exit {code}: crashed (signal {signal_number})"
    return f"exit {code}"


@dataclass
class ToolRun:
    stdout: str
    stderr: str
    elapsed_s: float


def tool_path(name: str) -> Path:
    path = build_dir() / name
    if not path.exists():
        raise FileNotFoundError(f"{path} not found: build the project first (make)")
    return path


def run_tool(name: str, args: list[str], timeout_s: float | None = None) -> ToolRun:
    """Runs build/<name> with `args`; raises ToolError on a non-zero exit."""
    cmd = [str(tool_path(name)), *args]
    start = time.perf_counter()
    proc = subprocess.run(
        cmd, capture_output=True, text=True, timeout=timeout_s, start_new_session=True,
        check=False,
    )
    elapsed = time.perf_counter() - start
    if proc.returncode != 0:
        raise ToolError(name, proc.returncode, proc.stderr)
    return ToolRun(proc.stdout, proc.stderr, elapsed)


def run_json(name: str, args: list[str], timeout_s: float | None = None) -> dict[str, Any]:
    """Runs a tool that prints one JSON document on stdout and returns it parsed."""
    result: dict[str, Any] = json.loads(run_tool(name, args, timeout_s).stdout)
    return result
