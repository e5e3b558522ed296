"""The installation's configuration files (TOML), and the one rule for where they are."""

import os
from importlib import resources
from pathlib import Path

CONFIG_DIR_ENV = "PTWL_CONFIG_DIR"


def config_dir() -> Path:
    """config/ of this installation, or $PTWL_CONFIG_DIR (every reader of a config file asks here)."""
    override = os.environ.get(CONFIG_DIR_ENV)
    if override:
        return Path(override)
    return Path(str(resources.files("ptwl_config")))
