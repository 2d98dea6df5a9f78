"""Keep numba's on-disk cache honest across modules.

numba keys a cached function on its own source file only. A module whose compiled functions call the kernel
(``triplanar/kernel.py``) keeps the kernel's code and its ``P_*``/``S_*`` layout built in, so after the kernel
changes numba would go on serving the old machine code. Each such module calls :func:`drop_if_stale` at import,
before anything of it is compiled, naming the files it depends on.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Iterable


def drop_if_stale(cache: Path, pattern: str, sources: Iterable[Path], stamp_name: str) -> bool:
    """Delete the cache files ``cache/pattern`` unless ``sources`` are unchanged since the last call (their
    SHA-256 is kept in ``cache/stamp_name``). Returns True if it dropped them."""
    digest = hashlib.sha256()
    for source in sources:
        digest.update(Path(source).read_bytes())
    stamp = cache / stamp_name
    try:
        if stamp.exists() and stamp.read_text() == digest.hexdigest():
            return False
        for path in cache.glob(pattern):
            path.unlink(missing_ok=True)
        cache.mkdir(exist_ok=True)
        stamp.write_text(digest.hexdigest())
    except OSError:  # read-only install: numba then does not cache there either
        pass
    return True
