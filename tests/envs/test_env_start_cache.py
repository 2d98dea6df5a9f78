"""Starting states are kept where they are asked for, never in a module-global cache: ``episode_start`` without a
cache computes, with one it computes once; each env owns its cache."""

from __future__ import annotations

from agents.heldout import nominal_benches
from envs.core import StartCache, make_config
from envs.triplanar_shear_v1 import TriPlanarShearV1Env, bench_start, can_start


def test_a_start_is_kept_only_in_the_cache_it_was_given():
    config, bench = make_config(None), nominal_benches([40.0])[0]
    assert bench_start(config, bench) is not bench_start(config, bench)   # nothing kept behind the caller's back
    cache = StartCache()
    first = bench_start(config, bench, cache)
    assert bench_start(config, bench, cache) is first and len(cache.entries) == 1
    assert can_start(config, bench, cache) and len(cache.entries) == 1


def test_each_env_owns_its_starts():
    bench = nominal_benches([40.0])[0]
    a, b = TriPlanarShearV1Env(), TriPlanarShearV1Env()
    a.reset(seed=0, options={"bench": bench})
    a.reset(seed=0, options={"bench": bench})
    assert len(a._start_cache.entries) == 1 and not b._start_cache.entries
