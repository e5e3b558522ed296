"""The one way anything reaches a console page as HTML.

viser's Html and Markdown components hand their content to the browser as raw HTML without
sanitising it (Markdown passes embedded tags through its rehype-raw step). Much of what the
console shows comes from outside: a command's sender and detail, frame, scene and task names,
exit reasons, link profile descriptions, and anything in a recording being replayed. So every
HTML string put on a page is a `markupsafe.Markup`, built only from literal templates with
`Markup(template).format(...)`, `Markup(...).join(...)` or `+`, which escape every value that is
not Markup already. `tests/test_markup_rule.py` holds the code to that: no other module calls
viser's `add_html`/`add_markdown` or sets a handle's `content`, and no `Markup(...)` is built from
anything but a string literal. Text that needs no markup (notifications, labels, dropdown
options) goes through viser's text components, which React renders as text.
"""

from typing import Any

import viser
from markupsafe import Markup, escape

__all__ = ["Markup", "add_html", "escape", "show"]


def add_html(gui: viser.GuiApi, content: Markup, order: float | None = None) -> Any:
    """An Html component showing `content` (escaped where it came from outside)."""
    _check(content)
    return gui.add_html(str(content), order=order)


def show(handle: Any, content: Markup) -> None:
    """Replace what an Html component made by `add_html` shows."""
    _check(content)
    handle.content = str(content)


def _check(content: Markup) -> None:
    # mypy holds every caller to Markup; this holds the untyped ones (Any) to it too.
    if not isinstance(content, Markup):
        raise TypeError(f"console HTML must be markupsafe.Markup, got {type(content).__name__}")
