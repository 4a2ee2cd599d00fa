"""The only place that runs the project's C++ tools as subprocesses.

Ready for minute-long runs (ODM's `system.run` is the model, ../shared/STYLE.md):
- argument lists only, never a shell string; the command and its exit status are logged;
- the tool's stderr (its progress and messages) is streamed line by line as it comes, to
  the console when `echo` is set and to a log file when `log` is given, and its tail is
  kept for the error message; stdout (where a tool prints a JSON result) is collected;
- the tool runs in its own session (process group), so it survives no interrupt of ours:
  on Ctrl-C (KeyboardInterrupt) or when `timeout_s` runs out, the whole group gets
  SIGTERM, then SIGKILL after a grace period, and is reaped before we go on;
- exit codes map to the project's errors (mound.errors): 2 -> ToolInputError (an
  InputError), 3 -> ToolNoResultError (a NoResultError), 1 or a signal -> ToolError,
  past the time limit -> ToolTimeout.
"""

from __future__ import annotations

import atexit
import collections
import contextlib
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from mound.datasets import sha256_of
from mound.errors import (  # noqa: F401  (re-exported for callers: native.ToolError)
    EXIT_BAD_INPUT,
    EXIT_INTERNAL,
    EXIT_NO_RESULT,
    EXIT_OK,
    Terminated,
    ToolError,
    ToolTimeout,
    tool_error,
)
from mound.paths import build_dir

TAIL_LINES = 200       # stderr lines kept in memory for the error message
GRACE_S = 3.0          # between SIGTERM and SIGKILL

# The tools running now in this process (any thread) with the tag of the work they belong
# to, so that end_all() can stop them: a Dask worker running a survey's tasks is told to by
# the driver when the user interrupts it. An ended tag stays ended: a task of that run
# that was between two tools then cannot start another (no race with the next Popen).
_live: dict[subprocess.Popen[bytes], str | None] = {}
_ended: set[str] = set()
_all_ended = False  # SIGTERM: no tool starts any more in this process
# Re-entrant: the SIGTERM handler ends the tools from the main thread, which may hold it.
_live_lock = threading.RLock()
_local = threading.local()
# The tools pinned by `pinned` (name -> the copy every run of it uses meanwhile).
_pinned: dict[str, Path] = {}


@contextlib.contextmanager
def tagged(tag: str) -> Iterator[None]:
    """Every tool this thread starts inside the block belongs to the work `tag`."""
    previous = getattr(_local, "tag", None)
    _local.tag = tag
    try:
        yield
    finally:
        _local.tag = previous


@dataclass
class ToolRun:
    stdout: str
    stderr: str          # the last TAIL_LINES lines
    elapsed_s: float
    pid: int


def tool_path(name: str) -> Path:
    path = _pinned.get(name) or build_dir() / name
    if not path.exists():
        raise FileNotFoundError(f"{path} not found: build the project first (make)")
    return path


@contextlib.contextmanager
def pinned(*names: str) -> Iterator[dict[str, str]]:
    """Inside the block every run of `names` (from any thread) runs a private copy of
    build/<name> taken on entry, so that a rebuild meanwhile (make relinks the binary in
    place) neither fails a run half-way (the file busy or half-written) nor judges one piece
    of work with two builds. Yields each copy's sha256, for the work's record."""
    with tempfile.TemporaryDirectory(prefix="mound-tools-") as tmp:
        copies = {}
        for name in names:
            copies[name] = Path(tmp) / name
            shutil.copy2(tool_path(name), copies[name])
        with _live_lock:
            before = {n: _pinned.get(n) for n in names}
            _pinned.update(copies)
        try:
            yield {n: sha256_of(c) for n, c in copies.items()}
        finally:
            with _live_lock:
                for n, old in before.items():
                    if old is None:
                        _pinned.pop(n, None)
                    else:
                        _pinned[n] = old


def _end_group(proc: subprocess.Popen[bytes]) -> None:
    """SIGTERM to the tool's process group, SIGKILL after GRACE_S, then reap it."""
    for sig, wait_s in ((signal.SIGTERM, GRACE_S), (signal.SIGKILL, 10.0)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            break
        try:
            proc.wait(timeout=wait_s)
            break
        except subprocess.TimeoutExpired:
            continue
    # The leader may be gone while others of its group live on: end them too.
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """A command's main runs in this block (main thread; elsewhere it does nothing): SIGTERM
    is taken as Ctrl-C — every tool this process runs is ended (its whole group), none
    starts any more, and Terminated (a KeyboardInterrupt) is raised where the main thread
    is. Without it Python dies at once and the tool it was waiting for (in a process group
    of its own) runs on."""
    global _all_ended
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: Any) -> None:
        global _all_ended
        _all_ended = True
        end_all()
        raise Terminated(f"signal {signum}")

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
        _all_ended = False


