"""What every request's tab has, so the panel treats them alike: its Send button, its check line,
the inputs its request is made from, its number fields by the API's name for them (where the
robot's refusals are said), and how its request is made."""

from typing import Any

import viser

from web.typed_number import TypedNumber, TypedVector

Typed = TypedNumber | TypedVector


class RequestTab:
    behavior: str  # the request's `type`
    send: viser.GuiButtonHandle
    check_line: viser.GuiHtmlHandle
    inputs: list[Any]  # every input the request is made from (a change rechecks it)
    typed: dict[str, Typed]  # its number fields, by the API's name

    def params(self) -> dict[str, Any]:
        """The request as the fields show it, in SI; FieldError while a field is not a number."""
        raise NotImplementedError

    def in_use(self) -> dict[str, Typed]:
        """The number fields the request is made from now."""
        return self.typed


def set_value(handle: Any, value: Any) -> None:
    """Assign a GUI input's value (a per-client handle: only this browser sees it)."""
    handle.value = value
