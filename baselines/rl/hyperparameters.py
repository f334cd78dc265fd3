"""Checks of the Stable-Baselines3 keyword arguments training passes on (``--hp``, presets' ``hyperparameters``).

SB3 checks few of them, late and with ``assert`` (``n_steps=-1`` fails after the envs are
built) or not at all (``n_epochs=0`` or ``gamma=2`` train on NaNs). Here every keyword of
every algorithm :mod:`baselines.rl.train` offers has a :class:`Rule` (type and range), and
:func:`check_hyperparameters` applies them before any env is built: a key the algorithm does
not take, or one training sets itself (``seed``, ``verbose``, ...), is refused naming it;
``policy_kwargs`` are checked key by key against the algorithm's ``MlpPolicy``.
:func:`check_rollout` adds the checks that need the env's action space and slot count
(``n_envs`` × robots). Every error is one ``ValueError`` line naming the key, the value and
what is expected. Values are passed on unchanged.
"""

from __future__ import annotations

import importlib
import inspect
import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["Rule", "check_hyperparameters", "check_rollout", "policy_rules", "rules"]

#: Keywords of the algorithms that training sets itself, with what sets them instead.
RESERVED: dict[str, str] = {
    "policy": "training uses MlpPolicy; shape it with policy_kwargs",
    "env": "the env comes from --env and --set",
    "seed": "use --seed",
    "verbose": "use --verbose",
    "device": "training runs on the CPU",
    "tensorboard_log": "use --tensorboard",
    "_init_setup_model": "internal to SB3",
}
#: Keywords of a policy's constructor that the algorithm sets itself.
_POLICY_RESERVED = {
    "observation_space": "the env's",
    "action_space": "the env's",
    "lr_schedule": "from learning_rate",
    "use_sde": "set use_sde as a hyperparameter of the algorithm",
    "mask_width": "training sets it from the env's action space (maskable_recurrent_ppo)",
}


@dataclass(frozen=True)
class Rule:
    """What a value must be: ``expected`` in words, ``test`` the check (an exception in it means no)."""

    expected: str
    test: Callable[[Any], bool]

    def accepts(self, value: Any) -> bool:
        try:
            return bool(self.test(value))
        except Exception:  # noqa: BLE001 - e.g. a comparison a foreign value does not support
            return False


