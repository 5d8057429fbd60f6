"""MJCF models of the court and the players."""

from importlib.resources import files
from pathlib import Path


def asset_path(name: str) -> Path:
    """Path of an MJCF file shipped in the package, e.g. ``asset_path("court.xml")``."""
    path = Path(str(files(__package__) / name))
    if not path.is_file():
        raise FileNotFoundError(f"no asset {name!r} in {path.parent}")
    return path
