"""Keep numba's on-disk cache honest across modules, find it, and say when it is cold.

numba keys a cached function on its own source file only. A module whose compiled functions call the kernel
(``triplanar/kernel.py``) keeps the kernel's code and its ``P_*``/``S_*`` layout built in, so after the kernel
changes numba would go on serving the old machine code. Each such module calls :func:`drop_if_stale` at import,
before anything of it is compiled, naming the files it depends on and the directory :func:`numba_cache_dir`
finds for it.

Where numba caches (:func:`numba_cache_dir`): ``NUMBA_CACHE_DIR`` if set; else ``__pycache__`` next to the source
if it is writable (a source tree, an editable install); else a user-wide directory (``~/.cache/numba/...``, or
under ``XDG_CACHE_HOME``), which is what a read-only site-packages gets. The stale-cache check follows it there.

A cold cache means compiling, tens of seconds in silence: :func:`announce_compilation` (called when
``triplanar`` is imported) prints one line on stderr before numba compiles the first of this project's
functions that it could not load from its cache (``make install`` compiles them all ahead:
``python -m triplanar.warmup``).
"""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path
from typing import Iterable

PACKAGES = ("triplanar", "envs", "agents", "experiments")  # whose compiled functions the notice is about
COMPILE_SECONDS = 60  # simulate, env and vector env from an empty cache, one core: ~50 s of CPU (docs/performance.md)
NOTICE = (f"triplanar: compiling the physics kernels, once (up to about {COMPILE_SECONDS} s; later runs load them "
          "from numba's cache, and `make install` or `python -m triplanar.warmup` compiles them ahead)...")


def numba_cache_dir(source: str | Path) -> Path | None:
    """The directory where numba caches the compiled functions defined in ``source`` (``cache=True``), chosen as
    numba chooses it (creating it, as numba does); None if numba can cache them nowhere."""
    try:
        from numba.core.caching import FunctionCache
    except ImportError:  # numba moved its internals: assume the usual place
        return Path(source).parent / "__pycache__"

    def probe() -> None:
        pass

    probe.__code__ = probe.__code__.replace(co_filename=str(source))
    try:
        return Path(FunctionCache(probe).cache_path)
    except RuntimeError:  # "no locator available": nowhere writable
        return None
    except Exception:  # numba changed its internals: assume the usual place
        return Path(source).parent / "__pycache__"


def drop_if_stale(cache: Path | None, pattern: str, sources: Iterable[Path], stamp_name: str) -> bool:
    """Delete the cache files ``cache/pattern`` unless ``sources`` are unchanged since the last call (their
    SHA-256 is kept in ``cache/stamp_name``). Returns True if it dropped them. ``cache`` None (numba caches
    nowhere) does nothing."""
    if cache is None:
        return False
    digest = hashlib.sha256()
    for source in sources:
        digest.update(Path(source).read_bytes())
    stamp = cache / stamp_name
    try:
        if stamp.exists() and stamp.read_text() == digest.hexdigest():
            return False
        for path in cache.glob(pattern):
            path.unlink(missing_ok=True)
        cache.mkdir(parents=True, exist_ok=True)
        stamp.write_text(digest.hexdigest())
    except OSError:  # not writable: numba then does not cache there either
        pass
    return True


_announcer = None


def announce_compilation() -> None:
    """From now on, the first time in this process that numba starts compiling one of this project's functions
    (its cache did not have it), say so on stderr (:data:`NOTICE`). Costs nothing when the cache is warm: numba
    signals only compilations."""
    global _announcer
    if _announcer is not None:
        return
    from numba.core import event, types

    class _Announcer(event.Listener):
        said = False

        def on_start(self, ev: event.Event) -> None:
            if self.said:
                return
            data = ev.data if isinstance(ev.data, dict) else {}
            func = getattr(data.get("dispatcher"), "py_func", None)
            module = getattr(func, "__module__", None) or ""
            # (an object-mode block, such as the kernel's call of user forces, is compiled in every process and
            # quickly: numba cannot cache it)
            object_mode = any(a in (types.ffi_forced_object, types.pyobject) for a in data.get("args", ()))
            if module.split(".")[0] in PACKAGES and not object_mode:
                self.said = True
                print(NOTICE, file=sys.stderr, flush=True)

        def on_end(self, ev: event.Event) -> None:
            pass

    _announcer = _Announcer()
    event.register("numba:compile", _announcer)