def _is_int(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


def number(low: float | None = None, high: float | None = None, *, open_low: bool = False) -> Rule:
    """A finite real number (not a bool) ``>= low`` (``> low`` with ``open_low``) and ``<= high``."""
    if low is None:
        expected = "a finite number"
    elif high is None:
        expected = f"a number {'>' if open_low else '>='} {low:g}"
    else:
        expected = f"a number in {'(' if open_low else '['}{low:g}, {high:g}]"

    def test(value: Any) -> bool:
        if not _is_number(value):
            return False
        above = low is None or (value > low if open_low else value >= low)
        return above and (high is None or value <= high)

    return Rule(expected, test)


def integer(minimum: int) -> Rule:
    """An integer (not a bool) ``>= minimum``."""
    return Rule(f"an integer >= {minimum}", lambda value: _is_int(value) and value >= minimum)


def optional(rule: Rule) -> Rule:
    """``None`` or what ``rule`` accepts."""
    return Rule(f"None or {rule.expected}", lambda value: value is None or rule.accepts(value))


def schedule(rule: Rule) -> Rule:
    """What ``rule`` accepts or (from Python) a callable of SB3's remaining progress."""
    return Rule(f"{rule.expected} (or, from Python, a schedule)", lambda value: rule.accepts(value) or callable(value))


def _resolve(path: str) -> type:
    module, _, name = path.rpartition(".")
    return getattr(importlib.import_module(module), name)


def subclass(path: str) -> Rule:
    """A class derived from the class at ``path`` (given from Python; a command line cannot name one)."""
    return Rule(
        f"a subclass of {path} (from Python)",
        lambda value: isinstance(value, type) and issubclass(value, _resolve(path)),
    )


def instance(path: str) -> Rule:
    """An instance of the class at ``path`` (given from Python)."""
    return Rule(f"an instance of {path} (from Python)", lambda value: isinstance(value, _resolve(path)))


FLAG = Rule("True or False", lambda value: isinstance(value, bool))
MAPPING = Rule("a dict with string keys", lambda value: isinstance(value, Mapping) and all(isinstance(k, str) for k in value))


def _layers(value: Any) -> bool:
    return isinstance(value, list) and all(_is_int(size) and size >= 1 for size in value)


def net_arch(keys: tuple[str, ...], every: bool) -> Rule:
    """``net_arch``: a list of layer sizes, or a dict of such lists under ``keys`` (all of them if ``every``)."""
    if not keys:
        return Rule("a list of layer sizes >= 1", _layers)
    which = " and ".join(keys) if every else f"among {', '.join(keys)}"

    def test(value: Any) -> bool:
        if isinstance(value, Mapping):
            names = set(value)
            fits = names == set(keys) if every else names <= set(keys)
            return fits and all(_layers(v) for v in value.values())
        return _layers(value)

    return Rule(f"a list of layer sizes >= 1, or a dict with keys {which} of such lists", test)


def _train_freq(value: Any) -> bool:
    if isinstance(value, tuple):  # SB3 takes a tuple (a list would be read as a frequency)
        return len(value) == 2 and _is_int(value[0]) and value[0] >= 1 and value[1] in ("step", "episode")
    return _is_int(value) and value >= 1


def _auto_or(minimum: float) -> Callable[[Any], bool]:
    """SAC's ``ent_coef``: a number ``>= minimum``, ``'auto'`` or ``'auto_<x>'`` with ``x > 0``."""

    def test(value: Any) -> bool:
        if isinstance(value, str):
            head, sep, tail = value.partition("_")
            return head == "auto" and (not sep or (math.isfinite(float(tail)) and float(tail) > 0))
        return _is_number(value) and value >= minimum

    return test


UNIT = number(0, 1)
POSITIVE = number(0, open_low=True)
NON_NEGATIVE = number(0)
COUNT = integer(1)

#: The rule of every keyword of the offered algorithms (one name means the same in each).
RULES: dict[str, Rule] = {
    "learning_rate": schedule(POSITIVE),
    "n_steps": COUNT,
    "batch_size": COUNT,
    "n_epochs": COUNT,
    "gamma": number(0, 1, open_low=True),
    "gae_lambda": UNIT,
    "clip_range": schedule(POSITIVE),
    "clip_range_vf": optional(schedule(POSITIVE)),
    "normalize_advantage": FLAG,
    "ent_coef": NON_NEGATIVE,
    "vf_coef": NON_NEGATIVE,
    "max_grad_norm": POSITIVE,
    "use_sde": FLAG,
    "sde_sample_freq": integer(-1),
    "rollout_buffer_class": optional(subclass("stable_baselines3.common.buffers.RolloutBuffer")),
    "rollout_buffer_kwargs": optional(MAPPING),
    "target_kl": optional(POSITIVE),
    "stats_window_size": COUNT,
    "policy_kwargs": optional(MAPPING),
    "rms_prop_eps": POSITIVE,
    "use_rms_prop": FLAG,
    "buffer_size": COUNT,
    "learning_starts": integer(0),
    "tau": number(0, 1, open_low=True),
    "train_freq": Rule("an integer >= 1, or a tuple (integer >= 1, 'step' or 'episode')", _train_freq),
    "gradient_steps": Rule("an integer >= 1, or -1 (as many as environment steps)", lambda v: _is_int(v) and (v >= 1 or v == -1)),
    "action_noise": optional(instance("stable_baselines3.common.noise.ActionNoise")),
    "replay_buffer_class": optional(subclass("stable_baselines3.common.buffers.ReplayBuffer")),
    "replay_buffer_kwargs": optional(MAPPING),
    "optimize_memory_usage": FLAG,
    "target_update_interval": COUNT,
    "target_entropy": Rule("'auto' or a finite number", lambda v: v == "auto" or _is_number(v)),
    "use_sde_at_warmup": FLAG,
    "policy_delay": COUNT,
    "target_policy_noise": NON_NEGATIVE,
    "target_noise_clip": NON_NEGATIVE,
    "exploration_fraction": number(0, 1, open_low=True),
    "exploration_initial_eps": UNIT,
    "exploration_final_eps": UNIT,
}
#: Where an algorithm's keyword means something else than in :data:`RULES`.
_ALGO_RULES: dict[str, dict[str, Rule]] = {
    "maskable_ppo": {"batch_size": optional(COUNT)},  # None: the whole rollout in one batch
    "sac": {"ent_coef": Rule("a number >= 0, 'auto' or 'auto_<initial value > 0>'", _auto_or(0))},
}
#: The rule of every keyword of the policies' constructors (``policy_kwargs``); ``net_arch`` per algorithm.
POLICY_RULES: dict[str, Rule] = {
    "activation_fn": subclass("torch.nn.Module"),
    "ortho_init": FLAG,
    "log_std_init": number(),
    "full_std": FLAG,
    "use_expln": FLAG,
    "squash_output": FLAG,
    "clip_mean": POSITIVE,
    "n_critics": COUNT,
    "features_extractor_class": subclass("stable_baselines3.common.torch_layers.BaseFeaturesExtractor"),
    "features_extractor_kwargs": optional(MAPPING),
    "share_features_extractor": FLAG,
    "normalize_images": FLAG,
    "optimizer_class": subclass("torch.optim.Optimizer"),
    "optimizer_kwargs": optional(MAPPING),
    # RecurrentPPO's MlpLstmPolicy (baselines.rl.recurrent)
    "lstm_hidden_size": COUNT,
    "n_lstm_layers": COUNT,
    "shared_lstm": FLAG,
    "enable_critic_lstm": FLAG,
    "lstm_kwargs": optional(MAPPING),
}
#: RecurrentPPO and its masked variant (baselines.rl.recurrent).
_RECURRENT = ("recurrent_ppo", "maskable_recurrent_ppo")
_NET_ARCH: dict[str, Rule] = {
    "dqn": net_arch((), every=False),
    **{algo: net_arch(("pi", "qf"), every=True) for algo in ("sac", "td3", "ddpg")},
    **{algo: net_arch(("pi", "vf"), every=False) for algo in ("ppo", "a2c", "maskable_ppo", *_RECURRENT)},
}
#: Algorithms that normalise advantages per mini-batch when ``normalize_advantage`` is true.
_ON_POLICY = ("ppo", "a2c", "maskable_ppo", *_RECURRENT)


def _shown(value: Any, width: int = 60) -> str:
    text = " ".join(repr(value).split())
    return text if len(text) <= width else text[: width - 3] + "..."


def _parameters(function: Callable[..., Any]) -> dict[str, inspect.Parameter]:
    return {name: p for name, p in inspect.signature(function).parameters.items() if name != "self"}


def _init_keywords(cls: type) -> list[str]:
    """The named parameters of ``cls.__init__``, and of its base's where it passes ``**kwargs`` on."""
    parameters = _parameters(cls.__init__)
    names = [n for n, p in parameters.items() if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
    if any(p.kind is p.VAR_KEYWORD for p in parameters.values()) and len(cls.__mro__) > 1:
        names += [n for n in _init_keywords(cls.__mro__[1]) if n not in names]
    return names


def rules(algo: str) -> dict[str, Rule | None]:
    """The keywords ``algo`` takes that training passes on, each with its rule (``None``: unchecked, a newer SB3's)."""
    from baselines.rl.sb3_policy import algorithm_class

    own = _ALGO_RULES.get(algo.lower(), {})
    names = [n for n in _parameters(algorithm_class(algo).__init__) if n not in RESERVED]
    return {name: own.get(name, RULES.get(name)) for name in names}


def policy_rules(algo: str) -> dict[str, Rule | None]:
    """The ``policy_kwargs`` keys of the policy ``algo`` trains (``MlpPolicy``; RecurrentPPO's ``MlpLstmPolicy``).

    Each with its rule (``None``: unchecked).
    """
    from baselines.rl.sb3_policy import algorithm_class, policy_name

    policy = policy_name(algo)
    policy = algorithm_class(algo).policy_aliases[policy] if isinstance(policy, str) else policy
    names = [n for n in _init_keywords(policy) if n not in _POLICY_RESERVED]
    return {name: _NET_ARCH[algo.lower()] if name == "net_arch" else POLICY_RULES.get(name) for name in names}


def _class_name(algo: str) -> str:
    from baselines.rl.sb3_policy import ALGORITHMS

    return ALGORITHMS.get(algo.lower(), algo)


def _check(
    algo: str, params: Mapping[str, Any], known: Mapping[str, Rule | None], reserved: Mapping[str, str], where: str
) -> None:
    owner = _class_name(algo) + where
    for key, value in params.items():
        if key in reserved:
            raise ValueError(f"{key!r} is set by training, not by a hyperparameter of {owner}: {reserved[key]}")
        if key not in known:
            raise ValueError(f"{key!r} is not a hyperparameter of {owner}; choose from {', '.join(sorted(known))}")
        rule = known[key]
        if rule is not None and not rule.accepts(value):
            raise ValueError(f"hyperparameter {key}={_shown(value)} of {owner}: expected {rule.expected}")


def check_hyperparameters(algo: str, params: Mapping[str, Any], base: Mapping[str, Any] | None = None) -> None:
    """Raise one-line ``ValueError`` for a keyword ``algo`` does not take, a reserved one or a bad value.

    ``policy_kwargs`` are checked key by key against ``algo``'s ``MlpPolicy``; ``batch_size``
    (PPO, MaskablePPO) must be >= 2 while ``normalize_advantage`` is true (SB3's default), and
    ``optimize_memory_usage`` needs ``replay_buffer_kwargs={'handle_timeout_termination': False}``;
    for these pairs ``base`` (a resumed model's values) fills in keys not in ``params`` before
    SB3's defaults do. An unknown ``algo`` raises ``ValueError`` naming the offered ones.
    """
    if not isinstance(params, Mapping) or not all(isinstance(k, str) for k in params):
        raise ValueError(f"hyperparameters must map keyword names to values, got {_shown(params)}")
    algo = algo.lower()
    _check(algo, params, rules(algo), RESERVED, "")
    policy_kwargs = params.get("policy_kwargs")
    if policy_kwargs:
        _check(algo, policy_kwargs, policy_rules(algo), _POLICY_RESERVED, "'s policy_kwargs")
    _check_pairs(algo, {**(base or {}), **params})


def _value(algo: str, params: Mapping[str, Any], key: str) -> Any:
    """``params[key]``, else SB3's default for ``algo`` (``None`` if it has none)."""
    from baselines.rl.sb3_policy import algorithm_class

    if key in params:
        return params[key]
    parameter = _parameters(algorithm_class(algo).__init__).get(key)
    return None if parameter is None or parameter.default is inspect.Parameter.empty else parameter.default


def _check_pairs(algo: str, params: Mapping[str, Any]) -> None:
    """Checks of keys that depend on each other (SB3's defaults fill in the keys not given)."""
    name = _class_name(algo)
    if algo in ("ppo", "maskable_ppo", *_RECURRENT) and _value(algo, params, "normalize_advantage") is True:
        batch_size = _value(algo, params, "batch_size")
        if _is_int(batch_size) and batch_size < 2:
            raise ValueError(
                f"hyperparameter batch_size={batch_size} of {name}: expected an integer >= 2 while normalize_advantage "
                "is True (advantages are normalised per mini-batch)"
            )
    if _value(algo, params, "optimize_memory_usage") is True:
        buffer_kwargs = _value(algo, params, "replay_buffer_kwargs") or {}
        if isinstance(buffer_kwargs, Mapping) and buffer_kwargs.get("handle_timeout_termination", True) is not False:
            raise ValueError(
                f"hyperparameter optimize_memory_usage=True of {name}: expected together with "
                "replay_buffer_kwargs={'handle_timeout_termination': False} (SB3 supports only one of the two)"
            )


def check_rollout(algo: str, params: Mapping[str, Any], action_space: Any, slots: int) -> None:
    """The checks that need the env: ``use_sde`` needs continuous (Box) actions; with ``slots`` SB3 envs
    (copies × robots) an on-policy rollout must hold more than one transition while advantages are
    normalised, and ``train_freq`` in episodes needs one slot. ``params`` are the run's values
    (training's defaults included); SB3's defaults fill in the rest. Raises one-line ``ValueError``.
    """
    from gymnasium import spaces

    algo, name = algo.lower(), _class_name(algo)
    if _value(algo, params, "use_sde") is True and not isinstance(action_space, spaces.Box):
        raise ValueError(f"hyperparameter use_sde=True of {name}: expected a continuous (Box) action space, not {action_space}")
    n_steps = _value(algo, params, "n_steps")
    if algo in _ON_POLICY and _value(algo, params, "normalize_advantage") is True and _is_int(n_steps) and n_steps * slots < 2:
        raise ValueError(
            f"hyperparameter n_steps={n_steps} of {name}: with {slots} SB3 env (n_envs × robots) a rollout must hold "
            "more than one transition while normalize_advantage is True"
        )
    train_freq = _value(algo, params, "train_freq")
    if isinstance(train_freq, tuple) and train_freq[1:] == ("episode",) and slots > 1:
        raise ValueError(
            f"hyperparameter train_freq={train_freq!r} of {name}: episodes need one SB3 env, not {slots} (n_envs × robots)"
        )
