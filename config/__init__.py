"""The installation's configuration files (TOML), and the one rule for where they are."""

import os
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import ValidationError

CONFIG_DIR_ENV = "PTWL_CONFIG_DIR"


class PtwlError(Exception):
    """The root of every error ptwl-console raises on purpose. Each package's errors subclass it
    (and a built-in kind where a caller relies on one, e.g. ValueError); the subclass's name says
    what went wrong. Defined here, in the lowest layer, so that every package can reach it."""


class ConfigError(PtwlError, ValueError):
    """A configuration that cannot work: a config file that does not validate, or a setting
    (a command-line option, an environment variable) that cannot be made safe. The message names
    the file and key or the option, and says what to do. The project's one ConfigError."""


def config_dir() -> Path:
    """config/ of this installation, or $PTWL_CONFIG_DIR (every reader of a config file asks here)."""
    override = os.environ.get(CONFIG_DIR_ENV)
    if override:
        return Path(override)
    return Path(str(resources.files("ptwl_config")))


def read_toml(path: Path) -> dict[str, Any]:
    """A config file's tables; ConfigError names the file when it cannot be read or parsed."""
    try:
        return tomllib.loads(path.read_text())
    except OSError as err:
        raise ConfigError(f"{path}: cannot read: {err}") from None
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{path}: not valid TOML: {err}") from None


def validation_problem(err: ValidationError) -> str:
    """A config table's first validation error as `key: message`."""
    first = err.errors()[0]
    where = ".".join(str(p) for p in first["loc"])
    message = str(first["msg"]).removeprefix("Value error, ")
    return f"{where}: {message}" if where else message