def end_all(tag: str | None = None) -> int:
    """Ends every tool this process is running now (their whole process groups), or only
    those of the work `tag`, which then starts no more; as on Ctrl-C. The threads waiting
    for them see a killed tool (a ToolError). Returns how many were ended."""
    with _live_lock:
        if tag is not None:
            _ended.add(tag)
        procs = [p for p, t in _live.items() if tag is None or t == tag]
    for proc in procs:
        _end_group(proc)
    return len(procs)


def run_tool(name: str, args: list[str], timeout_s: float | None = None, *,
             log: str | Path | None = None, echo: bool = False) -> ToolRun:
    """Runs build/<name> with `args`; raises a ToolError (see the module text) unless it
    exits 0."""
    cmd = [str(tool_path(name)), *args]
    log_file: IO[str] | None = None
    if log is not None:
        Path(log).parent.mkdir(parents=True, exist_ok=True)
        log_file = open(log, "a", encoding="utf-8")
    tail: collections.deque[str] = collections.deque(maxlen=TAIL_LINES)
    out_chunks: list[bytes] = []
    lock = threading.Lock()

    def note(line: str) -> None:
        with lock:
            if log_file is not None:
                log_file.write(line if line.endswith("\n") else line + "\n")
                log_file.flush()

    start = time.perf_counter()
    tag = getattr(_local, "tag", None)
    with _live_lock:
        if _all_ended or (tag is not None and tag in _ended):
            raise ToolError(name, -signal.SIGTERM, f"{name}: not started, the work was "
                            "interrupted")
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                stdin=subprocess.DEVNULL, start_new_session=True)
        _live[proc] = tag
    note(f"[native] pid {proc.pid}: {' '.join(cmd)}")
    assert proc.stdout is not None and proc.stderr is not None
    stdout, stderr = proc.stdout, proc.stderr

    def pump_stderr() -> None:
        for raw in iter(stderr.readline, b""):
            line = raw.decode("utf-8", "replace")
            tail.append(line.rstrip("\n"))
            note(line)
            if echo:
                sys.stderr.write(line)
                sys.stderr.flush()

    def pump_stdout() -> None:
        for chunk in iter(lambda: stdout.read(65536), b""):
            out_chunks.append(chunk)

    readers = [threading.Thread(target=pump_stderr, daemon=True),
               threading.Thread(target=pump_stdout, daemon=True)]
    for t in readers:
        t.start()
    try:
        try:
            code = proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            _end_group(proc)
            note(f"[native] pid {proc.pid}: ended after the {timeout_s:g} s time limit")
            for t in readers:
                t.join(timeout=5)
            raise ToolTimeout(name, proc.returncode,
                              "\n".join(tail) + f"\n{name}: ended after {timeout_s:g} s") from None
        except BaseException:  # KeyboardInterrupt, SystemExit: the tool must not outlive us
            _end_group(proc)
            note(f"[native] pid {proc.pid}: ended on interrupt")
            raise
        for t in readers:
            t.join()
        elapsed = time.perf_counter() - start
        note(f"[native] pid {proc.pid}: exit {code} after {elapsed:.3f} s")
    finally:
        with _live_lock:
            _live.pop(proc, None)
        stdout.close()
        stderr.close()
        if log_file is not None:
            log_file.close()
    if code != 0:
        raise tool_error(name, code, "\n".join(tail))
    return ToolRun(b"".join(out_chunks).decode("utf-8", "replace"), "\n".join(tail), elapsed,
                   proc.pid)


def run_json(name: str, args: list[str], timeout_s: float | None = None, *,
             log: str | Path | None = None, echo: bool = False) -> Mapping[str, object]:
    """Runs a tool that prints one JSON object on stdout and returns it parsed (its members
    are the caller's to read: a typed reader, or `tool_number`)."""
    run = run_tool(name, args, timeout_s, log=log, echo=echo)
    try:
        result = json.loads(run.stdout)
    except json.JSONDecodeError as e:
        raise ToolError(name, EXIT_INTERNAL, f"stdout is not JSON ({e})") from e
    if not isinstance(result, dict):
        raise ToolError(name, EXIT_INTERNAL, "stdout is not a JSON object")
    return result


def tool_number(doc: Mapping[str, object], key: str, name: str) -> float:
    """A number a tool's output or reply must hold (ToolError, a bug, when it does not)."""
    v = doc.get(key)
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise ToolError(name, EXIT_INTERNAL, f"its output's {key} is {v!r:.40}, not a number")
    return v


def tool_objects(doc: Mapping[str, object], key: str, name: str) -> list[Mapping[str, object]]:
    """A list of objects a tool's output or reply must hold (ToolError, a bug, otherwise)."""
    v = doc.get(key)
    if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
        raise ToolError(name, EXIT_INTERNAL, f"its output's {key} is not a list of objects")
    return v


