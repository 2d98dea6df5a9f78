"""Where compile time goes: ``PYTHONPATH=. python benchmarks/compile_profile.py [--top 25]``.

Runs, in one process with a fresh temporary ``NUMBA_CACHE_DIR``, what ``benchmarks/bench_compile.py`` runs from an
empty cache (the first ``simulate``, the first single-env step, the first vector-env step) and records numba's
``numba:compile`` events. Prints, per compiled function, the number of versions (signatures) compiled and the CPU
seconds spent compiling them, exclusive of the functions compiled inside (a caller's typing compiles its callees
first) and of writing the cache, which is timed apart (``Cache.save_overload``). Each version is a full compile of the
function and of all that it inlines; a function listed with more than one signature is a candidate duplicate (its
signatures are printed). The total is the process's CPU time of the work (imports excluded).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections import defaultdict


def _stages() -> None:
    """The three empty-cache stages of ``bench_compile.py``, in one process."""
    import gymnasium as gym
    import numpy as np

    import envs
    from triplanar import paper_model, simulate
    from triplanar.outcome import Outcome

    assert simulate(paper_model("A", 30.0)).status is Outcome.TRAVEL
    with envs.v0_on_purpose():
        env = gym.make("TriPlanarShear-v0")
        vec = gym.make_vec("TriPlanarShear-v0", num_envs=4)
    env.reset(seed=0)
    env.step(np.zeros(2, np.float32))
    vec.reset(seed=0)
    vec.step(np.zeros((4, 2), np.float32))


def profile() -> tuple[dict, dict, dict, float]:
    """Compile everything the stages need; per function: exclusive compile CPU, cache-writing CPU, signatures."""
    from numba.core import caching, event

    compile_s: dict[str, float] = defaultdict(float)
    save_s: dict[str, float] = defaultdict(float)
    signatures: dict[str, list] = defaultdict(list)
    stack: list[list] = []  # [name, start, time of what ran inside]

    class _Timer(event.Listener):
        def on_start(self, ev: event.Event) -> None:
            disp = ev.data["dispatcher"]
            name = f"{disp.py_func.__module__}.{disp.py_func.__qualname__}"
            signatures[name].append(ev.data["args"])
            stack.append([name, time.process_time(), 0.0])

        def on_end(self, ev: event.Event) -> None:
            name, start, inner = stack.pop()
            spent = time.process_time() - start
            compile_s[name] += spent - inner
            if stack:
                stack[-1][2] += spent

    original_save = caching.Cache.save_overload

    def timed_save(self: caching.Cache, sig: object, data: object) -> None:  # (replaces Cache.save_overload)
        start = time.process_time()
        try:
            return original_save(self, sig, data)
        finally:
            spent = time.process_time() - start
            fn = self._py_func
            save_s[f"{fn.__module__}.{fn.__qualname__}"] += spent
            if stack:
                stack[-1][2] += spent

    caching.Cache.save_overload = timed_save
    event.register("numba:compile", _Timer())
    start = time.process_time()
    _stages()
    return compile_s, save_s, signatures, time.process_time() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--top", type=int, default=25, help="functions to list, most expensive first")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache_dir:
        os.environ["NUMBA_CACHE_DIR"] = cache_dir  # before numba reads its configuration
        compile_s, save_s, signatures, total = profile()
    names = sorted(signatures, key=lambda n: -(compile_s[n] + save_s[n]))
    print(f"{'function':<58} {'versions':>8} {'compile s':>9} {'cache s':>8}")
    for name in names[:args.top]:
        print(f"{name:<58} {len(signatures[name]):>8} {compile_s[name]:>9.2f} {save_s[name]:>8.2f}")
    print(f"{len(names)} functions, {sum(len(s) for s in signatures.values())} versions: compile "
          f"{sum(compile_s.values()):.2f} s, cache writing {sum(save_s.values()):.2f} s, "
          f"work in all {total:.2f} s CPU")
    for name in names:
        if len(signatures[name]) > 1:
            print(f"{name}:")
            for sig in signatures[name]:
                print("    (" + ", ".join(str(a) for a in sig) + ")")


if __name__ == "__main__":
    main()
