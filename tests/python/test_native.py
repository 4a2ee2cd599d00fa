"""mound.native, the one subprocess caller: exit codes mapped to the project's errors,
stderr streamed to a log, and no tool left running after a time-out or a Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mound import native
from mound.datasets import sha256_of
from mound.errors import InputError, ToolError, ToolInputError, ToolTimeout
from mound.paths import REPO_ROOT


def big_tsp(path: Path, n: int = 6000) -> Path:
    """A random EUC_2D instance that keeps mound_plan busy for tens of seconds."""
    rng = np.random.default_rng(1)
    xy = rng.integers(0, 100_000, size=(n, 2))
    lines = ["NAME: big", "TYPE: TSP", f"DIMENSION: {n}", "EDGE_WEIGHT_TYPE: EUC_2D",
             "NODE_COORD_SECTION", *[f"{k + 1} {x} {y}" for k, (x, y) in enumerate(xy)], "EOF"]
    path.write_text("\n".join(lines) + "\n")
    return path


def gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return Path(f"/proc/{pid}/stat").read_text().split()[2] == "Z"  # a zombie is dead too


def test_bad_input_is_an_input_error_with_the_tools_message(tmp_path: Path,
                                                             mound_plan: Path) -> None:
    bad = tmp_path / "sites.json"
    bad.write_text(json.dumps({"schema": "mound.sites", "version": 1}))
    log = tmp_path / "logs" / "plan.log"
    with pytest.raises(ToolInputError) as err:
        native.run_tool("mound_plan", [str(bad)], log=log)
    assert isinstance(err.value, InputError) and err.value.code == native.EXIT_BAD_INPUT
    assert "home" in err.value.tail and "exit 2: bad input" in str(err.value)
    text = log.read_text()
    assert "[native] pid" in text and "home" in text and "exit 2" in text


def test_a_pinned_tool_runs_a_copy_of_the_build_taken_on_entry(mound_plan: Path) -> None:
    """native.pinned: inside the block a tool runs from a private copy of build/<name> (its
    sha256 yielded, the bytes the build's), so that a rebuild meanwhile cannot reach a run;
    after it, build/<name> again, and the copy is gone."""
    built = native.tool_path("mound_plan")
    with native.pinned("mound_plan") as digests:
        copy = native.tool_path("mound_plan")
        assert copy != built and copy.read_bytes() == built.read_bytes()
        assert digests == {"mound_plan": sha256_of(built)}
        run = native.run_tool("mound_plan", ["--help"], 60)
        assert "usage" in (run.stdout + run.stderr).lower()
        with native.pinned("mound_plan"):  # nested: the inner block's own copy
            assert native.tool_path("mound_plan") not in (copy, built)
        assert native.tool_path("mound_plan") == copy
    assert native.tool_path("mound_plan") == built and not copy.exists()


@pytest.mark.slow
def test_a_time_limit_ends_the_tool(tmp_path: Path, mound_plan: Path) -> None:
    tsp = big_tsp(tmp_path / "big.tsp")
    log = tmp_path / "tsp.log"
    start = time.monotonic()
    with pytest.raises(ToolTimeout) as err:
        native.run_tool("mound_plan", ["tsp", str(tsp)], timeout_s=1.0, log=log)
    assert time.monotonic() - start < 1.0 + native.GRACE_S + 2
    pid = int(log.read_text().split("[native] pid ")[1].split(":")[0])
    assert gone(pid)
    assert isinstance(err.value, ToolError) and "time limit" in log.read_text()


@pytest.mark.slow
def test_ctrl_c_during_a_long_call_leaves_no_child_behind(tmp_path: Path,
                                                           mound_plan: Path) -> None:
    tsp = big_tsp(tmp_path / "big.tsp")
    log = tmp_path / "tsp.log"
    script = ("import sys\nfrom mound import native\n"
              f"native.run_tool('mound_plan', ['tsp', {str(tsp)!r}], log={str(log)!r})\n")
    # The driver in its own process group, as a terminal's foreground job: Ctrl-C is a
    # SIGINT to that group, which the tool (in a session of its own) never sees.
    # SIGINT restored to its default in the driver: a run of the tests started in the
    # background (`make test &`) would otherwise pass on an ignored SIGINT.
    driver = subprocess.Popen([sys.executable, "-c", script], start_new_session=True,
                              stderr=subprocess.PIPE, text=True,
                              env={**os.environ, "PYTHONPATH": str(REPO_ROOT / "python")},
                              preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and not (log.exists() and "pid" in log.read_text()):
        time.sleep(0.05)
    pid = int(log.read_text().split("[native] pid ")[1].split(":")[0])
    time.sleep(0.5)
    assert not gone(pid), "the tool should still be working"
    os.killpg(driver.pid, signal.SIGINT)
    _, stderr = driver.communicate(timeout=native.GRACE_S + 10)
    assert driver.returncode != 0 and "KeyboardInterrupt" in stderr
    assert gone(pid), "the tool outlived the interrupted driver"
    assert "ended on interrupt" in log.read_text()


def _tools_naming(path: Path) -> list[int]:
    """The pids of the project's tools whose command line names `path`."""
    pids = []
    for d in Path("/proc").iterdir():
        try:
            cmd = (d / "cmdline").read_bytes().replace(b"\0", b" ").decode("utf-8", "replace")
        except OSError:
            continue
        if "mound_" in cmd and str(path) in cmd and "python" not in cmd:
            pids.append(int(d.name))
    return pids


@pytest.mark.slow
def test_sigterm_stops_a_command_and_its_tools_as_ctrl_c_does(tmp_path: Path,
                                                              mound_render: Path) -> None:
    """SIGTERM (a scheduler's or CI's stop) to `mound sim grid` while a tool runs: the tool
    is ended with it (before, Python died at once and the tool ran on), the command says so
    in one line and exits 143."""
    out = tmp_path / "grid"
    cmd = [sys.executable, "-m", "mound", "sim", "grid", "--out", str(out), "--sites", "40",
           "--size", "320", "240", "--dem", "none"]
    grid = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": str(REPO_ROOT / "python")})
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not _tools_naming(out):
        time.sleep(0.02)
    running = _tools_naming(out)
    assert running, "no tool of the grid was seen running"
    grid.send_signal(signal.SIGTERM)
    _, stderr = grid.communicate(timeout=native.GRACE_S + 30)
    assert grid.returncode == 143, stderr
    assert stderr.strip().splitlines()[-1] == "mound: terminated (SIGTERM)", stderr
    assert all(gone(pid) for pid in running), "a tool outlived the terminated command"


@pytest.mark.parametrize("tool, args", [("mound_render", ["job.json", "--help"]),
                                        ("mound_plan", ["sites.json", "--algo", "x", "--help"])])
def test_help_anywhere_prints_the_usage(tool: str, args: list[str]) -> None:
    run = native.run_tool(tool, args)
    assert run.stdout.startswith(f"usage: {tool}") and "--help anywhere" in run.stdout


@pytest.mark.parametrize("argv, usage", [
    (["field", "make", "--seed", "--help"], "usage: mound field make"),
    (["sim", "site", "--seed", "x", "-h"], "usage: mound sim site"),
    (["mission", "build", "--help", "plan.json"], "usage: mound mission build"),
])
def test_mound_help_anywhere(argv: list[str], usage: str,
                             capsys: pytest.CaptureFixture[str]) -> None:
    from mound.cli import main as mound_main

    with pytest.raises(SystemExit) as done:
        mound_main(argv)
    assert done.value.code == 0 and capsys.readouterr().out.startswith(usage)


def test_the_sanitized_run_takes_only_a_current_list_of_the_tests_that_run_tools(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """tools/native_tests.py: the traced ids, once each, stamped with the sources; `args`
    hands pytest that list only while the stamp is the sources', else nothing (the whole
    suite runs); an empty trace writes no list."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("native_tests",
                                                  REPO_ROOT / "tools" / "native_tests.py")
    assert spec is not None and spec.loader is not None
    nt = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(nt)
    trace, listing = tmp_path / "trace.txt", tmp_path / "native-tests.txt"
    trace.write_text("tests/a.py::t[1]\ntests/b.py::u\ntests/a.py::t[1]\n")
    assert nt.main(["write", str(trace), str(listing)]) == 0
    lines = listing.read_text().splitlines()
    assert lines == [f"# sources {nt.sources_stamp()}", "tests/a.py::t[1]", "tests/b.py::u"]
    capsys.readouterr()
    assert nt.main(["args", str(listing)]) == 0
    argfile = tmp_path / "native-tests.txt.args"
    assert capsys.readouterr().out.strip() == f"@{argfile}"
    assert argfile.read_text().splitlines() == ["tests/a.py::t[1]", "tests/b.py::u"]
    listing.write_text("# sources 0000\ntests/a.py::t[1]\n")  # written from other sources
    assert nt.main(["args", str(listing)]) == 0
    out = capsys.readouterr()
    assert out.out == "" and "other sources" in out.err
    trace.write_text("")
    assert nt.main(["write", str(trace), str(listing)]) == 0 and not listing.exists()
    assert nt.main(["args", str(listing)]) == 0 and capsys.readouterr().out == ""
    assert nt.main(["bogus"]) == 2