class ToolServer:
    """A tool kept running between requests (`mound_scene --serve`): each request is one
    JSON line and raw bytes on its stdin, each reply one JSON line and raw bytes on its
    stdout (the tool's header names the protocol). One caller at a time (a thread keeps
    its own, see `checkout`); its stderr is kept for the error message. Ended by `close`,
    by end_all() like any tool, and when this process exits (its stdin then ends)."""

    def __init__(self, name: str, args: list[str]) -> None:
        self.name = name
        self.path = str(tool_path(name))
        self.tail: collections.deque[str] = collections.deque(maxlen=TAIL_LINES)
        with _live_lock:
            if _all_ended:
                raise ToolError(name, -signal.SIGTERM, f"{name}: not started, the work was "
                                "interrupted")
            self.proc = subprocess.Popen([self.path, *args], stdin=subprocess.PIPE,
                                         stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                         start_new_session=True)
            _live[self.proc] = None  # shared between works: ended by end_all() only
        assert self.proc.stderr is not None
        err = self.proc.stderr
        self._pump = threading.Thread(target=self._read_stderr, args=(err,), daemon=True)
        self._pump.start()

    def _read_stderr(self, err: IO[bytes]) -> None:
        for raw in iter(err.readline, b""):
            self.tail.append(raw.decode("utf-8", "replace").rstrip("\n"))

    def alive(self) -> bool:
        return self.proc.poll() is None

    def request(self, head: Mapping[str, object], *payload: bytes | memoryview
                ) -> tuple[Mapping[str, object], bytearray]:
        """Sends one request (its JSON line, then the payload's pieces in order); the
        reply's JSON and the bytes after it (its `bytes` says how many). A reply
        {"status": "error"} raises ToolInputError; a tool that stopped raises what its exit
        status says (native.tool_error)."""
        stdin, stdout = self.proc.stdin, self.proc.stdout
        assert stdin is not None and stdout is not None
        try:
            stdin.write(json.dumps(head, separators=(",", ":")).encode() + b"\n")
            for piece in payload:
                stdin.write(piece)
            stdin.flush()
            line = stdout.readline()
        except (BrokenPipeError, ConnectionResetError):
            line = b""
        if not line:
            raise self._ended()
        try:
            reply = json.loads(line)
        except json.JSONDecodeError as e:
            self.close()
            raise ToolError(self.name, EXIT_INTERNAL, f"a reply is not JSON ({e})") from e
        if not isinstance(reply, dict):
            self.close()
            raise ToolError(self.name, EXIT_INTERNAL, "a reply is not a JSON object")
        if reply.get("status") == "error":
            raise tool_error(self.name, EXIT_BAD_INPUT, str(reply.get("message")))
        size = reply.get("bytes", 0)
        if not isinstance(size, int) or size < 0:
            self.close()
            raise ToolError(self.name, EXIT_INTERNAL, f"a reply's bytes is {size!r}")
        data = bytearray(size)  # writable: the caller's array may be edited in place
        view, got = memoryview(data), 0
        while got < size:
            n = stdout.readinto(view[got:])  # type: ignore[attr-defined]  # a BufferedReader
            if not n:
                raise self._ended()
            got += n
        return reply, data

    def _ended(self) -> ToolError:
        try:
            code = self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            _end_group(self.proc)
            code = self.proc.returncode
        self.close()
        self._pump.join(timeout=5)
        return tool_error(self.name, code if code != 0 else EXIT_INTERNAL,
                          "\n".join(self.tail) or f"{self.name}: the server stopped")

    def close(self) -> None:
        """Ends the tool: its stdin closed (it exits 0), SIGTERM after GRACE_S."""
        with _live_lock:
            _live.pop(self.proc, None)
        for f in (self.proc.stdin, self.proc.stdout):
            with contextlib.suppress(OSError):
                if f is not None:
                    f.close()
        try:
            self.proc.wait(timeout=GRACE_S)
        except subprocess.TimeoutExpired:
            _end_group(self.proc)


_servers_lock = threading.Lock()
_idle_servers: dict[tuple[str, tuple[str, ...]], list[ToolServer]] = {}


@contextlib.contextmanager
def checkout(name: str, args: list[str]) -> Iterator[ToolServer]:
    """A running `name args` server for this block's requests: an idle one of this build
    (build/<name>, or its pinned copy), else a new one; given back to the idle ones after,
    unless it failed. As many run as threads use them at once; all end at exit."""
    key = (str(tool_path(name)), tuple(args))
    server = None
    with _servers_lock:
        idle = _idle_servers.setdefault(key, [])
        while idle and server is None:
            s = idle.pop()
            if s.alive():
                server = s
            else:
                s.close()
    if server is None:
        server = ToolServer(name, args)
    ok = False
    try:
        yield server
        ok = True
    finally:
        if ok and server.alive():
            with _servers_lock:
                _idle_servers.setdefault(key, []).append(server)
        else:
            server.close()


def close_servers() -> None:
    """Ends every idle server (at exit; tests that count processes)."""
    with _servers_lock:
        servers = [s for idle in _idle_servers.values() for s in idle]
        _idle_servers.clear()
    for s in servers:
        s.close()


atexit.register(close_servers)
