"""MJCF models of the court and the players."""

from importlib.resources import files
from pathlib import Path


def asset_path(name: str) -> Path:
    """Path of an MJCF file shipped in the package, e.g. ``asset_path("court.xml")``."""
    path = Path(str(files(__package__) / name))
    if not path.is_file():
        raise FileNotFoundError(f"no asset {name!r} in {path.parent}")
    return path


def load_shot_bank():  # -> numpy.ndarray (n, 6)
    """(n, 6) recorded rally shots (position, velocity; world frame, flying toward player 0),
    from ``benchmarks/make_shot_bank.py``; a plain .npy read without pickle."""
    import numpy as np

    return np.load(asset_path("data/rally_shots.npy"), allow_pickle=False)
