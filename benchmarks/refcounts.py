"""Reference counts in the compiled hot path: ``PYTHONPATH=. python benchmarks/refcounts.py``.

Compiles, in a fresh temporary numba cache (numba shows no LLVM IR of cached code), a trace and an env step, then
counts the calls of ``NRT_incref`` and ``NRT_decref`` left in the optimised LLVM IR of ``kernel.dynamics_ws`` and
``stepping.integrate_ws`` (their own bodies, with whatever LLVM inlined into them), and lists the functions they still
call. Each reference count is an atomic increment or decrement; ``docs/performance.md`` relates them to speed.
"""

from __future__ import annotations

import os
import re
import tempfile


def _name(mangled: str) -> str:
    """``_ZN9triplanar6kernel12_solve_smallB3v38...`` -> ``triplanar.kernel._solve_small``."""
    if not mangled.startswith("_ZN"):
        return mangled
    parts, rest = [], mangled[3:]
    while (m := re.match(r"(\d+)", rest)):
        n = int(m.group(1))
        parts.append(rest[len(m.group(1)):len(m.group(1)) + n])
        rest = rest[len(m.group(1)) + n:]
    return ".".join(parts)


def _body(ir: str, name: str) -> str:
    match = re.search(r"\ndefine [^\n]*" + name + r"[^\n]*\{.*?\n\}", ir, re.S)
    return match.group(0) if match else ""


def main() -> None:
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache_dir:
        os.environ["NUMBA_CACHE_DIR"] = cache_dir
        import gymnasium as gym
        import numpy as np

        import envs  # noqa: F401  (registers the environment)
        from triplanar import kernel, paper_model, simulate, stepping

        simulate(paper_model("A", 30.0))
        env = gym.make("TriPlanarShear-v0")
        env.reset(seed=0)
        env.step(np.zeros(2, np.float32))
        for fn, name in ((kernel.dynamics_ws, "dynamics_ws"), (stepping.integrate_ws, "integrate_ws")):
            for sig in fn.signatures:
                body = _body(fn.inspect_llvm(sig), name)
                calls = sorted({_name(c) for c in re.findall(r"call [^@\n]*@([\w.$]+)", body)
                                if "NRT" not in c and not c.startswith("llvm.")})
                print(f"{name}: NRT_incref {body.count('@NRT_incref')}, NRT_decref {body.count('@NRT_decref')}, "
                      f"{body.count(chr(10))} lines of IR; calls {calls}")


if __name__ == "__main__":
    main()
