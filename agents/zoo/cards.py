"""Model cards of the shipped agents, read strictly: every field's type and range is checked where the card is read,
and a bad card is refused whole with a :class:`ShippedAgentError` naming the field (no traceback, no partial card).
Also the checks that an agent runs on the bench of its card (observation layout and hardware)."""

from __future__ import annotations

import json
import math
import re
from dataclasses import fields
from typing import Any

CARD_KEYS = ("name", "env_id", "env_kwargs", "algo", "hyperparameters", "timesteps", "seeds", "observation",
             "figures", "date", "command", "files")
ALGOS = ("ppo", "recurrent", "banked")   # banked: a PPO with a specimen bank (agents.zoo.banked_agent)
MAX_DEPTH = 8            # the shipped cards nest 5 deep (hyperparameters.hyperparams.policy_kwargs.net_arch)
MAX_CARD_BYTES = 1 << 20
MAX_SEEDS = 100
MAX_BANK = 256           # a banked agent's specimen bank (its hypotheses)
STARTER_KEYS = ("agent", "periods", "card_sha256")   # a banked agent's starter: who drives its first decisions
MAX_START_PERIODS = 10_000
SHA256 = re.compile(r"[0-9a-f]{64}")
# Env arguments that say what an episode draws (the specimen, the load), not the bench the agent acts on: they may
# differ from the card's (the bench sets give the specimen).
EPISODE_ARGUMENTS = ("randomize", "load_N", "load_levels", "load_range", "friction_noise_deg", "tip_friction_noise_deg",
                     "specimen", "foundation", "render_mode")


class ShippedAgentError(ValueError):
    """A shipped agent is missing, malformed, not on the pinned list, or does not fit the bench it is asked to run
    on."""


