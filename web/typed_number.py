"""Number fields that keep what was typed (issue 27).

viser's number inputs (Mantine's NumberInput) rewrite what is typed: they drop letters ("1e9"
became 19, "0x10" 10) and clamp to their min/max ("-5" s became 0.01 s), so the server used a
number the operator never saw and the field could go blank while the console went on with the
last value. Here a number is a text input holding exactly the text typed; the console reads it by
one strict rule (a decimal as a person writes it, with an optional exponent) and refuses anything
else with the reason shown under the field. The ranges are not the console's: the robot's own
models judge the value (web/checks.py) and their words come back to the field, in its units.
"""

import math
import re
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import viser
from ptwl_config import PtwlError

from web.markup import Markup, add_html, show

# Digits with an optional point and exponent, and nothing else. float() alone would also take
# "nan", "inf", "infinity" and "1_0"; a letter-stripping or hex-reading parser would invent a value.
DECIMAL = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?")
_NON_DECIMAL_PREFIX = re.compile(r"[+-]?0[xob]", re.IGNORECASE)
_NOT_FINITE_WORDS = {"nan", "inf", "infinity"}

EMPTY = "empty: type a number"
NOT_FINITE = "must be a finite number"
UNDERSCORE = "no underscores: type the digits alone"
NOT_DECIMAL = "not a decimal number (0x, 0o and 0b are refused)"
COMMA = "use a point for decimals (2.5), and no thousands separators"
NOT_A_NUMBER = "not a number (write e.g. 12.5 or 2.5e1)"
AXES = ("x", "y", "z")


class FieldError(PtwlError, ValueError):
    """A field's text is not a number the console will use; `reason` says why, for the operator."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def parse_number(text: str) -> float:
    """The number `text` means, read as a person writes it ("2.5e1" is 25); FieldError otherwise."""
    typed = text.strip()
    if DECIMAL.fullmatch(typed):
        value = float(typed)
        if math.isfinite(value):
            return value
        raise FieldError(NOT_FINITE)  # "1e999": past any float
    raise FieldError(_why_not(typed))


def _why_not(typed: str) -> str:
    if not typed:
        return EMPTY
    if typed.lower().lstrip("+-") in _NOT_FINITE_WORDS:
        return NOT_FINITE
    if "_" in typed:
        return UNDERSCORE
    if _NON_DECIMAL_PREFIX.match(typed):
        return NOT_DECIMAL
    if "," in typed:
        return COMMA
    return NOT_A_NUMBER


def parse_vector(texts: Sequence[str]) -> tuple[float, ...]:
    """x, y, z as typed; FieldError naming the first component that is not a number."""
    if len(texts) != len(AXES):
        raise FieldError(f"needs {len(AXES)} components (x, y, z), got {len(texts)}")
    values = []
    for axis, text in zip(AXES, texts, strict=True):
        try:
            values.append(parse_number(text))
        except FieldError as err:
            raise FieldError(f"{axis}: {err.reason}") from None
    return tuple(values)


def format_number(value: float, decimals: int = 3) -> str:
    """A number as the console writes it into a field: rounded, no trailing zeros, no "-0"."""
    rounded = round(float(value), decimals) + 0.0  # -0.0 + 0.0 is 0.0
    return f"{rounded:.{decimals}f}".rstrip("0").rstrip(".")


@dataclass(frozen=True)
class Unit:
    """A field's unit, and how the API's rules name the SI unit it stands for."""

    name: str  # as the field shows it: "mm"
    si: tuple[str, ...] = ()  # as the API's messages say it ("m"; longest first)
    per_si: float = 1.0  # field units in one SI unit: 1000 mm in a metre

    def to_si(self, value: float) -> float:
        return value / self.per_si


MM = Unit("mm", ("m",), 1000.0)
DEG = Unit("deg", ("rad",), 180.0 / math.pi)
SECONDS = Unit("s", ("s",))
NEWTONS = Unit("N", ("N",))
NEWTON_METRES = Unit("N m", ("N m",))
HERTZ = Unit("Hz", ("Hz",))
PERCENT = Unit("%")
PLAIN = Unit("")  # a direction: any length

_NUMBER_IN_TEXT = r"-?(?:\d+(?:\.\d*)?|\.\d+)(?:e[+-]?\d+)?"
_NUMBER_WORD = re.compile(rf"(?<![\w.]){_NUMBER_IN_TEXT}(?![\w.])")
_GOT_AT_END = re.compile(rf"(got {_NUMBER_IN_TEXT})$")


def in_field_units(message: str, unit: Unit) -> str:
    """The robot's rule, as its model says it in SI ("magnitude must be <= 1 m, got 5"), in the
    field's units ("magnitude must be <= 1000 mm, got 5000 mm"): the limit stays the robot's."""
    said = _NUMBER_WORD.sub(lambda m: f"{float(m[0]) * unit.per_si:.6g}", message)
    for si in unit.si:
        if si != unit.name:
            said = re.sub(rf"(?<=[\d\])]) {re.escape(si)}(?![\w/])", f" {unit.name}", said)
    return _GOT_AT_END.sub(rf"\1 {unit.name}", said) if unit.name else said


class _Typed:
    """What a scalar and a vector field share: their text inputs, the reason line under them,
    and the robot's refusal of the text it was given for (a new text is judged anew)."""

    def __init__(self, gui: viser.GuiApi, key: str, unit: Unit, inputs: list[viser.GuiTextHandle]) -> None:
        self.key = key
        self.unit = unit
        self.inputs = inputs
        self.reason_line = add_html(gui, reason_html(key, ""))
        self.reason_line.visible = False
        self._shown = ""
        self._refusal: tuple[tuple[str, ...], str] | None = None
        self._callbacks: list[Callable[[Any], None]] = []
        self._writing_thread: int | None = None  # the thread writing the texts, heard once after
        for handle in inputs:
            handle.on_update(self._changed)

    @property
    def texts(self) -> tuple[str, ...]:
        return tuple(str(handle.value) for handle in self.inputs)

    def _parsed(self) -> Any:
        """In the field's units, exactly as typed; FieldError if the text is not a number."""
        raise NotImplementedError

    def _write(self, texts: Sequence[str]) -> None:
        """Put `texts` in the inputs; the field's listeners hear of it once, if anything changed."""
        before = self.texts
        self._writing_thread = threading.get_ident()  # viser calls back on the assigning thread
        try:
            for handle, text in zip(self.inputs, texts, strict=True):
                _assign(handle, text)
        finally:
            self._writing_thread = None
        if self.texts != before:
            self._changed(None)

    def on_update(self, callback: Callable[[Any], None]) -> None:
        self._callbacks.append(callback)

    def _changed(self, event: Any) -> None:
        # Typing (viser's thread pool) is always heard; a write, once for all its components.
        if event is None or self._writing_thread != threading.get_ident():
            for callback in self._callbacks:
                callback(event)

    @property
    def disabled(self) -> bool:
        return bool(self.inputs[0].disabled)

    @disabled.setter
    def disabled(self, disabled: bool) -> None:
        for handle in self.inputs:
            handle.disabled = disabled

    def parse_reason(self) -> str:
        try:
            self._parsed()
        except FieldError as err:
            return err.reason
        return ""

    @property
    def reason(self) -> str:
        """Why this field cannot be sent as typed ("" if it can, as far as the last check said)."""
        said = self.parse_reason()
        if said or self._refusal is None:
            return said
        texts, refusal = self._refusal
        return refusal if texts == self.texts else ""

    def refuse(self, message_si: str) -> str:
        """The robot's rules refuse the text as typed now (`message_si`: in the API's words);
        what the field says of it, in its units. Refusals add up until `clear()`."""
        said = in_field_units(message_si, self.unit)
        texts = self.texts
        if self._refusal is not None and self._refusal[0] == texts:
            self._refusal = (texts, f"{self._refusal[1]}; {said}")
        else:
            self._refusal = (texts, said)
        return said

    def clear(self) -> None:
        self._refusal = None

    def show(self, active: bool = True) -> None:
        """The reason under the field, hidden while there is none (or the field is not in use)."""
        reason = self.reason if active else ""
        if reason != self._shown:
            self._shown = reason
            show(self.reason_line, reason_html(self.key, reason))
            self.reason_line.visible = bool(reason)


