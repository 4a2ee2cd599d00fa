#!/usr/bin/env python3
"""The shape of the Python package, measured from its source (issue 57): the largest
modules and functions, the import cycles between modules (imports inside functions
included), the private names one module imports from another (issue 70), and how often
`dict[str, Any]` is written.

    python tools/py_shape.py [--json]
"""
from __future__ import annotations

import ast
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "python" / "mound"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def imports_of(name: str, path: Path, known: set[str]) -> set[str]:
    """The package's modules `name` imports, at any depth of its code (a function's
    imports included); `from a import b` names a.b when that is a module, else a."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name in known:
                    out.add(a.name)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            for a in node.names:
                if f"{mod}.{a.name}" in known:
                    out.add(f"{mod}.{a.name}")
                elif mod in known:
                    out.add(mod)
    out.discard(name)
    return out


def private_imports_of(name: str, text: str) -> list[str]:
    """`module:line name` for each private name (`_x`, not a dunder) that module `name`
    imports from another module of the package."""
    out = []
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.ImportFrom) and not node.level and node.module and \
                node.module.startswith("mound") and node.module != name:
            out += [f"{name}:{node.lineno} {node.module}.{a.name}" for a in node.names
                    if a.name.startswith("_") and not a.name.startswith("__")]
    return out


def private_imports() -> list[str]:
    return [x for n, p in modules().items()
            for x in private_imports_of(n, p.read_text(encoding="utf-8"))]


def import_graph() -> dict[str, set[str]]:
    mods = modules()
    known = set(mods)
    return {n: imports_of(n, p, known) for n, p in mods.items()}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm),
    plus each module that imports itself."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10_000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def functions() -> list[tuple[int, str]]:
    """(lines, module:qualified name) of every function and method."""
    out = []
    for name, path in modules().items():
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))

        def walk(node: ast.AST, prefix: str, module: str) -> None:
            for child in ast.iter_child_nodes(node):
                if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                    q = f"{prefix}{child.name}"
                    end = child.end_lineno or child.lineno
                    out.append((end - child.lineno + 1, f"{module}:{q}"))
                    walk(child, q + ".", module)
                elif isinstance(child, ast.ClassDef):
                    walk(child, f"{prefix}{child.name}.", module)

        walk(tree, "", name)
    return sorted(out, reverse=True)


def shape() -> dict[str, object]:
    mods = modules()
    lines = sorted(((len(p.read_text(encoding="utf-8").splitlines()), n)
                    for n, p in mods.items()), reverse=True)
    funcs = functions()
    return {
        "modules": len(mods),
        "lines": sum(n for n, _ in lines),
        "largest_modules": [{"module": m, "lines": n} for n, m in lines[:5]],
        "modules_over_600": sum(n > 600 for n, _ in lines),
        "largest_functions": [{"function": f, "lines": n} for n, f in funcs[:5]],
        "functions_over_100": sum(n > 100 for n, _ in funcs),
        "import_cycles": cycles(import_graph()),
        "private_imports": private_imports(),
        "dict_str_any": sum(p.read_text(encoding="utf-8").count("dict[str, Any]")
                            for p in mods.values()),
    }


def main() -> int:
    s = shape()
    if "--json" in sys.argv[1:]:
        print(json.dumps(s, indent=1))
        return 0
    print(f"{s['modules']} modules, {s['lines']} lines")
    print(f"largest modules ({s['modules_over_600']} over 600 lines):")
    for m in s["largest_modules"]:  # type: ignore[attr-defined]
        print(f"  {m['lines']:5d}  {m['module']}")
    print(f"largest functions ({s['functions_over_100']} over 100 lines):")
    for f in s["largest_functions"]:  # type: ignore[attr-defined]
        print(f"  {f['lines']:5d}  {f['function']}")
    cyc = s["import_cycles"]
    print(f"import cycles: {len(cyc)}")  # type: ignore[arg-type]
    for c in cyc:  # type: ignore[attr-defined]
        print("  " + " <-> ".join(c))
    priv = s["private_imports"]
    print(f"private names imported across modules: {len(priv)}")  # type: ignore[arg-type]
    for x in priv:  # type: ignore[attr-defined]
        print("  " + x)
    print(f"dict[str, Any] written {s['dict_str_any']} times")
    return 0


if __name__ == "__main__":
    sys.exit(main())
