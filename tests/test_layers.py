"""The house's arrows all point down (issue 28.3): each package imports only packages below it,
at import time or lazily, so there is no cycle; and the console checks a command by the API's
models without importing FastAPI or the server."""

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# Bottom to top. ptwl_config is the `config/` directory's package.
LAYERS = [
    "ptwl_config",
    "guard",
    "robot_sim",
    "recording",
    "latency",
    "server",
    "web",
    "experiments",
    "ptwl",
    "bench",
]
DIRS = {"ptwl_config": "config"}


def imports_of(package: str) -> dict[str, set[str]]:
    """{imported package: the files that import it}, every import in the package's files."""
    found: dict[str, set[str]] = {}
    for path in (ROOT / DIRS.get(package, package)).rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                root = name.split(".")[0]
                if root in LAYERS and root != package:
                    found.setdefault(root, set()).add(str(path.relative_to(ROOT)))
    return found


def test_every_import_points_down() -> None:
    upward = {
        f"{package} -> {imported}": sorted(files)
        for package in LAYERS
        for imported, files in imports_of(package).items()
        if LAYERS.index(imported) > LAYERS.index(package)
    }
    assert upward == {}


def test_the_console_checks_commands_without_fastapi_or_the_server() -> None:
    loaded = "sorted({m.split('.')[0] for m in sys.modules} & {'fastapi', 'server', 'starlette'})"
    code = f"import sys, web.checks; print({loaded})"
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60
    )
    assert result.stdout.strip() == "[]", result.stderr
