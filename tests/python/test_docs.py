"""The documentation stays a front door plus docs/: the README's size and links, and the
layering the architecture page draws (read from the code by tools/docs/hooks.py)."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest
from markdown.extensions.toc import slugify

ROOT = Path(__file__).resolve().parents[2]
LINK = re.compile(r"\]\(([^)\s]+)\)")


def _tool(name: str, path: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / path)
    assert spec and spec.loader
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _hooks():
    return _tool("docs_hooks", "tools/docs/hooks.py")


def _anchors(md: Path) -> set[str]:
    fence, out = False, set()
    for line in md.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            fence = not fence
        elif not fence and line.startswith("#"):
            title = line.lstrip("#").strip().replace("`", "")
            out.add(slugify(title, "-"))
    return out


def test_the_readme_is_a_front_door() -> None:
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 200
    text = "\n".join(lines)
    for must in ("make demo", "make test", "python python/mission.py", "mound_plan sites.json 120"):
        assert must in text


@pytest.mark.parametrize("name", ["README.md", "CHANGELOG.md"])
def test_links_outside_docs_reach_a_file_and_its_heading(name: str) -> None:
    """mkdocs --strict checks the links inside docs/; these two files live outside it."""
    src = ROOT / name
    links = LINK.findall(src.read_text(encoding="utf-8"))
    assert links
    for link in links:
        if link.startswith(("http://", "https://")):
            continue
        path, _, anchor = link.partition("#")
        target = (src.parent / path).resolve()
        assert target.is_file(), f"{name}: {link}"
        if anchor:
            assert anchor in _anchors(target), f"{name}: {link}: no such heading"


def test_cpp_libraries_form_layers_and_keep_heavy_dependencies_private() -> None:
    hooks = _hooks()
    libs = hooks.cpp_layers()
    levels = hooks._levels({n: m for n, (m, _) in libs.items()})  # raises on a cycle
    assert levels["mound_common"] == 0
    owners = {"OpenCV": {"mound_sfm", "mound_mvs", "mound_sim"}, "Ceres::ceres": {"mound_ba"},
              "PCL": {"mound_icp"}}
    for dep, allowed in owners.items():
        users = {n for n, (_, private) in libs.items() if dep in private}
        assert users and users <= allowed, (dep, users)


def test_python_packages_form_layers() -> None:
    hooks = _hooks()
    uses = hooks.python_layers()
    units = {u: {d for d in ds if d in uses} for u, ds in uses.items()}
    levels = hooks._levels(units)  # raises on a cycle
    assert levels["survey"] == max(levels.values())
    assert "survey" not in set().union(*units.values())


def test_no_python_package_imports_upwards() -> None:
    """Issue 70: the planner took flight geometry from the missions (plan -> uav) and the
    3-D stage its training from the simulator (recon -> sim); each package imports only
    the layers below it (hooks.PYTHON_LAYERS). The check finds both planted back."""
    hooks = _hooks()
    uses = hooks.python_layers()
    assert hooks.upward_imports(uses) == []
    planted = {**uses, "plan": uses["plan"] | {"uav"}, "recon": uses["recon"] | {"sim"}}
    assert hooks.upward_imports(planted) == ["plan -> uav", "recon -> sim"]
    assert hooks.upward_imports({**uses, "newpkg": set()}) == [
        "newpkg: not placed in PYTHON_LAYERS"]


def test_no_import_cycle_between_python_modules() -> None:
    """Module by module, imports inside functions included (issue 57: three cycles were
    hidden by imports inside functions); the checker finds a planted one."""
    shape = _tool("py_shape", "tools/py_shape.py")
    graph = shape.import_graph()
    assert len(graph) > 50 and graph["mound.survey.driver"]  # it reads the package
    assert shape.cycles(graph) == []
    planted = {**graph, "mound.jsonio": graph["mound.jsonio"] | {"mound.survey.driver"}}
    assert any("mound.jsonio" in c for c in shape.cycles(planted))


def test_no_private_name_is_imported_from_another_module() -> None:
    """A module's `_name` is its own (issue 70): what another module needs is public. The
    checker finds a planted import, and leaves dunders and a module's own names alone."""
    shape = _tool("py_shape", "tools/py_shape.py")
    assert shape.private_imports() == []
    planted = "from mound.plan.exact import flow_graph, _helper\nfrom mound.x import __all__\n"
    assert shape.private_imports_of("mound.plan.cli", planted) == [
        "mound.plan.cli:1 mound.plan.exact._helper"]
    assert shape.private_imports_of("mound.plan.exact", "from mound.plan.exact import _a") == []


def test_every_spec_checks_itself_with_check() -> None:
    """One name for a spec's self-check (issue 70: `validate` in 8 classes, `check` in 2)."""
    import ast

    shape = _tool("py_shape", "tools/py_shape.py")
    named = [f"{m}:{node.lineno}" for m, path in shape.modules().items()
             for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
             if isinstance(node, ast.FunctionDef) and node.name == "validate"]
    assert named == []


def test_no_cpp_function_is_longer_than_150_lines(tmp_path) -> None:
    """Issue 70: Reconstruct (414 lines), DetectMound (274) and six more were split along
    their seams; the measure (tools/cpp_shape.py) finds every function and a planted long
    one."""
    shape = _tool("cpp_shape", "tools/cpp_shape.py")
    found = shape.shape()
    assert len(found) > 400 and any("Reconstruct" in w for _, w in found)
    assert [w for n, w in found if n > shape.MAX_LINES] == []
    body = "\n".join(f"  x += {k};" for k in range(160))
    src = tmp_path / "long.cc"
    src.write_text(f"namespace a {{\n\nint Long(int x,\n         int y) {{\n{body}\n"
                   "  return x;\n}\n\nstruct S {\n  int a;\n};\n\nint f();\n")
    assert shape.functions(src) == [(164, "Long", 3)]


def test_the_plan_example_is_shortened_but_keeps_its_ends() -> None:
    short = _hooks()._short
    assert short(["home", *[f"s{i:03d}" for i in range(50)], "home"]).endswith('"s049", "home"]')
    assert short({"a": 1}) == '{"a": 1}'
    assert len(short({"k": "x" * 500})) < 100


def test_one_version_everywhere() -> None:
    """pyproject.toml holds the version; the package and every C++ tool report it."""
    import subprocess
    import tomllib

    import mound
    from mound.paths import build_dir

    want = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"][
        "version"]
    assert mound.__version__ == want
    for tool in ("mound_plan", "mound_recon", "mound_render", "mound_scene"):
        out = subprocess.run([str(build_dir() / tool), "--version"], capture_output=True,
                             text=True, check=True).stdout.split()
        assert out == [tool, want]


def test_no_package_imports_a_command_line_module() -> None:
    """Command lines map flags onto library calls; libraries never import them back."""
    pattern = re.compile(r"^\s*from mound(?:\.\w+)*\.cli import|^\s*from mound import cli\b|"
                         r"^\s*import mound(?:\.\w+)*\.cli\b|^\s*from mound\.\w+ import cli\b",
                         re.M)
    offenders = []
    for f in (ROOT / "python" / "mound").rglob("*.py"):
        if f.name in ("cli.py", "__main__.py"):
            continue
        if pattern.search(f.read_text(encoding="utf-8")):
            offenders.append(str(f.relative_to(ROOT)))
    assert offenders == []
