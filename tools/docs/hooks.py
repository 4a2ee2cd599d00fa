"""MkDocs hooks: the command-line reference is generated from the tools themselves, so the
docs cannot drift from them (mkdocs.yml names this file under `hooks:`).

A page holds a marker where the text goes; the build runs the command and puts its output
in a code block. Any failure (a tool not built, a non-zero exit) stops the build.

    <!-- help: mound_recon reconstruct -->   build/mound_recon reconstruct --help
    <!-- help: mission.py -->                python python/mission.py --help
    <!-- help-tree: mound -->                `mound --help` and every verb's --help, each
                                             under its own heading
    <!-- run: mound_plan sites.json 120 --> the command's JSON output, one line per key
                                             (long lists shortened)
    <!-- layers: cpp -->                     the C++ libraries by layer, from CMake
    <!-- layers: python -->                  the Python subpackages by layer, from imports
    <!-- include: CHANGELOG.md -->           a Markdown file of the repository (outside
                                             docs/), its links into docs/ made relative

The C++ tools come from $MOUND_BUILD_DIR (default build/, as in mound.paths), Python from
the running interpreter (the project's .venv when `make docs` runs it).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

from mkdocs.exceptions import PluginError

ROOT = Path(__file__).resolve().parents[2]
NATIVE = ("mound_plan", "mound_recon", "mound_render", "mound_scene")
MARKER = re.compile(r"<!-- (help|help-tree|run|include|layers): ([^>]*?) -->")


def _argv(words: list[str]) -> list[str]:
    prog, rest = words[0], words[1:]
    if prog in NATIVE:
        build = Path(os.environ.get("MOUND_BUILD_DIR", ROOT / "build"))
        exe = build / prog if build.is_absolute() else ROOT / build / prog
        return [str(exe), *rest]
    if prog == "mound":
        return [sys.executable, "-m", "mound", *rest]
    if prog == "mission.py":
        return [sys.executable, str(ROOT / "python" / "mission.py"), *rest]
    raise PluginError(f"docs: unknown program {prog!r} in a marker")


def _output(words: list[str]) -> str:
    argv = _argv(words)
    env = {**os.environ, "PYTHONPATH": str(ROOT / "python"), "COLUMNS": "100"}
    try:
        r = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired) as e:
        raise PluginError(f"docs: {' '.join(words)}: {e} (is the project built?)") from e
    if r.returncode != 0:
        raise PluginError(f"docs: {' '.join(words)} exited {r.returncode}: "
                          f"{r.stderr.strip()[-300:]}")
    return r.stdout.rstrip()


def _fence(text: str) -> str:
    return f"```text\n{text}\n```"


def _short(value: Any) -> str:
    """A value on one line of at most ~90 characters: long lists keep their ends."""
    text = json.dumps(value)
    if len(text) <= 90:
        return text
    if isinstance(value, list) and len(value) > 6 and all(isinstance(v, str) for v in value):
        head = ", ".join(json.dumps(v) for v in value[:4])
        tail = ", ".join(json.dumps(v) for v in value[-2:])
        return f"[{head}, ... {len(value) - 6} more ..., {tail}]"
    if isinstance(value, list):
        return f"[{len(value)} items: {json.dumps(value[0])[:60]} ...]"
    return text[:86] + " ..."


def _run(words: list[str]) -> str:
    out = _output(words)
    try:
        doc = json.loads(out)
    except json.JSONDecodeError:
        return _fence(out)
    if not isinstance(doc, dict):
        return _fence(out)
    lines = [f'  "{k}": {_short(v)},' for k, v in doc.items()]
    if lines:
        lines[-1] = lines[-1].rstrip(",")
    return "```json\n{\n" + "\n".join(lines) + "\n}\n```"


def _include(words: list[str]) -> str:
    path = (ROOT / words[0]).resolve()
    if len(words) != 1 or ROOT not in path.parents or path.suffix != ".md":
        raise PluginError(f"docs: include: {' '.join(words)}: one Markdown file of the repository")
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        raise PluginError(f"docs: include: {e}") from e
    return text.replace("](docs/", "](")


def _verbs(parser: argparse.ArgumentParser, path: list[str]
           ) -> list[tuple[list[str], argparse.ArgumentParser]]:
    found = [(path, parser)]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found += _verbs(sub, [*path, name])
    return found


def _tree(words: list[str]) -> str:
    if words != ["mound"]:
        raise PluginError("docs: help-tree is for `mound` only")
    sys.path.insert(0, str(ROOT / "python"))
    from mound.cli import build_parser

    # What `--help` prints is the parser's format_help(): formatted here, in one process,
    # at the width the subprocesses get. The top level is run for real, as a check.
    os.environ["COLUMNS"] = "100"
    parts = ["## `mound`\n\n" + _fence(_output(["mound", "--help"]))]
    for path, parser in _verbs(build_parser(), ["mound"])[1:]:
        parts.append(f"## `{' '.join(path)}`\n\n" + _fence(parser.format_help().rstrip()))
    return "\n\n".join(parts)


def on_page_markdown(markdown: str, **_: Any) -> str:
    def replace(m: re.Match[str]) -> str:
        kind, words = m.group(1), m.group(2).split()
        if not words:
            raise PluginError(f"docs: empty marker {m.group(0)!r}")
        if kind == "help":
            return _fence(_output([*words, "--help"]))
        if kind == "run":
            return _run(words)
        if kind == "include":
            return _include(words)
        if kind == "layers":
            return _layers(words)
        return _tree(words)

    return MARKER.sub(replace, markdown)


# --- the architecture page: who uses whom, read from the code at build time -------------

_LIB = re.compile(r"mound_add_library\(\s*(\w+)(.*?)\)", re.S)


def cpp_layers() -> dict[str, tuple[set[str], set[str]]]:
    """{library: (project libraries it links, outside libraries it keeps private)} from
    cpp/*/CMakeLists.txt (mound_add_library blocks)."""
    libs: dict[str, tuple[set[str], set[str]]] = {}
    for cm in sorted((ROOT / "cpp").glob("*/CMakeLists.txt")):
        for name, body in _LIB.findall(cm.read_text(encoding="utf-8")):
            words = body.split()
            mine: set[str] = set()
            private: set[str] = set()
            section = ""
            for w in words:
                if w.isupper() and w.endswith(("DEPS", "SRCS")):
                    section = w
                elif section.endswith("DEPS"):
                    if w.startswith("mound_"):
                        mine.add(w)
                    elif section == "PRIVATE_DEPS":
                        private.add(re.sub(r"\$\{(\w+?)(_LIBS|_LIBRARIES)?\}", r"\1", w))
            libs[name] = (mine, private)
    return libs


