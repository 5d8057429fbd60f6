"""Named slices of flat vectors (observations, actions), declared once per layout."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Layout:
    """A flat vector as named consecutive slices: ``layout["shuttle_position"]`` is a
    ``slice``; controllers decode observations by these names, not by literal indices."""

    parts: tuple[tuple[str, int], ...]
    _slices: dict[str, slice] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        slices, start = {}, 0
        for name, size in self.parts:
            if name in slices:
                raise ValueError(f"layout part {name!r} appears twice")
            slices[name] = slice(start, start + size)
            start += size
        object.__setattr__(self, "_slices", slices)

    def __getitem__(self, name: str) -> slice:
        try:
            return self._slices[name]
        except KeyError:
            raise KeyError(f"no part {name!r}; parts: {', '.join(self._slices)}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._slices)

    @property
    def size(self) -> int:
        return sum(size for _, size in self.parts)

    def extended(self, *parts: tuple[str, int]) -> Layout:
        """This layout followed by ``parts``."""
        return Layout((*self.parts, *parts))
