"""What a controller is, as data: one frozen dataclass per kind, :meth:`build` into an
:class:`agents.controller_base.Controller` with the env arguments it needs.

=================  ==========================  =============================================================
spec               canonical string            builds
=================  ==========================  =============================================================
``ScriptedSpec``   ``NAME`` (``pi_feedback``)  a scripted or model-based (``mpc``, ``limit``) controller of
                                               :mod:`agents.bench_controllers`, with its ``params``
``PPOSpec``        ``ppo:RUN``,                a finished run of :mod:`agents.trainer` (frame stack,
                   ``ppo_recurrent:RUN``,      LSTM) or a ``TriPlanarShear-v0`` run that reads the exact state
                   ``ppo_state:RUN``
``ShippedSpec``    ``shipped:NAME``            training seed ``seed`` of a shipped agent (:mod:`agents.zoo`)
``StudentSpec``    ``student:FOLDER``          a distilled student (:mod:`agents.student`)
``EstimatedSpec``  ``estimated:FOLDER``        a reference-deviation PPO on a bench estimate of its deviation
                                               (:mod:`agents.deviation_estimator`)
``BankedSpec``     ``banked:RUN``,             a reference-deviation PPO run on a specimen bank's estimate of
                   ``banked:RUN?starter=NAME   its deviation (:mod:`agents.banked_deviation`); with a shipped
                   &periods=N``                agent (its seed ``seed``) driving the first N decisions
=================  ==========================  =============================================================

:func:`parse_controller` is the one place a user's string becomes a spec (``--driver`` of
``experiments.distill_labels``; ``triplanar evaluate`` maps its names through ``experiments.evaluate``); a bad
string is refused naming the field.

**Why a canonical string.** A spec's :attr:`text` is exactly the string ``experiments.episodes.EpisodeBatch`` held
in its ``controller`` field before specs existed, and the numbers that are not in that string (a scripted
controller's ``params``, a shipped agent's ``seed`` and ``zoo_dir``) stay in the batch's own fields. So a batch
made from a spec pickles to the same bytes as before: the task keys of ``triplanar.workbench.executor``'s
``TaskCheckpoint`` (derived from the pickled batch) and the ``driver`` recorded in a label folder's
``settings.json`` are unchanged, and a spec round-trips: ``parse_controller(spec.text, params=..., seed=...,
zoo_dir=...) == spec`` (tested for every kind).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Union

import numpy as np

from .controller_base import Controller

PPO_KINDS = ("ppo", "ppo_recurrent", "ppo_state")   # frame stack, LSTM, v0 on the exact state
STARTER_MARK = "?"   # banked:RUN?starter=NAME&periods=N (BankedSpec)


class ControllerSpecError(ValueError):
    """A controller string or spec field that names no controller."""


@dataclass(frozen=True)
class Built:
    """A built controller: the controller, the env arguments it runs with, whether it is learned (learned
    controllers' episodes seed the sensor noise with the episode's index)."""

    controller: Any
    env_kwargs: dict[str, Any]
    learned: bool


class _Named(Controller):
    """A policy's ``act`` under a label."""

    def __init__(self, name: str, policy_act: Any):
        self.name, self.policy_act = name, policy_act

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.policy_act(obs)


def _nonempty(kind: str, field: str, value: Any) -> None:
    if not isinstance(value, str) or not value:
        raise ControllerSpecError(f"{kind}.{field}: expected a non-empty string, got {value!r}")


@dataclass(frozen=True)
class ScriptedSpec:
    """A controller of :func:`agents.bench_controllers.make_controller` (``params``: its keyword arguments as
    ``(name, value)`` pairs, in the order given)."""

    name: str
    params: tuple = ()

    def __post_init__(self):
        from .bench_controllers import controller_names
        if self.name not in controller_names():
            raise ControllerSpecError(f"ScriptedSpec.name: unknown controller {self.name!r}; choose from "
                                      f"{controller_names()} (or ppo:RUN, ppo_recurrent:RUN, ppo_state:RUN, "
                                      "shipped:NAME, student:FOLDER, estimated:FOLDER, banked:RUN)")
        if not isinstance(self.params, tuple) or not all(
                isinstance(p, tuple) and len(p) == 2 and isinstance(p[0], str) for p in self.params):
            raise ControllerSpecError(f"ScriptedSpec.params: expected a tuple of (name, value) pairs, got "
                                      f"{self.params!r:.80}")

    @property
    def text(self) -> str:
        return self.name

    def build(self, label: str, env_kwargs: dict[str, Any], tip_friction_deg: float | None = None) -> Built:
        from .bench_controllers import make_controller
        controller = make_controller(self.name, **dict(self.params))
        controller.name = label
        return Built(controller, dict(env_kwargs), False)


