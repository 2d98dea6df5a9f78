"""The project's one way to write an output file: complete or not at all.

Every command and long run writes its files through :func:`write_atomic`: the content goes to a temporary file in
the same folder (same file system, so the rename is atomic), which then replaces the target. A run killed while
writing leaves the previous file (or none) and no temporary behind, except after a hard kill, whose ``*.partial*``
leftovers the next run of the same writer may overwrite.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable


def temporary_path(path: str | os.PathLike[str]) -> Path:
    """The temporary name :func:`write_atomic` uses for ``path``: hidden, process-unique, and with ``path``'s suffix
    kept last (writers such as stable-baselines3's ``save`` add their suffix when it is missing)."""
    path = Path(path)
    return path.with_name(f".{path.stem}.{os.getpid()}.partial{path.suffix}")


def write_atomic(path: str | os.PathLike[str], write: Callable[[Path], Any], *,
                 tmp: str | os.PathLike[str] | None = None) -> None:
    """``write(tmp)`` then rename ``tmp`` over ``path``: the file at ``path`` is complete, or unchanged if ``write``
    raised (the temporary is removed either way). ``tmp`` defaults to :func:`temporary_path`."""
    path = Path(path)
    tmp_path = Path(tmp) if tmp is not None else temporary_path(path)
    try:
        write(tmp_path)
        os.replace(tmp_path, path)
    finally:
        tmp_path.unlink(missing_ok=True)
