"""Named link profiles from config/links.toml, validated at load."""

import tomllib
from functools import cache
from pathlib import Path

from ptwl_config import PtwlError, config_dir
from pydantic import ValidationError

from latency.profile import LinkProfile


class LinkConfigError(PtwlError, ValueError):
    """A links file that does not validate, or an unknown profile name."""


def links_file() -> Path:
    return config_dir() / "links.toml"


def load_profiles(path: Path) -> dict[str, LinkProfile]:
    try:
        raw = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise LinkConfigError(f"{path}: {err}") from None
    profiles = {}
    for name, table in raw.items():
        try:
            profiles[name] = LinkProfile.model_validate(table)
        except ValidationError as err:
            first = err.errors()[0]
            where = ".".join(str(p) for p in first["loc"])
            raise LinkConfigError(f"{path}: [{name}] {where}: {first['msg']}") from None
    return profiles


@cache
def named_profiles() -> dict[str, LinkProfile]:
    return load_profiles(links_file())


def named_profile(name: str) -> LinkProfile:
    profiles = named_profiles()
    if name not in profiles:
        raise LinkConfigError(f"unknown link profile {name!r}; valid: {', '.join(sorted(profiles))}")
    return profiles[name]
