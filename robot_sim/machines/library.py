"""Machine files: reading one (TOML) and the built-in machines shipped with the robot
(robot_sim/machines/builtin/*.toml, one per task it could express)."""

import tomllib
from functools import cache
from pathlib import Path

from pydantic import ValidationError

from robot_sim.errors import ConfigError
from robot_sim.machines.spec import MachineSpec

BUILTIN_DIR = Path(__file__).parent / "builtin"
MAX_FILE_BYTES = 256_000  # a machine's file: 64 states fit in a fraction of this


def read_machine(path: Path) -> MachineSpec:
    """The machine in a TOML file, validated (ConfigError naming the file, state and field)."""
    size = path.stat().st_size
    if size > MAX_FILE_BYTES:
        raise ConfigError(f"{path}: {size} bytes; a machine file is at most {MAX_FILE_BYTES}")
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise ConfigError(f"{path}: not TOML: {err}") from None
    try:
        return MachineSpec.model_validate(raw)
    except ValidationError as err:
        said = "; ".join(
            f"{'.'.join(map(str, e['loc'])) or 'machine'}: {e['msg'].removeprefix('Value error, ')}"
            for e in err.errors()
        )
        raise ConfigError(f"{path}: {said}") from None


@cache
def builtin_machines() -> dict[str, MachineSpec]:
    """The built-in machines by task."""
    found = [read_machine(p) for p in sorted(BUILTIN_DIR.glob("*.toml"))]
    return {spec.task or spec.name: spec for spec in found}
