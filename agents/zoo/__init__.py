"""Shipped agents: trained controllers kept in the repository, each with its model card.

Format (one directory per agent, ``agents/zoo/NAME/``)::

    card.json                     the model card (below), read by the loader
    README.md                     the same card for people (written from card.json)
    seed_S/policy.safetensors     the SB3 policy's weights of training seed S (tensors only)
    seed_S/normalizer.json        its observation normalisation (VecNormalize's statistics and settings)

``card.json`` holds: ``name``, ``env_id`` and ``env_kwargs`` (what it was trained on), ``algo`` (``ppo``: frame
stack; ``recurrent``: RecurrentPPO; ``banked``: a frame-stack PPO with a specimen bank beside it,
:mod:`agents.zoo.banked_agent`) and ``hyperparameters``, ``timesteps`` (per seed), ``seeds``, ``observation``
(the observation layout it expects: mode, fields with sizes, frames), ``figures`` (held-out and stress statistics
with their intervals, :func:`experiments.stats.row_stats`, with the number of benches), ``date``, ``command`` (what
trained it), ``files`` (the SHA-256 of every model file), and for a ``banked`` agent ``bank_size`` (its specimen bank's
hypotheses). Cards are read strictly (:func:`cards.parse_card`).

**What is loaded, and how.** Nothing of a shipped agent is unpickled: the weights are safetensors (a header and
raw tensors, no code), the statistics and the card JSON, and :mod:`agents.zoo.agent` rebuilds the SB3 policy
object from the card's hyperparameters and the env's spaces. The agents that exist, and the SHA-256 of each of
their files (card included), are pinned here in the package's code (:data:`SHIPPED`), not beside the files: a
folder added under ``agents/zoo`` is neither listed nor loaded, a changed file is refused, and so is a symlinked
folder or file. ``python -m experiments.shipping`` writes an agent in this format and prints its pins.

**A stranger's SB3 zip** (``model.zip``, ``vecnormalize.pkl``) holds pickles, and unpickling runs the code in them:
:func:`agents.ppo_controller.load_untrusted_sb3_zip` and :func:`agents.ppo_controller.load_untrusted_vecnormalize`
load one, only when called by name with its path; nothing here calls them.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Any

from .cards import (ShippedAgentError, bench_arguments, card_markdown, check_bench, check_layout, observation_layout,
                    parse_card)

__all__ = ["ShippedAgentError", "bench_arguments", "card_markdown", "check_bench", "check_layout", "load_shipped",
           "model_files", "observation_layout", "parse_card", "read_card", "shipped_names", "SHIPPED", "ZOO_DIR"]

ZOO_DIR = Path(__file__).parent
CARD = "card.json"
Pins = dict[str, dict[str, str]]

# The shipped agents and the SHA-256 of each of their files (written by `python -m experiments.shipping`).
SHIPPED: Pins = {
    "ppo_banked": {
        "card.json": "e97b633cc79b2a17a78109dd07107a535b9f4f0b6838aa7a89c2f7f67dada0ad",
        "seed_0/normalizer.json": "8f0e2e4e53110cde0086a48a2518ea653ea321d25718feb69d526410e5ad4dbd",
        "seed_0/policy.safetensors": "f76c9e9a029aca445c3a2240cd2c04ceeeb39714d7fb90a625e3761313f239d1",
        "seed_1/normalizer.json": "4b17c7077251deaf55165ca5541756257fbd3fdea010ec3f88391b49d129bb05",
        "seed_1/policy.safetensors": "1bea28e5251cfed5994d1c7864737b9d78ad6f323ec9bae7014f4c16bc78a1f0",
        "seed_2/normalizer.json": "72c6ead19ac8970d65aaa6035a3ae36bff67dbc7d52da2c772f14055d651a7eb",
        "seed_2/policy.safetensors": "beb54e875ce014c5e81d46af0dd05766d02e81a30939e54be5b0862493deb352",
    },
    "ppo_recurrent": {
        "card.json": "4e93a128182dcb0183b47b08a058c5e8c5ed08c928f29498ef122e046263e9d2",
        "seed_0/normalizer.json": "933fdf2be6a12c6eb5edcaa0a57e0ff27909c3bb0b848dcb287bef6b7a2c78a6",
        "seed_0/policy.safetensors": "9ad6f95d78ca82d4e622af1781db7714b5790945a086296cacedd1f0a060e944",
        "seed_1/normalizer.json": "2f99f76ea57697693cff68582dfb7539745b93316aba5b0f61a1b77cb5f546b4",
        "seed_1/policy.safetensors": "3e225ac962e3dd4450afe32a4959e191a5388f73b7fc8f98566a9ffd9fc8407c",
        "seed_2/normalizer.json": "caf5813439f35aa50bcbd6c6c8ce181a5af3e2156e9121e9c9346c3137df9d6d",
        "seed_2/policy.safetensors": "f542a31a28120853df93670e6527d262527a385879182232887d057abfe87435",
        "seed_3/normalizer.json": "c03167c0ca2ab9ad4cbb094a99ba1c7e8d91108fba82dea83ed5a393a075048c",
        "seed_3/policy.safetensors": "27268bae3b8d7b1c6be44b029936c1087f5c9862a24abfcd7fbfef254339887b",
        "seed_4/normalizer.json": "74f56d15861bb834b657d059cc3067e541e8bd1e388a708ef35aa617b6f5cc6b",
        "seed_4/policy.safetensors": "79fbac79b6716ef7a20a93f9abe9037c121838a013240c7be61789be24b02dec",
    },
    "ppo_robust": {
        "card.json": "5f3ee3b2bed81977b311519439475898798c2d26a4cf9fdafb16dc574da1a09b",
        "seed_0/normalizer.json": "5b009d4aed7ed5eccb2a5a04315969aba945435f504c25631d47e86894ec7634",
        "seed_0/policy.safetensors": "a35d3c9a33013df349c82745b124de9c4a0ec738990f943d5c323242db70c14b",
        "seed_1/normalizer.json": "91a668aa0415f0e490e9a04e3749917a249f0e3ac0a7ed7fb4cb1d8637e858a2",
        "seed_1/policy.safetensors": "052a9facb736326d2fcb3acca8eb527d29a6ca70702e15081c2bb362a1020c69",
        "seed_2/normalizer.json": "6cf87e50dbf6f1482d223a242c59fd952f3a606bbc825c3113b76e2d1c06c350",
        "seed_2/policy.safetensors": "a8ed7cc8ae00a7ee5719ea4bfce54e3c4d3b2187684225d62ffe0c4359f6181c",
        "seed_3/normalizer.json": "e9471180e15b6a3835c4f2968653220ab6b5cb7e296955fa3bdafd7a751168e3",
        "seed_3/policy.safetensors": "ddf2adf425159de14fe8135dae3fd45b770e623476c7fe48c8d48daad7317f05",
        "seed_4/normalizer.json": "42a2489cac725ca2f6ed69892f5ea1cad7738eb343fe6b12e9c44ad602d3cabc",
        "seed_4/policy.safetensors": "efb050e15e749a1c5a2140c5adc22a042cf4d4eb2f31f1cd0291e22b817da335",
    },
    "ppo_steel_slow_noisy": {
        "card.json": "7034f4b6e16fa9f82cb305ab8a95a0e410d6ecbe26cd963260e39dd8d63d8a2f",
        "seed_0/normalizer.json": "5254afc92091e1b95bec65434fe7fc223f9a6c9651dc6896957c5a58fd76ac15",
        "seed_0/policy.safetensors": "7e222bb045b83fcc5a2706ccb70d4a115a2bb7ee52616430637b690365617958",
        "seed_1/normalizer.json": "50440c3f5124a6173ea0e7dc06d48de7aa96efbc98c40f42efe3da638db0d603",
        "seed_1/policy.safetensors": "e4f5b588bf81c2c3061952b1640ef789c61326ebfc6a9bfc2c3db700373a851c",
        "seed_2/normalizer.json": "a8e2f1346ea69a828594617b7b3f16705a44dba40da05d4fd2bc903389afb88c",
        "seed_2/policy.safetensors": "fe5e27b0c68d6a3f0631563573787531b27879e00d8697097e80091f4306ae7b",
    },
}


def shipped_names(zoo_dir: Path | None = None, pins: Pins | None = None) -> list[str]:
    """The shipped agents: the names pinned in :data:`SHIPPED` (``pins``), not the folders found on disk
    (``zoo_dir`` is accepted for the callers that name their zoo)."""
    return sorted(SHIPPED if pins is None else pins)


def _agent_pins(name: str, pins: Pins | None) -> dict[str, str]:
    pinned = SHIPPED if pins is None else pins
    if name not in pinned:
        raise ShippedAgentError(f"no shipped agent {name!r}; shipped: {sorted(pinned) or 'none'} (the list is "
                                "pinned in agents/zoo/__init__.py, a folder added under agents/zoo is not loaded)")
    return pinned[name]


def read_pinned(name: str, rel: str, zoo_dir: Path | None = None, pins: Pins | None = None) -> bytes:
    """The bytes of file ``rel`` of shipped agent ``name``, refused unless its SHA-256 is the pinned one and no
    part of its path below the zoo is a symlink (the bytes checked are the bytes returned)."""
    expected = _agent_pins(name, pins).get(rel)
    root = Path(zoo_dir or ZOO_DIR)
    path = root / name / rel
    if expected is None:
        raise ShippedAgentError(f"{path}: not a file pinned for shipped agent {name!r}")
    parts = Path(name, rel).parts
    for i in range(1, len(parts) + 1):
        if (root.joinpath(*parts[:i])).is_symlink():
            raise ShippedAgentError(f"{root.joinpath(*parts[:i])}: a symlink; shipped agents are real files")
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
    except OSError as err:
        raise ShippedAgentError(f"{path}: cannot read ({err.strerror})") from None
    with os.fdopen(fd, "rb") as f:
        data = f.read()
    if hashlib.sha256(data).hexdigest() != expected:
        raise ShippedAgentError(f"{path}: not the file pinned for shipped agent {name!r} (SHA-256 differs)")
    return data


def read_card(name: str, zoo_dir: Path | None = None, pins: Pins | None = None) -> dict[str, Any]:
    """The model card of the shipped agent ``name``: pinned, then read strictly (refused naming the field)."""
    card = parse_card(read_pinned(name, CARD, zoo_dir, pins), str(Path(zoo_dir or ZOO_DIR) / name / CARD))
    if card["name"] != name:
        raise ShippedAgentError(f"{name}/{CARD}: field 'name' is {card['name']!r}, not {name!r}")
    return card


def model_files(seed: int) -> tuple[str, str]:
    """The two files of one seed, relative to the agent's directory."""
    from .agent import NORMALIZER, POLICY
    return f"seed_{seed}/{POLICY}", f"seed_{seed}/{NORMALIZER}"


