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
hypotheses), if it was trained on that bank's Gauss-Newton tracker, ``tracker`` true (the tracker run behind the
decision as a bench runs it), and if another shipped agent drives its first decisions, ``starter`` (that agent's
name, the number of decisions, the SHA-256 of its card; its seed of the same number is loaded from the same zoo).
Cards are read strictly (:func:`cards.parse_card`).

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
           "load_starter", "model_files", "observation_layout", "parse_card", "read_card", "read_pinned", "shipped_names",
           "SHIPPED", "ZOO_DIR"]

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
        "card.json": "6484c9dded5220845c076c3ff0e8f4fdd8928391e2d446f61689a8b8eda9ab3b",
        "seed_0/normalizer.json": "9ce37035febc647ac2d090447d26faf0c22b8daf704f6bac7beb4feceadb097a",
        "seed_0/policy.safetensors": "ec0ec229be0f371c222d6844d3cd9d934302f2e71d21ed96006405fc38257e86",
        "seed_1/normalizer.json": "9659a591b9c74848b4f976a28393f928c901597ff51f5a549139b0c988d4f18c",
        "seed_1/policy.safetensors": "feff98d3b4eea7925262564a373ab1056db1a1150ad7c68c3ec21d0f34ffa3b5",
        "seed_2/normalizer.json": "d7f870e60977c0b257377aae41268cccbb98583fff58bdeb13e6677ed478c38e",
        "seed_2/policy.safetensors": "180d8d9f8397545d9a4c75be1a5f3af7a9948483b4393c64ea7c80e3ed04bcb6",
        "seed_3/normalizer.json": "2cc050b98b79945f319d1766622df6b1f80758a6d92a3a2535905fea223aec91",
        "seed_3/policy.safetensors": "604006b98545c25f618e557aea68a81e9c67d1cb70a2060c7550f0195db0cddf",
        "seed_4/normalizer.json": "bc8dd452ad156ed1a2ed6e33c464ddb2dd97ecb8a876c5e59a5ff7c51b3b85e4",
        "seed_4/policy.safetensors": "3061f60ee492997716910fdfd0bf1be1d8bae7565b7853aa80b35d8e5aa3c023",
    },
    "ppo_robust": {
        "card.json": "b6de56671d53e0417e21bcd0abeadc2529018e9dad0e88553726a8a449ad8fb0",
        "seed_0/normalizer.json": "eede3a9615b2e3da337a95925d799346f19b3085bf512a6eb79f6c033de11470",
        "seed_0/policy.safetensors": "a436755a0f64daba968b46b54544cde0edfeec81ece4b96f3c8f611fb7e7aa77",
        "seed_1/normalizer.json": "11233deff73d9169774577bd5d0c892df7fca4645718798cc444441e8e7987c2",
        "seed_1/policy.safetensors": "9b98ffea18b8afb36f021f9e3f9c2be548622cef1c4550767da5bb06ec98adf8",
        "seed_2/normalizer.json": "a979f202c1ff8d19bf5432aa8b74b33bee1f6406c1b6e1f3dd4c31d21e0a0bba",
        "seed_2/policy.safetensors": "b1743299da9a73bc594a6b4df7c81aac1750e4cdf60f07bad15c37caa750a35d",
        "seed_3/normalizer.json": "e88ab0ca7ef6dc50cd068f517712b9d6b0e7957e652f82cf263e00cb680502c3",
        "seed_3/policy.safetensors": "19c03b91d39cbe42504425ac95526d78ffb663c77ae1ea2f539143a10c1335cf",
        "seed_4/normalizer.json": "49eabba0469a7fe4e8207829035d203795abcfdcc8585e0fc166c06e4dd5ee0e",
        "seed_4/policy.safetensors": "41f5bf8cd8f940ce0953b8118e4e29f1ba5a6d1a1314e866fa4b65b080d382a0",
    },
    "ppo_rolling_slow_noisy": {
        "card.json": "0c738d7c4260c91ed8092bdca50f2748e6945026aa78ba9e4854f0b9b825f68f",
        "seed_0/normalizer.json": "4520c7e9471eac1b9dbccc93d3465901ecdcbe169178f2d617af8c7195f04477",
        "seed_0/policy.safetensors": "5b18059c2303f78d8462209434ef6932137c051b02d43a21919c0b5b94d8bdb3",
        "seed_1/normalizer.json": "9e99c9c6f7a259b39d3ec9e8e8527fa7ba2eb50211af4d184610fc5854db5c2e",
        "seed_1/policy.safetensors": "a319783c8021c2116f785638b34368c9eefbc8c92138100eba8555f01ee17cc3",
        "seed_2/normalizer.json": "48a3aa426a78007aee102f243eedc3627861c5734d34828038057767d4ab1f4a",
        "seed_2/policy.safetensors": "325b6c1053b9c1d8f585c31d1bba3178e0b28f16ce93c78dec7ac2e2edf5900e",
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
    "ppo_tracked": {
        "card.json": "5afd7e3940dd97518cd187d7bc254c392970b0db0b8de5bc5d901a09d91193a6",
        "seed_0/normalizer.json": "2c2b2ec77dbc6290ec4e9722aea99fcdcbdb4d5507d1c3280c78c79c67eb3d77",
        "seed_0/policy.safetensors": "c30d5ed1d2c502edb429f5ad0163b10ac62d4b5fcadb8e6fd64e6521912bf3aa",
        "seed_1/normalizer.json": "c33702411356b43ae840a35875da47f78af892b0b4ff204820c3c652149423f9",
        "seed_1/policy.safetensors": "6766df93f85ebfdf69a33b263e4b6c64df8f7cde8629ba3eb77449ea320cdd13",
        "seed_2/normalizer.json": "c0d8417d385418e97d4288786edd08417affaef1fdc513cc0cc62ae9a32eacfa",
        "seed_2/policy.safetensors": "81ee02a7b7bdb80807a4c134b56f2434f461982d77d309970b4582eb9dd574c7",
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
        return BankedAgent(card, seed, policy, normalizer, _starter(card, seed, zoo_dir, pins))
    return ShippedAgent(card, seed, policy, normalizer)


def _starter(card: dict[str, Any], seed: int, zoo_dir: Path | None, pins: Pins | None) -> Any:
    """The shipped agent that drives a ``banked`` agent's first decisions (its card's ``starter``; None if it has
    none): its seed ``seed``, from the same zoo and pins, refused unless its card is the one the agent's card names
    (the figures were measured with that one) and it has no starter of its own."""
    named = card.get("starter")
    if named is None:
        return None
    agent = named["agent"]
    if _agent_pins(agent, pins).get(CARD) != named["card_sha256"]:
        raise ShippedAgentError(f"shipped agent {card['name']!r}: its starter {agent!r} is not the one its card names "
                                "(field 'starter.card_sha256' differs from the pinned card's SHA-256)")
    starter_card = read_card(agent, zoo_dir, pins)
    if starter_card.get("starter") is not None:
        raise ShippedAgentError(f"shipped agent {card['name']!r}: its starter {agent!r} has a starter of its own")
    check_layout(starter_card, card["env_kwargs"])    # (the starter sees the agent's observations, on its bench)
    check_bench(starter_card, bench_arguments(card["env_kwargs"]), f"{card['name']!r}'s card",
                "a starter runs on the bench of the agent it starts")
    return load_starter(agent, seed, zoo_dir, pins)


def load_starter(name: str, seed: int, zoo_dir: Path | None = None, pins: Pins | None = None) -> Any:
    """The shipped agent ``name``'s seed ``seed`` as a banked agent's starter: a recurrent one in numpy
    (:class:`agents.zoo.starter.NumpyRecurrentStarter`), another as loaded."""
    from .starter import NumpyRecurrentStarter
    agent = load_shipped(name, seed, zoo_dir, pins)
    return NumpyRecurrentStarter(agent) if agent.recurrent else agent
