"""The one error type of the world loader."""

from __future__ import annotations

from pathlib import Path


class WorldError(ValueError):
    """A world file is malformed: says which file, which key, what was expected and found."""

    def __init__(self, file: Path | str, key: str, expected: str, found: object) -> None:
        self.file = Path(file)
        self.key = key
        self.expected = expected
        self.found = found
        super().__init__(f"{self.file}: {key or '<top>'}: expected {expected}, found {found!r}")