def load_shipped(name: str, seed: int, zoo_dir: Path | None = None, pins: Pins | None = None) -> Any:
    """The shipped agent ``name``'s policy of training seed ``seed`` (:class:`agents.zoo.agent.ShippedAgent`:
    SB3's ``predict``, ``reset()``, ``agent(obs)``, ``make_env()``), its files checked against the pinned SHA-256
    and read without unpickling (module docstring)."""
    from safetensors.torch import load as load_tensors

    from .agent import ObsNormalizer, ShippedAgent, build_policy
    card = read_card(name, zoo_dir, pins)
    if seed not in card["seeds"]:
        raise ShippedAgentError(f"shipped agent {name!r} has no seed {seed}; its seeds: {card['seeds']}")
    policy_rel, norm_rel = model_files(seed)
    weights = read_pinned(name, policy_rel, zoo_dir, pins)
    try:
        state_dict = load_tensors(weights)
    except Exception as err:  # the safetensors reader's own error types
        raise ShippedAgentError(f"{name}/{policy_rel}: not a safetensors file ({err})") from None
    policy = build_policy(card, state_dict)
    size = policy.observation_space.shape[0]
    normalizer = ObsNormalizer.from_json(read_pinned(name, norm_rel, zoo_dir, pins), size, f"{name}/{norm_rel}")
    if card["algo"] == "banked":
        from .banked_agent import BankedAgent
        return BankedAgent(card, seed, policy, normalizer)
    return ShippedAgent(card, seed, policy, normalizer)
