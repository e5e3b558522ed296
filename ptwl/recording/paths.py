"""Where a recording may go: checked before anything starts, so a bad path costs no session."""

from pathlib import Path

from ptwl_config import PtwlError


class RecordPathError(PtwlError, ValueError):
    pass


def check_record_path(path: Path) -> None:
    if path.suffix != ".mcap":
        raise RecordPathError(f"--record: the file must end in .mcap, got {str(path)!r}")
    if path.exists():
        raise RecordPathError(
            f"--record: {str(path)!r} exists; recordings are never overwritten, choose another name"
        )
    if not path.parent.is_dir():
        raise RecordPathError(f"--record: no directory {str(path.parent)!r} to write into")
