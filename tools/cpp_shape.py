"""The C++ side's shape: its longest functions (issue 70: none over MAX_LINES in cpp/
outside tests). clang-format puts a function defined at namespace level at column 0,
its signature ending in `{` (or its opening line followed by continuation lines) and its
closing `}` alone at column 0: that is what is measured, from the signature's first line
to the closing brace, as py_shape.py measures Python's.

    .venv/bin/python tools/cpp_shape.py [--top N]
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MAX_LINES = 150
NOT_FUNCTIONS = re.compile(r"^(namespace|struct|class|enum|union|extern|template\s*<[^>]*>\s*"
                           r"(struct|class))\b")


def functions(path: Path) -> list[tuple[int, str, int]]:
    """(lines, name, first line) of each function defined at column 0 in `path`."""
    lines = path.read_text(encoding="utf-8").splitlines()
    out = []
    start = None
    for k, line in enumerate(lines):
        if start is None:
            if (line and not line[0].isspace() and not line.startswith(("#", "//", "}"))
                    and not NOT_FUNCTIONS.match(line) and "(" in line and ";" not in line
                    and "=" not in line.split("(")[0]):
                start = k
            continue
        if line.startswith("}"):
            name = re.findall(r"([\w:~]+)\s*\(", " ".join(lines[start:start + 3]))
            out.append((k - start + 1, name[0] if name else "?", start + 1))
            start = None
        elif line and not line[0].isspace() and not line.startswith(("#", "//")):
            # a declaration without a body, or a prototype: start again here
            start = k if "(" in line and ";" not in line else None
    return out


def shape() -> list[tuple[int, str]]:
    """(lines, path:name:line) of every function in cpp/ outside tests, longest first."""
    found = []
    for path in sorted((ROOT / "cpp").rglob("*.cc")) + sorted((ROOT / "cpp").rglob("*.h")):
        if path.name.endswith(("_test.cc", "_fuzz.cc")):
            continue
        rel = path.relative_to(ROOT)
        found += [(n, f"{rel}:{name}:{line}") for n, name, line in functions(path)]
    return sorted(found, reverse=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--top", type=int, default=10)
    args = ap.parse_args()
    found = shape()
    over = [f for f in found if f[0] > 100]
    print(f"{len(found)} functions in cpp/ (tests left out); {len(over)} over 100 lines, "
          f"{sum(n > MAX_LINES for n, _ in found)} over {MAX_LINES}")
    for n, where in found[:args.top]:
        print(f"  {n:5d}  {where}")


if __name__ == "__main__":
    main()