@dataclass(frozen=True)
class PPOSpec:
    """A PPO run folder: ``kind`` ``ppo`` (frame stack), ``ppo_recurrent`` (LSTM) or ``ppo_state`` (v0)."""

    path: str
    kind: str = "ppo"

    def __post_init__(self):
        _nonempty("PPOSpec", "path", self.path)
        if self.kind not in PPO_KINDS:
            raise ControllerSpecError(f"PPOSpec.kind: expected one of {list(PPO_KINDS)}, got {self.kind!r}")

    @property
    def text(self) -> str:
        return f"{self.kind}:{self.path}"

    def build(self, label: str, env_kwargs: dict[str, Any], tip_friction_deg: float | None = None) -> Built:
        if self.kind == "ppo_state":
            from .ppo_controller import PPOController
            run = Path(self.path)
            ppo = PPOController.load(run / "final_model.zip", run / "vecnormalize.pkl", name=label)
            return Built(_Named(label, ppo.act), {**env_kwargs, "observation_mode": "state"}, True)
        from .robust_policy import load_policy
        return Built(load_policy(self.path, "ppo" if self.kind == "ppo" else "recurrent", name=label),
                     dict(env_kwargs), True)


@dataclass(frozen=True)
class ShippedSpec:
    """Training seed ``seed`` of the shipped agent ``name`` (``zoo_dir``: the zoo; None: the project's)."""

    name: str
    seed: int = 0
    zoo_dir: str | None = None

    def __post_init__(self):
        _nonempty("ShippedSpec", "name", self.name)
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ControllerSpecError(f"ShippedSpec.seed: expected a non-negative integer, got {self.seed!r}")
        if self.zoo_dir is not None:
            _nonempty("ShippedSpec", "zoo_dir", self.zoo_dir)

    @property
    def text(self) -> str:
        return f"shipped:{self.name}"

    def build(self, label: str, env_kwargs: dict[str, Any], tip_friction_deg: float | None = None) -> Built:
        """The agent on its card's bench (``env_kwargs`` override the card's; refused if the bench differs)."""
        from .zoo import bench_arguments, check_bench, check_layout, load_shipped, read_card
        zoo = Path(self.zoo_dir) if self.zoo_dir else None
        card = read_card(self.name, zoo)
        env_kwargs = {**card["env_kwargs"], **env_kwargs}
        env_kwargs.pop("randomize", None)   # the bench set gives the specimen
        check_layout(card, env_kwargs)
        tip = {} if tip_friction_deg is None else {"tip_friction_deg": tip_friction_deg}
        check_bench(card, bench_arguments({**env_kwargs, **tip}), "the batch's bench")
        policy = load_shipped(self.name, self.seed, zoo)
        policy.name = label
        return Built(policy, env_kwargs, True)


@dataclass(frozen=True)
class StudentSpec:
    """A student folder of ``experiments.train_student`` (it brings its own env arguments)."""

    folder: str

    def __post_init__(self):
        _nonempty("StudentSpec", "folder", self.folder)

    @property
    def text(self) -> str:
        return f"student:{self.folder}"

    def build(self, label: str, env_kwargs: dict[str, Any], tip_friction_deg: float | None = None) -> Built:
        from .student import StudentController
        student = StudentController.load(self.folder, name=label)
        return Built(student, {**student.env_kwargs, **env_kwargs}, True)


@dataclass(frozen=True)
class EstimatedSpec:
    """An estimator folder of ``experiments.deviation_estimator`` and the reference-deviation run it names."""

    folder: str

    def __post_init__(self):
        _nonempty("EstimatedSpec", "folder", self.folder)

    @property
    def text(self) -> str:
        return f"estimated:{self.folder}"

    def build(self, label: str, env_kwargs: dict[str, Any], tip_friction_deg: float | None = None) -> Built:
        from .estimated_policy import EstimatedDeviationPolicy
        return Built(EstimatedDeviationPolicy.load(self.folder, name=label), dict(env_kwargs), True)


