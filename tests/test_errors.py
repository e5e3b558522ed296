"""One root for the project's errors (issue 28.2): every exception class a package defines for
others to catch subclasses ptwl_config.PtwlError, so a script can catch "anything ptwl-console
refused" in one clause, and the subclass's name says what went wrong. (A private one, used for
control flow inside a module, is exempt.)"""

import ast
import importlib
from pathlib import Path

from ptwl_config import ConfigError, PtwlError

from robot_sim.errors import RobotSimError
from tests.test_layers import LAYERS, directory_of, files_of


def public_classes() -> list[tuple[str, str]]:
    """(module, class name) of every public class with a base, in every package."""
    found = []
    for package in LAYERS:
        directory = directory_of(package)
        for path in files_of(package):
            parts = [package, *path.relative_to(directory).with_suffix("").parts]
            module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            for node in ast.parse(Path(path).read_text()).body:
                if isinstance(node, ast.ClassDef) and node.bases and not node.name.startswith("_"):
                    found.append((module, node.name))
    return found


def test_every_public_exception_has_the_one_root() -> None:
    exceptions = {}
    for module, name in public_classes():
        cls = getattr(importlib.import_module(module), name)
        if isinstance(cls, type) and issubclass(cls, BaseException):
            exceptions[f"{module}.{name}"] = cls
    assert len(exceptions) >= 15  # the scan found them (robot_sim, server, web, latency, ...)
    assert {name for name, cls in exceptions.items() if not issubclass(cls, PtwlError)} == set()


def test_package_roots_and_builtin_kinds_are_kept() -> None:
    """robot_sim keeps its own root under the project's; an error a caller catches as a
    built-in kind still is one."""
    from latency.named import LinkConfigError
    from ptwl.recording.reader import RecordingError
    from robot_sim.command_book import FutureSentAtError, QueueFullError
    from robot_sim.errors import UnknownNameError

    assert issubclass(RobotSimError, PtwlError) and issubclass(QueueFullError, RobotSimError)
    assert issubclass(UnknownNameError, KeyError) and issubclass(FutureSentAtError, ValueError)
    assert all(issubclass(e, ValueError) for e in (ConfigError, LinkConfigError, RecordingError))