def _depth(value: Any) -> int:
    """Nesting depth of a parsed JSON value, iteratively (a deep card must not exhaust the stack here either)."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        item, level = stack.pop()
        deepest = max(deepest, level)
        if isinstance(item, dict):
            stack.extend((v, level + 1) for v in item.values())
        elif isinstance(item, list):
            stack.extend((v, level + 1) for v in item)
    return deepest


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _need(ok: bool, source: str, field: str, what: str, value: Any) -> None:
    if not ok:
        shown = repr(value)
        raise ShippedAgentError(f"{source}: field {field!r} must be {what}, got {shown[:80]}")


def _check_observation(obs: Any, source: str) -> None:
    _need(isinstance(obs, dict), source, "observation", "an object", obs)
    _need(obs.get("observation_mode") in ("bench", "state"), source, "observation.observation_mode",
          "'bench' or 'state'", obs.get("observation_mode"))
    frames = obs.get("frames")
    _need(_is_int(frames) and 1 <= frames <= 64, source, "observation.frames", "an integer 1-64", frames)
    layout = obs.get("fields")
    _need(isinstance(layout, list) and 0 < len(layout) <= 64, source, "observation.fields",
          "a list of [name, size] pairs", layout)
    for i, pair in enumerate(layout):
        _need(isinstance(pair, list) and len(pair) == 2 and isinstance(pair[0], str) and _is_int(pair[1])
              and 0 < pair[1] <= 1024, source, f"observation.fields[{i}]", "a [name, size] pair", pair)


def _check_figures(figures: Any, source: str) -> None:
    _need(isinstance(figures, dict), source, "figures", "an object of bench sets", figures)
    for bench_set, row in figures.items():
        _need(isinstance(row, dict), source, f"figures.{bench_set}", "an object of statistics", row)
        for key, value in row.items():
            ok = _is_number(value) or (isinstance(value, list) and all(_is_number(v) for v in value))
            _need(ok, source, f"figures.{bench_set}.{key}", "a number or a list of numbers", value)


def _check_scalars(card: dict[str, Any], source: str) -> None:
    _need(isinstance(card["name"], str) and card["name"].isidentifier(), source, "name",
          "a name of letters, digits and underscores", card["name"])
    _need(isinstance(card["env_id"], str) and card["env_id"].startswith("TriPlanarShear-"), source, "env_id",
          "a TriPlanarShear env id", card["env_id"])
    _need(card["algo"] in ALGOS, source, "algo", f"one of {list(ALGOS)}", card["algo"])
    _need(_is_int(card["timesteps"]) and card["timesteps"] > 0, source, "timesteps", "a positive integer",
          card["timesteps"])
    for key in ("date", "command"):
        _need(isinstance(card[key], str), source, key, "a string", card[key])


def _check_collections(card: dict[str, Any], source: str) -> None:
    seeds = card["seeds"]
    _need(isinstance(seeds, list) and 0 < len(seeds) <= MAX_SEEDS and all(_is_int(s) and 0 <= s < 2**31
                                                                         for s in seeds),
          source, "seeds", f"a list of 1-{MAX_SEEDS} integers 0 <= seed < 2**31", seeds)
    _need(len(set(seeds)) == len(seeds), source, "seeds", "a list without repeats", seeds)
    kwargs = card["env_kwargs"]
    _need(isinstance(kwargs, dict), source, "env_kwargs", "an object", kwargs)
    for key, value in kwargs.items():
        _need(isinstance(value, (bool, int, float, str)) and not (isinstance(value, float) and math.isnan(value)),
              source, f"env_kwargs.{key}", "a boolean, number or string", value)
    _need(isinstance(card["hyperparameters"], dict), source, "hyperparameters", "an object", card["hyperparameters"])
    files = card["files"]
    _need(isinstance(files, dict) and all(isinstance(k, str) and isinstance(v, str) and SHA256.fullmatch(v)
                                          for k, v in files.items()),
          source, "files", "an object of file -> SHA-256 (64 hex digits)", files)


def _check_bank(card: dict[str, Any], source: str) -> None:
    """``bank_size``: the hypotheses of a ``banked`` agent's specimen bank, and no other agent's; ``tracker``: whether
    its bank's Gauss-Newton tracker runs beside it (a banked agent's only; absent: no); ``starter``: the shipped
    agent (its seed of the same number) that drives a banked agent's first ``periods`` decisions, named with the
    SHA-256 of its card (a banked agent's only; absent: none)."""
    bank = card.get("bank_size")
    if card["algo"] == "banked":
        _need(_is_int(bank) and 1 <= bank <= MAX_BANK, source, "bank_size",
              f"the specimen bank's size, an integer 1-{MAX_BANK}", bank)
    else:
        _need(bank is None, source, "bank_size", "absent (only a banked agent runs a specimen bank)", bank)
    tracker = card.get("tracker")
    _need(tracker is None or (card["algo"] == "banked" and isinstance(tracker, bool)), source, "tracker",
          "true or false on a banked agent (its bank's Gauss-Newton tracker), absent on any other", tracker)
    starter = card.get("starter")
    if starter is None:
        return
    _need(card["algo"] == "banked", source, "starter", "absent (only a banked agent's start is another agent's)",
          starter)
    _need(isinstance(starter, dict) and set(starter) == set(STARTER_KEYS), source, "starter",
          f"an object of {list(STARTER_KEYS)}", starter)
    _need(isinstance(starter["agent"], str) and starter["agent"].isidentifier() and starter["agent"] != card["name"],
          source, "starter.agent", "another shipped agent's name", starter["agent"])
    _need(_is_int(starter["periods"]) and 1 <= starter["periods"] <= MAX_START_PERIODS, source, "starter.periods",
          f"an integer 1-{MAX_START_PERIODS} (the decisions it drives)", starter["periods"])
    _need(isinstance(starter["card_sha256"], str) and bool(SHA256.fullmatch(starter["card_sha256"])), source,
          "starter.card_sha256", "the SHA-256 of the starter's card (64 hex digits)", starter["card_sha256"])


def parse_card(text: str | bytes, source: str = "card.json") -> dict[str, Any]:
    """A model card from its JSON text, every field checked (refused with :class:`ShippedAgentError` naming the
    field: a missing key, a wrong type, an out-of-range value, nesting deeper than :data:`MAX_DEPTH`)."""
    if len(text) > MAX_CARD_BYTES:
        raise ShippedAgentError(f"{source}: {len(text)} bytes, more than a model card's {MAX_CARD_BYTES}")
    try:
        card = json.loads(text)
    except RecursionError:
        raise ShippedAgentError(f"{source}: nested too deep (more than {MAX_DEPTH} levels)") from None
    except (ValueError, UnicodeDecodeError) as err:
        raise ShippedAgentError(f"{source}: not JSON ({err})") from None
    if not isinstance(card, dict):
        raise ShippedAgentError(f"{source}: a model card is a JSON object, got {type(card).__name__}")
    if _depth(card) > MAX_DEPTH:
        raise ShippedAgentError(f"{source}: nested too deep (more than {MAX_DEPTH} levels)")
    missing = [k for k in CARD_KEYS if k not in card]
    if missing:
        raise ShippedAgentError(f"{source}: model card lacks {missing}")
    _check_scalars(card, source)
    _check_collections(card, source)
    _check_bank(card, source)
    _check_observation(card["observation"], source)
    _check_figures(card["figures"], source)
    return card


# -- the bench an agent runs on ----------------------------------------------------------------------------------

def observation_layout(env_kwargs: dict[str, Any], algo: str, frames: int | None = None) -> dict[str, Any]:
    """The observation an agent trained with ``algo`` on ``TriPlanarShear-v1(**env_kwargs)`` sees: the mode, the
    fields of one observation (name, size) and the number of stacked frames (``frames``, default the frame-stacked
    runs' 4; a recurrent policy sees 1)."""
    from envs.core import OBSERVATION
    from envs.triplanar_shear_v1 import BENCH_OBSERVATION

    from ..robust_policy import FRAMES
    mode = env_kwargs.get("observation_mode", "bench")
    layout = BENCH_OBSERVATION if mode == "bench" else OBSERVATION
    return {"observation_mode": mode, "fields": [[f.name, f.size] for f in layout.fields.values()],
            "frames": 1 if algo == "recurrent" else int(frames or FRAMES)}


def check_layout(card: dict[str, Any], env_kwargs: dict[str, Any]) -> None:
    """Refuse (naming the field) a bench whose observation differs from the one in the agent's card."""
    expected, actual = card["observation"], observation_layout(env_kwargs, card["algo"],
                                                               card["observation"].get("frames"))
    for key in ("observation_mode", "frames"):
        if expected.get(key) != actual[key]:
            raise ShippedAgentError(f"shipped agent {card['name']!r} expects {key}={expected.get(key)!r}, this bench "
                                    f"has {actual[key]!r}")
    want, have = [tuple(f) for f in expected["fields"]], [tuple(f) for f in actual["fields"]]
    for i in range(max(len(want), len(have))):
        w = want[i] if i < len(want) else None
        h = have[i] if i < len(have) else None
        if w != h:
            field = (w or h)[0]
            raise ShippedAgentError(f"shipped agent {card['name']!r}: observation field {field!r} differs (model card: "
                                    f"{w}, this bench: {h}; name, size at position {i})")


def bench_arguments(env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """Every ``TriPlanarShear-v1`` argument that shapes what the agent acts on (the bench's hardware, the tip, the
    task's settings), defaults filled in; the arguments of :data:`EPISODE_ARGUMENTS` left out."""
    from envs.core import ShearConfig, make_config
    from envs.triplanar_shear_v1 import BENCH_FIELDS, BenchConfig
    kwargs = {k: v for k, v in env_kwargs.items() if k not in EPISODE_ARGUMENTS}
    bench = BenchConfig(**{k: kwargs.pop(k) for k in BENCH_FIELDS if k in kwargs})
    config = make_config(None, **kwargs)
    return ({k: getattr(bench, k) for k in BENCH_FIELDS if k not in EPISODE_ARGUMENTS}
            | {f.name: getattr(config, f.name) for f in fields(ShearConfig) if f.name not in EPISODE_ARGUMENTS})


def bench_arguments_of_env(env: Any) -> dict[str, Any]:
    """:func:`bench_arguments` of a made ``TriPlanarShear-v1`` env (wrappers looked through)."""
    from envs.core import ShearConfig
    from envs.triplanar_shear_v1 import BENCH_FIELDS, TriPlanarShearV1Env
    inner = getattr(env, "unwrapped", env)
    if not isinstance(inner, TriPlanarShearV1Env):
        raise ShippedAgentError(f"the shipped agents run on TriPlanarShear-v1 (model card: env_id), this env is "
                                f"{type(inner).__name__}")
    return ({k: getattr(inner.bench, k) for k in BENCH_FIELDS if k not in EPISODE_ARGUMENTS}
            | {f.name: getattr(inner.config, f.name) for f in fields(ShearConfig) if f.name not in EPISODE_ARGUMENTS})


def check_bench(card: dict[str, Any], actual: dict[str, Any], where: str = "this env",
                hint: str = "make its env with agent.make_env()") -> None:
    """Refuse, naming the first differing argument, a bench (:func:`bench_arguments`) other than the card's; the
    message ends with ``hint`` (what to do instead)."""
    expected = bench_arguments(card["env_kwargs"])
    for key, want in expected.items():
        have = actual.get(key)
        if not (have == want or (_is_number(have) and _is_number(want) and float(have) == float(want))):
            raise ShippedAgentError(f"shipped agent {card['name']!r} was trained with {key}={want!r} (model card: "
                                    f"env_kwargs), {where} has {key}={have!r}; {hint}")


def card_markdown(card: dict[str, Any]) -> str:
    """The model card for people (README.md of the agent's directory)."""
    lines = [f"# {card['name']}", "", f"Trained {card['date']} by", "", "```", card["command"], "```", "",
             f"* env: `{card['env_id']}` with `{json.dumps(card['env_kwargs'])}`",
             f"* algorithm: {card['algo']}; hyperparameters `{json.dumps(card['hyperparameters'])}`",
             f"* {card['timesteps']:,} steps per seed; seeds {card['seeds']}",
             *([f"* specimen bank beside the policy: {card['bank_size']} hypotheses (`agents/zoo/banked_agent.py`)"
                + ("; its Gauss-Newton tracker behind the decision (`agents/deviation_tracker.py`, "
                   "`agents/estimate_worker.py`)" if card.get("tracker") else "")]
               if card["algo"] == "banked" else []),
             *([f"* the first {card['starter']['periods']} decisions are the shipped `{card['starter']['agent']}`'s "
                "(its seed of the same number; the bank and the frame stack see them)"] if card.get("starter") else []),
             f"* observation: {card['observation']['observation_mode']} mode, {card['observation']['frames']} "
             "frame(s)", "", "| bench set | benches | episodes | success (95 % CI) | mimicry error over successes, "
             "mm (95 % CI) | CVaR 10 %, mm | score, mm (95 % CI) |", "|---|---|---|---|---|---|---|"]
    for bench_set, r in card["figures"].items():
        lines.append(f"| {bench_set} | {r['n_benches']} | {r['n_episodes']} | {100 * r['success_rate']:.1f} % "
                     f"({100 * r['success_low']:.1f}-{100 * r['success_high']:.1f}) | {r['mimicry_error_mm']:.2f} "
                     f"({r['error_low_mm']:.2f}-{r['error_high_mm']:.2f}) | {r['cvar10_mm']:.2f} | {r['score']:.2f} "
                     f"({r['score_low']:.2f}-{r['score_high']:.2f}) |")
    lines += ["", "Load it with `agents.zoo.load_shipped(name, seed)`: the weights are safetensors, the normalisation "
              "statistics JSON (nothing is unpickled), checked against the SHA-256 pinned in `agents/zoo/__init__.py`.",
              ""]
    return "\n".join(lines)
