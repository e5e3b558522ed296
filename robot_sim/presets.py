"""Stiffness/damping and dither presets from config/presets.toml, validated at load.

The file is parsed into the same pydantic models the API uses (GainsSpec, DitherParams), so a
preset that loads is a preset the API accepts. A bad file raises ConfigError naming the file,
the key and the problem.
"""

from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

from ptwl_config import config_dir, read_toml, validation_problem
from pydantic import ValidationError

from robot_sim.errors import ConfigError, UnknownNameError
from robot_sim.params import NAMED, DitherParams, GainsSpec


@dataclass(frozen=True)
class Presets:
    stiffness: dict[str, GainsSpec]
    stiffness_descriptions: dict[str, str]
    dither: dict[str, DitherParams]
    default_stiffness: str

    def stiffness_preset(self, name: str) -> GainsSpec:
        try:
            return self.stiffness[name]
        except KeyError:
            raise UnknownNameError("stiffness preset", name, list(self.stiffness)) from None

    def dither_preset(self, name: str) -> dict[str, Any]:
        """The preset's fields (without `preset` and `type`), for merging into a request."""
        try:
            params = self.dither[name]
        except KeyError:
            raise UnknownNameError("dither preset", name, list(self.dither)) from None
        return params.model_dump(exclude={"preset", "type", "watchdog", "progress"})


def load_presets(path: Path) -> Presets:
    raw = read_toml(path)
    for section in ("stiffness", "dither"):
        if not isinstance(raw.get(section), dict) or not raw[section]:
            raise ConfigError(f"{path}: [{section}] is missing or empty")
    stiffness: dict[str, GainsSpec] = {}
    descriptions: dict[str, str] = {}
    for name, table in raw["stiffness"].items():
        body = dict(table)
        descriptions[name] = str(body.pop("description", ""))
        try:
            stiffness[name] = GainsSpec.model_validate(body)
        except ValidationError as err:
            raise ConfigError(f"{path}: [stiffness.{name}] {validation_problem(err)}") from None
    dither: dict[str, DitherParams] = {}
    for name, table in raw["dither"].items():
        if "preset" in table:
            raise ConfigError(f"{path}: [dither.{name}] preset: a preset cannot name another preset")
        try:
            dither[name] = DitherParams.model_validate(table)
        except ValidationError as err:
            raise ConfigError(f"{path}: [dither.{name}] {validation_problem(err)}") from None
    default = raw.get("default", {}).get("stiffness_preset", "medium")
    if default not in stiffness:
        raise ConfigError(
            f"{path}: [default].stiffness_preset: unknown preset {default!r}; "
            f"valid: {', '.join(sorted(stiffness))}"
        )
    return Presets(stiffness, descriptions, dither, default)


@cache
def default_presets() -> Presets:
    return load_presets(config_dir() / "presets.toml")


# The presets a request names are these (robot_sim/params.py resolves names through NAMED).
NAMED.stiffness_preset = lambda name: default_presets().stiffness_preset(name)
NAMED.dither_preset = lambda name: default_presets().dither_preset(name)
