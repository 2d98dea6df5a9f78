"""Shipped agents: trained controllers kept in the repository, each with its model card.

Format (one directory per agent, ``agents/zoo/NAME/``)::

    card.json          the model card (below), read by the loader
    README.md          the same card for people (written from card.json)
    seed_S/model.zip           stable-baselines3 model of training seed S
    seed_S/vecnormalize.pkl    its observation normalisation statistics (VecNormalize, without its env)

``card.json`` holds: ``name``, ``env_id`` and ``env_kwargs`` (what it was trained on), ``algo`` (``ppo``: frame
stack; ``recurrent``: RecurrentPPO) and ``hyperparameters``, ``timesteps`` (per seed), ``seeds``, ``observation``
(the observation layout it expects: mode, fields with sizes, frames), ``figures`` (held-out and stress statistics
with their intervals, :func:`experiments.stats.row_stats`, with the number of benches), ``date``, ``command`` (what
trained it), and ``files`` (the SHA-256 of every model file).

**Trusted input.** The model files are pickles (SB3's zip holds cloudpickled objects; ``vecnormalize.pkl`` is a
pickle), and unpickling runs code. The loader therefore reads only files of the repository's own ``agents/zoo``
directory, by agent name and seed, at the paths above, and only after their SHA-256 matches the card: nothing is
loaded from a path a user types. Ship only agents you trained.
"""

from __future__ import annotations

import hashlib
import json
import pickle
from pathlib import Path
from typing import Any

ZOO_DIR = Path(__file__).parent
CARD = "card.json"
MODEL = "model.zip"
NORMALIZER = "vecnormalize.pkl"
CARD_KEYS = ("name", "env_id", "env_kwargs", "algo", "hyperparameters", "timesteps", "seeds", "observation",
             "figures", "date", "command", "files")


class ShippedAgentError(ValueError):
    """A shipped agent is missing, malformed, or does not fit the bench it is asked to run on."""


def shipped_names(zoo_dir: Path | None = None) -> list[str]:
    """The agents shipped in ``zoo_dir`` (default: the repository's ``agents/zoo``)."""
    zoo = Path(zoo_dir or ZOO_DIR)
    return sorted(p.name for p in zoo.iterdir() if (p / CARD).is_file()) if zoo.is_dir() else []


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def read_card(name: str, zoo_dir: Path | None = None) -> dict[str, Any]:
    """The model card of the shipped agent ``name`` (refused if it lacks a field)."""
    names = shipped_names(zoo_dir)
    if name not in names:
        raise ShippedAgentError(f"no shipped agent {name!r}; shipped: {names or 'none'}")
    path = Path(zoo_dir or ZOO_DIR) / name / CARD
    card = json.loads(path.read_text())
    missing = [k for k in CARD_KEYS if k not in card]
    if missing:
        raise ShippedAgentError(f"{path}: model card lacks {missing}")
    return card


def model_files(seed: int) -> tuple[str, str]:
    """The two files of one seed, relative to the agent's directory."""
    return f"seed_{seed}/{MODEL}", f"seed_{seed}/{NORMALIZER}"


def observation_layout(env_kwargs: dict[str, Any], algo: str, frames: int | None = None) -> dict[str, Any]:
    """The observation an agent trained with ``algo`` on ``TriPlanarShear-v1(**env_kwargs)`` sees: the mode, the
    fields of one observation (name, size) and the number of stacked frames (``frames``, default the frame-stacked
    runs' 4; a recurrent policy sees 1)."""
    from envs.core import OBSERVATION
    from envs.triplanar_shear_v1 import BENCH_OBSERVATION

    from ..train_robust import FRAMES
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


def load_shipped(name: str, seed: int, zoo_dir: Path | None = None) -> Any:
    """The shipped agent ``name``'s policy of training seed ``seed`` as a bench controller (``reset``/``act``),
    after checking its files' SHA-256 against the card (trusted input: see the module docstring)."""
    from ..train_robust import RecurrentPolicy, RobustPolicy
    card = read_card(name, zoo_dir)
    if seed not in card["seeds"]:
        raise ShippedAgentError(f"shipped agent {name!r} has no seed {seed}; its seeds: {card['seeds']}")
    root = Path(zoo_dir or ZOO_DIR) / name
    model_rel, norm_rel = model_files(seed)
    for rel in (model_rel, norm_rel):
        if rel not in card["files"] or not (root / rel).is_file() or _sha256(root / rel) != card["files"][rel]:
            raise ShippedAgentError(f"{root / rel}: missing or not the file its model card names (SHA-256)")
    with open(root / norm_rel, "rb") as f:
        normalizer = pickle.load(f)
    if card["algo"] == "recurrent":
        from sb3_contrib import RecurrentPPO
        return RecurrentPolicy(RecurrentPPO.load(str(root / model_rel), device="cpu"), normalizer, name)
    from stable_baselines3 import PPO
    return RobustPolicy(PPO.load(str(root / model_rel), device="cpu"), normalizer, name,
                        int(card["observation"]["frames"]))


def card_markdown(card: dict[str, Any]) -> str:
    """The model card for people (README.md of the agent's directory)."""
    lines = [f"# {card['name']}", "", f"Trained {card['date']} by", "", "```", card["command"], "```", "",
             f"* env: `{card['env_id']}` with `{json.dumps(card['env_kwargs'])}`",
             f"* algorithm: {card['algo']}; hyperparameters `{json.dumps(card['hyperparameters'])}`",
             f"* {card['timesteps']:,} steps per seed; seeds {card['seeds']}",
             f"* observation: {card['observation']['observation_mode']} mode, {card['observation']['frames']} "
             "frame(s)", "", "| bench set | benches | episodes | success (95 % CI) | mimicry error over successes, "
             "mm (95 % CI) | CVaR 10 %, mm | score, mm (95 % CI) |", "|---|---|---|---|---|---|---|"]
    for bench_set, r in card["figures"].items():
        lines.append(f"| {bench_set} | {r['n_benches']} | {r['n_episodes']} | {100 * r['success_rate']:.1f} % "
                     f"({100 * r['success_low']:.1f}-{100 * r['success_high']:.1f}) | {r['mimicry_error_mm']:.2f} "
                     f"({r['error_low_mm']:.2f}-{r['error_high_mm']:.2f}) | {r['cvar10_mm']:.2f} | {r['score']:.2f} "
                     f"({r['score_low']:.2f}-{r['score_high']:.2f}) |")
    lines += ["", "The model files are pickles: load them only through `agents.zoo.load_shipped` (trusted input, "
              "checked against the SHA-256 in card.json).", ""]
    return "\n".join(lines)