def python_layers() -> dict[str, set[str]]:
    """{subpackage of mound: the other subpackages (or top-level modules) it imports}."""
    pkg = ROOT / "python" / "mound"
    units = sorted(p.name for p in pkg.iterdir() if p.is_dir() and (p / "__init__.py").exists())
    uses: dict[str, set[str]] = {u: set() for u in units}
    imp = re.compile(r"^\s*(?:from|import)\s+mound\.(\w+)", re.M)
    for u in units:
        for f in (pkg / u).rglob("*.py"):
            for target in imp.findall(f.read_text(encoding="utf-8")):
                if target != u:
                    uses[u].add(target)
    return uses


# The Python packages' intended layers, lowest first (issue 70): a package imports only
# packages of lower layers. A new package is placed here; test_docs fails on an import
# upwards or sideways (plan -> uav, recon -> sim were such).
PYTHON_LAYERS = (("classify", "geometry"),
                 ("formats",),
                 ("recon", "scene"),
                 ("flightplan", "photos", "sim"),
                 ("grids", "plan", "training", "uav"),
                 ("survey",))


def upward_imports(uses: dict[str, set[str]]) -> list[str]:
    """`a -> b` for each package a that imports a package b not below it in PYTHON_LAYERS
    (and `a: not placed` for a package the table lacks)."""
    rank = {p: k for k, layer in enumerate(PYTHON_LAYERS) for p in layer}
    out = [f"{a}: not placed in PYTHON_LAYERS" for a in uses if a not in rank]
    for a, targets in sorted(uses.items()):
        for b in sorted(targets):
            if a in rank and b in rank and rank[b] >= rank[a]:
                out.append(f"{a} -> {b}")
    return out


def _levels(deps: dict[str, set[str]]) -> dict[str, int]:
    level: dict[str, int] = {}

    def of(n: str, seen: tuple[str, ...] = ()) -> int:
        if n in level:
            return level[n]
        if n in seen:
            raise PluginError(f"docs: dependency cycle through {' -> '.join((*seen, n))}")
        inner = [of(d, (*seen, n)) for d in deps.get(n, ()) if d in deps]
        level[n] = 1 + max(inner, default=-1)
        return level[n]

    for n in deps:
        of(n)
    return level


def _layers(words: list[str]) -> str:
    if words == ["cpp"]:
        libs = cpp_layers()
        deps = {n: m for n, (m, _) in libs.items()}
        level = _levels(deps)
        rows = ["| layer | library | uses | outside libraries (private) |", "|---|---|---|---|"]
        for n in sorted(deps, key=lambda n: (level[n], n)):
            rows.append(f"| {level[n]} | `{n}` | "
                        f"{', '.join(f'`{d}`' for d in sorted(deps[n])) or '—'} | "
                        f"{', '.join(sorted(libs[n][1])) or '—'} |")
        return "\n".join(rows)
    if words == ["python"]:
        uses = python_layers()
        units = {u: {d for d in ds if d in uses} for u, ds in uses.items()}
        level = _levels(units)
        rows = ["| layer | package | uses packages | uses modules |", "|---|---|---|---|"]
        for n in sorted(units, key=lambda n: (level[n], n)):
            mods = sorted(uses[n] - set(uses))
            rows.append(f"| {level[n]} | `mound.{n}` | "
                        f"{', '.join(f'`{d}`' for d in sorted(units[n])) or '—'} | "
                        f"{', '.join(f'`{m}`' for m in mods) or '—'} |")
        return "\n".join(rows)
    raise PluginError(f"docs: layers: cpp or python, not {' '.join(words)!r}")
