"""An output folder written by one run at a time, and a set of result files in it replaced as a whole.

:func:`output_lock` takes an exclusive lock beside the folder (``.NAME.lock`` in its parent, ``flock``: released
when the process ends, however it ends), so that a second run into the same folder is refused instead of mixing its
files with the first's. :func:`replace_set` writes a result set (``evaluate``'s CSV, episodes CSV, JSON and plot)
into a new folder beside the old one, holding links to the old folder's other files, then exchanges the two in one
step (Linux ``renameat2(RENAME_EXCHANGE)``; elsewhere two renames): a kill leaves the previous set or the new one,
never a mixture. A killed run's new folder (``.NAME.PID.TOKEN.partial``) is removed by the next run
(:func:`remove_stale_sets`). :func:`triplanar.atomic.write_atomic` cannot express this: it replaces one file.
"""

from __future__ import annotations

import ctypes
import os
import secrets
import shutil
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator, Sequence

from .atomic import MARK, _writer_alive

_AT_FDCWD = -100
_RENAME_EXCHANGE = 2


def check_folder(out: str | os.PathLike[str], option: str = "--out") -> Path:
    """``out`` as an output folder, checked before any work: not an existing file, its parent a folder."""
    path = Path(out).resolve()
    if path.exists() and not path.is_dir():
        raise ValueError(f"{option} {out}: exists and is not a folder")
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise ValueError(f"{option} {out}: {parent} is not a folder")
            if not os.access(parent, os.W_OK | os.X_OK):
                raise ValueError(f"{option} {out}: cannot write in {parent}")
            break
    return path


@contextmanager
def output_lock(out: str | os.PathLike[str], option: str = "--out") -> Iterator[Path]:
    """Hold ``out`` for this run (its parent is created; ``out`` itself is left to the writers); ValueError if
    another run holds it."""
    import fcntl
    path = check_folder(out, option)
    path.parent.mkdir(parents=True, exist_ok=True)
    lock = path.parent / f".{path.name}.lock"
    while True:
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise ValueError(f"{option} {out}: another run is writing there (it holds {lock}); wait for it to "
                             "finish or give another folder") from None
        try:
            same = os.stat(lock).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)   # the holder removed it as we opened it: take the new one
    try:
        yield path
    finally:
        try:
            os.unlink(lock)
        finally:
            os.close(fd)


def _partial_name(out: Path, pid: int | None = None) -> Path:
    return out.with_name(f".{out.name}.{os.getpid() if pid is None else pid}.{secrets.token_hex(6)}{MARK}")


def remove_stale_sets(out: str | os.PathLike[str]) -> None:
    """Remove what a killed :func:`replace_set` left beside ``out`` (its writer dead), and the killed single-file
    writes' temporaries inside it."""
    out = Path(out)
    prefix = f".{out.name}."
    if out.parent.is_dir():
        for entry in out.parent.iterdir():
            parts = entry.name[len(prefix):].split(".") if entry.name.startswith(prefix) else []
            if (entry.name.endswith(MARK) and len(parts) == 3 and parts[0].isdigit()
                    and not _writer_alive(int(parts[0]))):
                shutil.rmtree(entry, ignore_errors=True)
    if out.is_dir():
        for entry in out.iterdir():
            parts = entry.name.split(".")
            if (entry.name.startswith(".") and MARK in entry.name and len(parts) >= 5 and parts[-4].isdigit()
                    and not _writer_alive(int(parts[-4]))):
                entry.unlink(missing_ok=True)


def _exchange(a: Path, b: Path) -> bool:
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        done = libc.renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0
    except (AttributeError, OSError):
        return False
    return done


def replace_set(out: str | os.PathLike[str], names: Sequence[str], write: Callable[[Path], None]) -> list[Path]:
    """Write the files ``names`` (``write(folder)`` writes them into ``folder``) so that ``out`` holds all of the new
    ones, or all of the previous ones if the run is killed; ``out``'s other files are kept. Returns their paths."""
    out = Path(out).resolve()
    out.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_sets(out)
    new = _partial_name(out)
    try:
        new.mkdir()
        if out.is_dir():
            for entry in out.iterdir():
                if entry.name in names or (entry.name.startswith(".") and MARK in entry.name):
                    continue
                if entry.is_dir() and not entry.is_symlink():
                    shutil.copytree(entry, new / entry.name, symlinks=True, copy_function=_link_or_copy)
                else:
                    _link_or_copy(entry, new / entry.name)
        write(new)
        missing = [n for n in names if not (new / n).exists()]
        if missing:
            raise RuntimeError(f"the result set is missing {', '.join(missing)}")
        if out.is_dir() and _exchange(new, out):
            shutil.rmtree(new, ignore_errors=True)     # now the previous set
        else:
            if out.is_dir():
                old = _partial_name(out)
                os.rename(out, old)
                os.rename(new, out)
                shutil.rmtree(old, ignore_errors=True)
            else:
                os.rename(new, out)
    finally:
        if new.exists():
            shutil.rmtree(new, ignore_errors=True)
    return [out / n for n in names]


def _link_or_copy(source: str | os.PathLike[str], target: str | os.PathLike[str]) -> None:
    try:
        os.link(source, target, follow_symlinks=False)
    except OSError:
        shutil.copy2(source, target, follow_symlinks=False)
