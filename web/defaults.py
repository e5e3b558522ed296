"""Console defaults from config/console.toml (operator units: mm, deg)."""

import os
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class ConsoleDefaults:
    ptwl: dict[str, Any]
    rwe: dict[str, Any]
    dither_preset: str
    stiffness_preset: str
    wrench_arrow_m_per_n: float
    plot_s: float


def load_defaults() -> ConsoleDefaults:
    override = os.environ.get("PTWL_CONFIG_DIR")
    base = Path(override) if override else Path(str(resources.files("ptwl_config")))
    raw = tomllib.loads((base / "console.toml").read_text())
    return ConsoleDefaults(
        ptwl=raw["ptwl"],
        rwe=raw["rwe"],
        dither_preset=raw["dither"]["preset"],
        stiffness_preset=raw["stiffness"]["preset"],
        wrench_arrow_m_per_n=float(raw["view"]["wrench_arrow_m_per_n"]),
        plot_s=float(raw["view"]["telemetry_plot_s"]),
    )
