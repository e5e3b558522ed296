"""The house's arrows all point down (issue 28.3): each package imports only packages below it,
at import time or lazily, so there is no cycle; and the console checks a command by the API's
models without importing FastAPI or the server."""

import ast
import graphlib
import subprocess
import sys
from pathlib import Path

import pytest

from ptwl.launcher import running_proxy

ROOT = Path(__file__).resolve().parents[1]
# Bottom to top. ptwl_config is the `config/` directory's package; guard, recording and
# experiments live under the ptwl namespace (ptwl/<name>/), the rest of ptwl (the command line,
# the launcher) is the top but for bench, which is not installed.
LAYERS = [
    "ptwl_config",
    "ptwl.guard",
    "robot_sim",
    "ptwl.recording",
    "latency",
    "server",
    "web",
    "ptwl.experiments",
    "ptwl",
    "bench",
]
DIRS = {"ptwl_config": "config"}


def directory_of(layer: str) -> Path:
    return ROOT / DIRS.get(layer, layer.replace(".", "/"))


def layer_of(module: str) -> str | None:
    """The layer a dotted module name belongs to: the longest layer name it starts with."""
    matches = [layer for layer in LAYERS if module == layer or module.startswith(layer + ".")]
    return max(matches, key=len, default=None)


def files_of(layer: str) -> list[Path]:
    """The layer's own files (ptwl's without its sub-layers)."""
    nested = [directory_of(other) for other in LAYERS if other.startswith(layer + ".")]
    return [
        path
        for path in directory_of(layer).rglob("*.py")
        if not any(path.is_relative_to(inner) for inner in nested)
    ]


def imports_of(package: str) -> dict[str, set[str]]:
    """{imported layer: the files that import it}, every import in the layer's files."""
    found: dict[str, set[str]] = {}
    for path in files_of(package):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [f"{node.module}.{alias.name}" for alias in node.names]
            else:
                continue
            for name in names:
                layer = layer_of(name)
                if layer is not None and layer != package:
                    found.setdefault(layer, set()).add(str(path.relative_to(ROOT)))
    return found


def test_every_import_points_down() -> None:
    upward = {
        f"{package} -> {imported}": sorted(files)
        for package in LAYERS
        for imported, files in imports_of(package).items()
        if LAYERS.index(imported) > LAYERS.index(package)
    }
    assert upward == {}


def module_graph(package: str) -> dict[str, set[str]]:
    """{module: the modules of the same package it imports at run time (lazily or not; an
    `if TYPE_CHECKING:` import is for the type checker only)}."""
    directory = directory_of(package)
    modules: dict[str, Path] = {}
    for path in files_of(package):
        parts = [package, *path.relative_to(directory).with_suffix("").parts]
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    graph: dict[str, set[str]] = {}
    for module, path in modules.items():
        tree = ast.parse(path.read_text())
        type_only = {
            id(inner)
            for node in ast.walk(tree)
            if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)
            for inner in ast.walk(node)
        }
        imported: set[str] = set()
        for node in ast.walk(tree):
            if id(node) in type_only:
                continue
            if isinstance(node, ast.Import):
                imported |= {alias.name for alias in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                # `from a import b`: the module a.b if there is one, else a itself.
                subs = {f"{node.module}.{alias.name}" for alias in node.names}
                imported |= (subs & modules.keys()) or {node.module}
                if not subs <= modules.keys():
                    imported.add(node.module)
        graph[module] = (imported & modules.keys()) - {module}
    return graph


@pytest.mark.parametrize("package", LAYERS)
def test_no_module_imports_one_that_imports_it_back(package: str) -> None:
    """Inside each package too: robot_sim's params resolves preset and task names through a
    registry its owners fill (params.NAMED), rather than importing them lazily."""
    try:
        tuple(graphlib.TopologicalSorter(module_graph(package)).static_order())
    except graphlib.CycleError as err:
        pytest.fail(f"{package}: an import cycle: {' -> '.join(err.args[1])}")


def test_module_graph_sees_a_lazy_import_cycle(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The check above can fail: a lazy import back is a cycle, a TYPE_CHECKING one is not."""
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from pkg import b\n")
    (package / "b.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import pkg.a\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    assert module_graph("pkg") == {"pkg": set(), "pkg.a": {"pkg.b"}, "pkg.b": set()}
    (package / "b.py").write_text("def f():\n    from pkg.a import x\n")
    assert module_graph("pkg")["pkg.b"] == {"pkg.a"}
    with pytest.raises(graphlib.CycleError):
        tuple(graphlib.TopologicalSorter(module_graph("pkg")).static_order())


def test_the_console_checks_commands_without_fastapi_or_the_server() -> None:
    loaded = "sorted({m.split('.')[0] for m in sys.modules} & {'fastapi', 'server', 'starlette'})"
    code = f"import sys, web.checks; print({loaded})"
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60
    )
    assert result.stdout.strip() == "[]", result.stderr


def test_the_links_entry_point_imports_only_the_link() -> None:
    """What the launcher starts for every link: parsing its arguments and loading the link
    itself reaches none of the robot's physics (robot_sim, MuJoCo, the numba-compiled tick), which
    cost each start ~0.9 s of CPU."""
    robot = "{'robot_sim', 'mujoco', 'numba', 'server', 'web'}"
    heavy = f"sorted({{m.split('.')[0] for m in sys.modules}} & {robot})"
    code = (
        "import sys, ptwl.proxy_cli, latency.serve\n"
        "ptwl.proxy_cli.add_proxy_parser(__import__('argparse').ArgumentParser().add_subparsers())\n"
        f"print({heavy})"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60
    )
    assert result.stdout.strip() == "[]", result.stdout + result.stderr
    with running_proxy("http://127.0.0.1:9") as link:  # and it is what the launcher starts
        args = link.process.args
        assert isinstance(args, list) and args[1:3] == ["-m", "ptwl.proxy_cli"], args