@dataclass(frozen=True)
class BankedSpec:
    """A reference-deviation PPO run on a specimen bank's estimate of its deviation, at the module's settings; with
    a ``starter`` (a shipped agent's name), that agent's training seed ``seed`` drives the first ``start_periods``
    decisions (:class:`agents.banked_deviation.BankedDeviationPolicy`'s ``starter``): the canonical string
    ``banked:RUN?starter=NAME&periods=N``."""

    run: str
    starter: str | None = None
    start_periods: int = 0
    seed: int = 0

    def __post_init__(self):
        _nonempty("BankedSpec", "run", self.run)
        if self.starter is None:
            if self.start_periods or self.seed:
                raise ControllerSpecError("BankedSpec: start_periods and seed are a starter's; give the starter")
            return
        _nonempty("BankedSpec", "starter", self.starter)
        for field, least in (("start_periods", 1), ("seed", 0)):
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, int) or value < least:
                raise ControllerSpecError(f"BankedSpec.{field}: expected an integer >= {least}, got {value!r}")

    @property
    def text(self) -> str:
        if self.starter is None:
            return f"banked:{self.run}"
        return f"banked:{self.run}{STARTER_MARK}starter={self.starter}&periods={self.start_periods}"

    @classmethod
    def parse(cls, rest: str, seed: int) -> BankedSpec:
        """The spec of ``banked:REST`` (``REST`` = ``RUN`` or ``RUN?starter=NAME&periods=N``; the row's ``seed`` is
        the starter's training seed)."""
        run, mark, query = rest.partition(STARTER_MARK)
        if not mark:
            return cls(rest)
        fields = dict(part.partition("=")[::2] for part in query.split("&"))
        if set(fields) != {"starter", "periods"} or not fields["periods"].isdigit():
            raise ControllerSpecError(f"controller 'banked:{rest}': after {STARTER_MARK!r} expected "
                                      "starter=NAME&periods=N (a shipped agent, a positive number of decisions)")
        return cls(run, fields["starter"], int(fields["periods"]), seed)

    def build(self, label: str, env_kwargs: dict[str, Any], tip_friction_deg: float | None = None) -> Built:
        from .banked_deviation import BankedDeviationPolicy
        if self.starter is None:
            return Built(BankedDeviationPolicy.load(self.run, name=label), dict(env_kwargs), True)
        from .zoo import load_starter
        starter = load_starter(self.starter, self.seed)
        return Built(BankedDeviationPolicy.load(self.run, name=label, starter=starter,
                                                start_periods=self.start_periods), dict(env_kwargs), True)


ControllerSpec = Union[ScriptedSpec, PPOSpec, ShippedSpec, StudentSpec, EstimatedSpec, BankedSpec]


def parse_controller(text: str, *, params: tuple = (), seed: int = 0, zoo_dir: str | None = None) -> ControllerSpec:
    """The spec of a controller string (module docstring's table). ``params``: a scripted controller's numbers;
    ``seed``, ``zoo_dir``: a shipped agent's (``seed`` also a banked run's starter's; another kind's row seed is
    not part of the controller)."""
    if not isinstance(text, str) or not text:
        raise ControllerSpecError(f"controller: expected a non-empty string, got {text!r}")
    kind, sep, rest = text.partition(":")
    if params and (not isinstance(params, tuple) or sep):
        raise ControllerSpecError(f"controller {text!r}: params are a scripted controller's, got {params!r:.80}")
    if zoo_dir is not None and kind != "shipped":
        raise ControllerSpecError(f"controller {text!r}: zoo_dir is a shipped agent's, got {zoo_dir!r}")
    if not sep:
        return ScriptedSpec(text, params)
    if not rest:
        field = {"shipped": "name", "student": "folder", "estimated": "folder", "banked": "run"}.get(kind, "path")
        raise ControllerSpecError(f"controller {text!r}: the {field} after {kind + ':'!r} is empty")
    if kind in PPO_KINDS:
        return PPOSpec(rest, kind)
    if kind == "shipped":
        return ShippedSpec(rest, seed, zoo_dir)
    if kind == "student":
        return StudentSpec(rest)
    if kind == "estimated":
        return EstimatedSpec(rest)
    if kind == "banked":
        return BankedSpec.parse(rest, seed)
    raise ControllerSpecError(f"controller {text!r}: unknown kind {kind!r}; expected a bench controller name or "
                              f"one of {[*PPO_KINDS, 'shipped', 'student', 'estimated', 'banked']} followed by ':'")
