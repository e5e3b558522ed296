"""One escaping rule: every HTML string a console page gets is markupsafe.Markup made from literal
templates (web/markup.py says why). These tests hold the whole source tree to that, so a new
component that formats outside text into HTML by hand fails here, not in a browser."""

import ast
from pathlib import Path

import pytest
from markupsafe import Markup

from web.markup import add_html, show

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = [
    "web",
    "server",
    "latency",
    "ptwl",
    "bench",
    "robot_sim",
]  # ptwl holds guard, recording, experiments
SINKS = {"add_html", "add_markdown"}
PAYLOAD = "<img src=x onerror=alert(1)>\"'&"


def _sources() -> list[Path]:
    files = [p for package in PACKAGES for p in (ROOT / package).rglob("*.py")]
    assert len(files) > 100  # the tree was found
    return files


def _sets_content(node: ast.AST) -> bool:
    """`x.content = ...`, `x.content += ...`, `x.content: T = ...` or `setattr(x, "content", ...)`."""
    targets: list[ast.expr] = []
    if isinstance(node, ast.Assign):
        targets = node.targets
    elif isinstance(node, ast.AugAssign | ast.AnnAssign):
        targets = [node.target]
    elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "setattr":
        name = node.args[1] if len(node.args) > 1 else None
        return not isinstance(name, ast.Constant) or name.value == "content"  # a computed name too
    return any(isinstance(t, ast.Attribute) and t.attr == "content" for t in targets)


def _markup_names(tree: ast.AST) -> set[str]:
    """The names `Markup` goes by in a module (aliases too)."""
    names = {"Markup"}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            names |= {a.asname or a.name for a in node.names if a.name == "Markup"}
    return names


def test_only_web_markup_touches_viser_html_sinks() -> None:
    offenders = []
    for path in _sources():
        if path == ROOT / "web" / "markup.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            func = node.func if isinstance(node, ast.Call) else None
            if isinstance(func, ast.Attribute) and func.attr in SINKS:
                offenders.append(f"{path.relative_to(ROOT)}:{node.lineno} calls {func.attr}")
            if _sets_content(node):
                offenders.append(f"{path.relative_to(ROOT)}:{node.lineno} sets .content")
    assert offenders == []


def _unsafe_markups(tree: ast.AST) -> list[int]:
    """Lines where Markup (by any name, or markupsafe.Markup) is built from anything but one
    string literal."""
    names = _markup_names(tree)
    lines = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        func = node.func
        called = (
            func.id if isinstance(func, ast.Name) else func.attr if isinstance(func, ast.Attribute) else ""
        )
        literal = len(node.args) == 1 and isinstance(node.args[0], ast.Constant)
        if called in names and (not (literal and isinstance(node.args[0].value, str)) or node.keywords):
            lines.append(node.lineno)
    return lines


def test_markup_is_only_built_from_literal_templates() -> None:
    offenders = [
        f"{path.relative_to(ROOT)}:{line}"
        for path in _sources()
        for line in _unsafe_markups(ast.parse(path.read_text(), str(path)))
    ]
    assert offenders == []


def test_the_rule_sees_the_ways_round_it() -> None:
    """The checks above, on code that would slip past a narrower one."""
    sneaky = ast.parse(
        "h.content += x\nsetattr(h, 'content', x)\nh.content: str = x\nh.label = x\n"
        "from markupsafe import Markup as M\nM(x)\nmarkupsafe.Markup(f'{x}')\nM('<b>{}</b>').format(x)\n"
    )
    assert sum(_sets_content(n) for n in ast.walk(sneaky)) == 3
    assert _unsafe_markups(sneaky) == [6, 7]


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
