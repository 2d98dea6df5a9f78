"""The project's one way to write an output file: complete or not at all.

Every command and long run writes its files through :func:`write_atomic`: the content goes to a temporary file in
the same folder (same file system, so the rename is atomic), which then replaces the target. A run killed while
writing leaves the previous file (or none) and no temporary behind, except after a hard kill (SIGKILL, power loss):
its temporary carries the writer's process id, so :func:`remove_stale_temporaries` can tell it from a live writer's
file and remove it (the measurement and lab-data writers do so before they write).
"""

from __future__ import annotations

import os
import secrets
from pathlib import Path
from typing import Any, Callable

HEX = "0123456789abcdef"
MARK = ".partial"  # between the writer's id and the target's suffix: ``.NAME.PID.TOKEN.partial.SUFFIX``


def temporary_path(path: str | os.PathLike[str], pid: int | None = None) -> Path:
    """A temporary name for ``path``, beside it: hidden, unique to the writing process (``pid``, default this one)
    and to the call (a random token), and with ``path``'s suffix kept last (writers such as matplotlib's ``savefig``
    read the format from it; stable-baselines3's ``save`` adds its suffix when it is missing)."""
    path = Path(path)
    writer = os.getpid() if pid is None else int(pid)
    return path.with_name(f".{path.stem}.{writer}.{secrets.token_hex(6)}{MARK}{path.suffix}")


def write_atomic(path: str | os.PathLike[str], write: Callable[[Path], Any]) -> None:
    """``write(tmp)`` to a :func:`temporary_path`, then rename it over ``path``: the file at ``path`` is complete,
    or unchanged if ``write`` raised (the temporary is removed either way)."""
    path = Path(path)
    tmp = temporary_path(path)
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def _writer_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return True  # another user's process, or not a process id we can ask about: leave its file alone
    return True


def remove_stale_temporaries(path: str | os.PathLike[str]) -> None:
    """Remove the temporaries of ``path`` (:func:`temporary_path`) whose writer has died: what a hard kill leaves.
    A temporary of a process still running (this one included) is left alone."""
    path = Path(path)
    prefix, ending = f".{path.stem}.", f"{MARK}{path.suffix}"
    try:
        entries = os.listdir(path.parent)
    except OSError:
        return
    for entry in entries:
        if not (entry.startswith(prefix) and entry.endswith(ending)):
            continue
        parts = entry[len(prefix):-len(ending)].split(".")
        ours = len(parts) == 2 and parts[0].isdigit() and len(parts[1]) == 12 and set(parts[1]) <= set(HEX)
        if ours and not _writer_alive(int(parts[0])):
            try:
                os.unlink(path.parent / entry)
            except OSError:
                pass
