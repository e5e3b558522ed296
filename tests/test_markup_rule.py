"""One escaping rule: every HTML string a console page gets is markupsafe.Markup made from literal
templates (web/markup.py says why). These tests hold the whole source tree to that, so a new
component that formats outside text into HTML by hand fails here, not in a browser."""

import ast
from pathlib import Path

import pytest
from markupsafe import Markup

from web.markup import add_html, show

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ["web", "recording", "server", "latency", "experiments", "ptwl", "bench", "guard", "robot_sim"]
SINKS = {"add_html", "add_markdown"}
PAYLOAD = "<img src=x onerror=alert(1)>\"'&"


def _sources() -> list[Path]:
    files = [p for package in PACKAGES for p in (ROOT / package).rglob("*.py")]
    assert len(files) > 100  # the tree was found
    return files


def test_only_web_markup_touches_viser_html_sinks() -> None:
    offenders = []
    for path in _sources():
        if path == ROOT / "web" / "markup.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            func = node.func if isinstance(node, ast.Call) else None
            if isinstance(func, ast.Attribute) and func.attr in SINKS:
                offenders.append(f"{path.relative_to(ROOT)}:{node.lineno} calls {func.attr}")
            targets = node.targets if isinstance(node, ast.Assign) else []
            for target in targets:
                if isinstance(target, ast.Attribute) and target.attr == "content":
                    offenders.append(f"{path.relative_to(ROOT)}:{node.lineno} sets .content")
    assert offenders == []


def test_markup_is_only_built_from_literal_templates() -> None:
    offenders = []
    for path in _sources():
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "Markup":
                literal = len(node.args) == 1 and isinstance(node.args[0], ast.Constant)
                if not (literal and isinstance(node.args[0].value, str)) or node.keywords:
                    offenders.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert offenders == []


def test_a_plain_string_is_refused_at_the_sink() -> None:
    class Handle:
        content = ""

    with pytest.raises(TypeError, match="Markup"):
        show(Handle(), PAYLOAD)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="Markup"):
        add_html(None, "<b>x</b>")  # type: ignore[arg-type]
    handle = Handle()
    show(handle, Markup("<b>{}</b>").format(PAYLOAD))
    assert handle.content == "<b>&lt;img src=x onerror=alert(1)&gt;&#34;&#39;&amp;</b>"