class TypedNumber(_Typed):
    """One number, typed into one text input labelled as viser's number input was."""

    def __init__(
        self,
        gui: viser.GuiApi,
        key: str,
        label: str,
        value: float,
        unit: Unit,
        hint: str | None = None,
        disabled: bool = False,
        decimals: int = 3,
    ) -> None:
        self._decimals = decimals
        text = gui.add_text(label, format_number(value, decimals), hint=hint, disabled=disabled)
        super().__init__(gui, key, unit, [text])

    def _parsed(self) -> float:
        return parse_number(self.texts[0])

    @property
    def value(self) -> float:
        return self._parsed()

    @value.setter
    def value(self, value: float) -> None:
        self._write([format_number(value, self._decimals)])

    @property
    def si(self) -> float:
        """As the API takes it: the typed number times the unit's scale."""
        return self.unit.to_si(self._parsed())

    @property
    def label(self) -> str:
        return str(self.inputs[0].label)

    def relabel(self, label: str, unit: Unit) -> None:
        """A field whose meaning changes (dither amplitude: deg or mm with the mode)."""
        self.inputs[0].label = label
        self.unit = unit
        self.clear()


class TypedVector(_Typed):
    """x, y, z typed into three text inputs under one folder named as the vector is."""

    def __init__(
        self,
        gui: viser.GuiApi,
        key: str,
        label: str,
        value: Sequence[float],
        unit: Unit,
        hint: str | None = None,
        decimals: int = 3,
    ) -> None:
        self._decimals = decimals
        self.label = label
        with gui.add_folder(label):
            inputs = [
                gui.add_text(axis, format_number(v, decimals), hint=hint)
                for axis, v in zip(AXES, value, strict=True)
            ]
            super().__init__(gui, key, unit, inputs)

    def _parsed(self) -> tuple[float, ...]:
        return parse_vector(self.texts)

    @property
    def value(self) -> tuple[float, ...]:
        return self._parsed()

    @value.setter
    def value(self, value: Sequence[float]) -> None:
        numbers = [float(v) for v in value]
        if len(numbers) != len(AXES):
            raise ValueError(f"a vector field takes {len(AXES)} components, got {len(numbers)}")
        self._write([format_number(v, self._decimals) for v in numbers])

    @property
    def si(self) -> list[float]:
        return [self.unit.to_si(v) for v in self._parsed()]


def _assign(handle: Any, text: str) -> None:
    """Set a text input (viser's stubs type `value` read-only; assigning is how it is set, and
    viser skips a text that did not change)."""
    handle.value = text


def reason_html(key: str, reason: str) -> Markup:
    """The line under a field saying why it cannot be sent (empty while it can)."""
    return Markup(
        '<div id="field-reason-{}" class="ptwl-field-reason" data-reason="{}" '
        'style="color:#e03131;font-size:0.8em;line-height:1.3;padding:0 12px 6px 12px">{}</div>'
    ).format(key, reason, reason)
