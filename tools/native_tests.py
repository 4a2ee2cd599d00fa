"""Which Python tests run compiled code: `make test` traces them, `make test-asan` reruns them.

The sanitizers watch only the C++ tools; a test that never starts one runs the same code
under `make test-asan` as under `make test`. So `make test-python` runs with
$MOUND_TOOL_TRACE (mound.paths.build_dir appends the current test's id each time a tool is
located; conftest.py adds the tests that take a built tool as a fixture), and

    python tools/native_tests.py write TRACE LIST   the traced ids, stamped with the sources
    python tools/native_tests.py args LIST          pytest's arguments for the ASan run

`args` prints `@LIST.args` (pytest reads arguments from a file) when LIST was written from
these very sources (a sha256 over python/, tests/ and pyproject.toml), else nothing: a run
without a current trace is the whole suite.
"""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def sources_stamp() -> str:
    h = hashlib.sha256()
    files = sorted([*(ROOT / "python").rglob("*.py"), *(ROOT / "tests").rglob("*.py"),
                    ROOT / "pyproject.toml"])
    for f in files:
        h.update(str(f.relative_to(ROOT)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


def write(trace: Path, out: Path) -> int:
    ids = sorted(set(trace.read_text(encoding="utf-8").split("\n")) - {""}) \
        if trace.exists() else []
    if not ids:
        print(f"{trace}: no test ran a compiled tool; {out} not written", file=sys.stderr)
        out.unlink(missing_ok=True)
        return 0
    tmp = out.with_suffix(".tmp")
    tmp.write_text(f"# sources {sources_stamp()}\n" + "\n".join(ids) + "\n", encoding="utf-8")
    tmp.replace(out)
    print(f"{len(ids)} tests run compiled tools ({out})")
    return 0


def args(listing: Path) -> int:
    if not listing.exists():
        return 0
    lines = listing.read_text(encoding="utf-8").split("\n")
    if lines[0] != f"# sources {sources_stamp()}":
        print(f"{listing} is from other sources: the whole suite runs", file=sys.stderr)
        return 0
    ids = [ln for ln in lines[1:] if ln]
    argfile = listing.with_name(listing.name + ".args")
    argfile.write_text("\n".join(ids) + "\n", encoding="utf-8")
    print(f"@{argfile}")
    return 0


def main(argv: list[str]) -> int:
    if len(argv) == 3 and argv[0] == "write":
        return write(Path(argv[1]), Path(argv[2]))
    if len(argv) == 2 and argv[0] == "args":
        return args(Path(argv[1]))
    print("usage: native_tests.py write TRACE LIST | args LIST", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
