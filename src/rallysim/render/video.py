"""Writing rendered frames: MP4 or GIF videos, and PNG strips of stills (the paper's Fig. 7).

MP4 goes through imageio-ffmpeg, whose wheel ships its own ffmpeg binary, so no system ffmpeg
is needed; GIF and PNG go through Pillow.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from PIL import Image

Frames = Sequence[np.ndarray] | np.ndarray


def _check(frames: Frames) -> list[np.ndarray]:
    out = [np.asarray(f) for f in frames]
    if not out:
        raise ValueError("no frames to write")
    shape = out[0].shape
    for f in out:
        if f.dtype != np.uint8 or f.ndim != 3 or f.shape[2] != 3:
            raise ValueError(f"frames must be (H, W, 3) uint8, got {f.shape} {f.dtype}")
        if f.shape != shape:
            raise ValueError(f"all frames must have one shape, got {shape} and {f.shape}")
    return out


def write_video(frames: Frames, path: str | Path, fps: float = 10) -> Path:
    """Write ``frames`` ((H, W, 3) uint8 each) as ``.mp4`` (H.264) or ``.gif``, by suffix.

    GIF stores times in hundredths of a second, and Pillow merges identical consecutive frames
    into one longer frame: the timing is kept, the frame count may drop."""
    path = Path(path)
    images = _check(frames)
    suffix = path.suffix.lower()
    if suffix == ".mp4":
        _write_mp4(images, path, fps)
    elif suffix == ".gif":
        _write_gif(images, path, fps)
    else:
        raise ValueError(f"unknown video format {suffix!r}; valid: '.mp4', '.gif'")
    return path


def _write_mp4(images: list[np.ndarray], path: Path, fps: float) -> None:
    import imageio.v2 as imageio  # only MP4 needs ffmpeg's plugin

    # yuv420p (what players expect) halves the chroma resolution: sides must be even.
    h, w = images[0].shape[:2]
    pad = ((0, h % 2), (0, w % 2), (0, 0))
    with imageio.get_writer(path, format="FFMPEG", mode="I", fps=fps, codec="libx264",
                            pixelformat="yuv420p", macro_block_size=1,
                            ffmpeg_log_level="error", quality=8) as writer:
        for image in images:
            writer.append_data(np.pad(image, pad, mode="edge") if any(pad[0] + pad[1])
                               else image)


def _write_gif(images: list[np.ndarray], path: Path, fps: float) -> None:
    first, *rest = (Image.fromarray(image) for image in images)
    first.save(path, save_all=True, append_images=rest, duration=round(1000.0 / fps), loop=0,
               optimize=False)


def write_strip(frames: Frames, path: str | Path, columns: int | None = None,
                gap: int = 4) -> np.ndarray:
    """Tile ``frames`` in reading order into one PNG image, ``columns`` wide (default: all in
    one row), ``gap`` white pixels between them; returns the tiled image."""
    images = _check(frames)
    n = len(images)
    columns = n if columns is None else columns
    if columns < 1:
        raise ValueError(f"columns must be >= 1, got {columns}")
    rows = -(-n // columns)
    h, w = images[0].shape[:2]
    sheet = np.full((rows * h + (rows - 1) * gap, columns * w + (columns - 1) * gap, 3), 255,
                    np.uint8)
    for k, image in enumerate(images):
        r, c = divmod(k, columns)
        sheet[r * (h + gap):r * (h + gap) + h, c * (w + gap):c * (w + gap) + w] = image
    Image.fromarray(sheet).save(Path(path), format="PNG")
    return sheet
