"""Console defaults from config/console.toml (operator units: mm, deg)."""

import tomllib
from dataclasses import dataclass
from typing import Any

from ptwl_config import config_dir


@dataclass(frozen=True)
class ConsoleDefaults:
    ptwl: dict[str, Any]
    rwe: dict[str, Any]
    dither_preset: str
    stiffness_preset: str
    wrench_arrow_m_per_n: float
    plot_s: float
    max_age_over_rtt_s: float
    twin: bool
    twin_min_rtt_s: float


def load_defaults() -> ConsoleDefaults:
    raw = tomllib.loads((config_dir() / "console.toml").read_text())
    return ConsoleDefaults(
        ptwl=raw["ptwl"],
        rwe=raw["rwe"],
        dither_preset=raw["dither"]["preset"],
        stiffness_preset=raw["stiffness"]["preset"],
        wrench_arrow_m_per_n=float(raw["view"]["wrench_arrow_m_per_n"]),
        plot_s=float(raw["view"]["telemetry_plot_s"]),
        max_age_over_rtt_s=float(raw["commands"]["max_age_over_rtt_s"]),
        twin=bool(raw["twin"]["enabled"]),
        twin_min_rtt_s=float(raw["twin"]["min_round_trip_s"]),
    )
