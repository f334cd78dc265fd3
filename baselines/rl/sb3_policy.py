"""``SB3Policy``: a saved Stable-Baselines3 model as a parameter-shared teamgym policy.

The model (trained with :class:`baselines.rl.sb3_env.TeamVecEnv`, or any model whose
spaces match one agent's) acts for every robot: the live agents' observations are
stacked and passed to one ``model.predict`` call (deterministic unless
``deterministic=False``); a maskable model (sb3-contrib's ``MaskablePPO``) also gets the
live agents' action masks, so it never picks a masked action. A recurrent model (sb3-contrib's
``RecurrentPPO``) carries each robot's LSTM state from step to step and starts every episode
from a zero state (:class:`baselines.rl.recurrent.AgentMemory`, reset by :meth:`SB3Policy.reset`);
a model trained on flattened motion ⊕ message actions (``comm_dim``, ``protocol_messages``) has
its flat actions decoded into the env's ``Dict`` ones (:mod:`baselines.rl.message_actions`, the
sidecar's ``message_actions``). ``python -m baselines.train``
writes a sidecar ``<model>.json`` beside every model it saves (env id, config, algorithm,
settings; the one sidecar format of :mod:`baselines.learned`, shared with RLlib checkpoints);
:func:`read_sidecar` reads it. The policy name ``sb3:PATH`` builds an :class:`SB3Policy`.

Stable-Baselines3 (and torch, and sb3-contrib for ``maskable_ppo``) are imported only when
a model is loaded, so ``import baselines`` works without them.
"""

from __future__ import annotations

import inspect
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from baselines.policy import Policy
from teamgym.envs.base import TeamEnv

__all__ = [
    "AGENT_DIR",
    "ALGORITHMS",
    "SB3Policy",
    "algorithm_class",
    "check_action_space",
    "detect_algorithm",
    "read_sidecar",
    "resolve_model",
    "shipped_agents",
]

#: algorithm name -> class name in Stable-Baselines3 (in sb3-contrib for :data:`CONTRIB_ALGORITHMS`)
ALGORITHMS: dict[str, str] = {
    "ppo": "PPO",
    "a2c": "A2C",
    "sac": "SAC",
    "td3": "TD3",
    "ddpg": "DDPG",
    "dqn": "DQN",
    "maskable_ppo": "MaskablePPO",
    "recurrent_ppo": "RecurrentPPO",
    "maskable_recurrent_ppo": "RecurrentPPO",  # with this package's masked LSTM policy (baselines.rl.masked_recurrent)
}
#: algorithms that come from sb3-contrib rather than Stable-Baselines3
CONTRIB_ALGORITHMS = frozenset({"maskable_ppo", "recurrent_ppo", "maskable_recurrent_ppo"})
#: the policy each algorithm trains (``MlpPolicy`` unless listed): RecurrentPPO's LSTM policy (:mod:`baselines.rl.recurrent`),
#: or a class (``module:Class``)
POLICIES: dict[str, str] = {
    "recurrent_ppo": "MlpLstmPolicy",
    "maskable_recurrent_ppo": "baselines.rl.masked_recurrent:MaskedLstmPolicy",
}
#: action spaces each algorithm can learn (algorithms not listed take any)
_ACTION_SPACES: dict[str, tuple[type[spaces.Space], ...]] = {
    "maskable_ppo": (spaces.Discrete, spaces.MultiDiscrete, spaces.MultiBinary),
    "maskable_recurrent_ppo": (spaces.Discrete, spaces.MultiDiscrete),
    "dqn": (spaces.Discrete,),
    "sac": (spaces.Box,),
    "td3": (spaces.Box,),
    "ddpg": (spaces.Box,),
}


#: algorithms that take action masks (``MaskablePPO.learn`` reads ``env.action_masks()``)
MASKABLE_ALGORITHMS = frozenset({"maskable_ppo", "maskable_recurrent_ppo"})


def algorithm_name(name: str) -> str:
    """The registered name of algorithm ``name``, spelled any common way (``maskable-ppo``, ``MaskablePPO``, ``PPO``)."""
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"an SB3 algorithm name is needed, got {name!r}; choose one of {sorted(ALGORITHMS)}")
    key = name.strip().lower().replace("-", "_")
    by_class: dict[str, str] = {}
    for algo, cls in ALGORITHMS.items():  # a class name means its first algorithm (RecurrentPPO: recurrent_ppo)
        by_class.setdefault(cls.lower(), algo)
    key = by_class.get(key, key)
    if key not in ALGORITHMS:
        raise ValueError(f"unknown SB3 algorithm {name!r}; choose one of {sorted(ALGORITHMS)} (hyphens work too: maskable-ppo)")
    return key


def policy_name(algo: str) -> str | type:
    """The SB3 policy ``algo`` trains: an alias (``MlpLstmPolicy`` for ``recurrent_ppo``, else ``MlpPolicy``) or a class."""
    import importlib

    name = POLICIES.get(algorithm_name(algo), "MlpPolicy")
    if ":" not in name:
        return name
    module, _, attribute = name.partition(":")
    return getattr(importlib.import_module(module), attribute)


def check_masks(algo: str, env: Any) -> None:
    """Raise ``ValueError`` if ``env``'s actions are masked and ``algo`` cannot respect masks, naming the one to use."""
    from baselines.rl.recurrent import RECURRENT_ALGORITHMS, masks_refusal

    key = algorithm_name(algo)
    action_type = getattr(env, "action_type", None)
    if key in MASKABLE_ALGORITHMS or not getattr(action_type, "has_masks", False):
        return
    if key in RECURRENT_ALGORITHMS:
        raise ValueError(masks_refusal(key, type(env).__name__, action_type.name))
    raise ValueError(
        f"{key} cannot respect the action masks of {type(env).__name__} (action_type={action_type.name!r}): it would "
        "pick masked actions, which the env refuses; use --algo maskable-ppo (sb3-contrib's MaskablePPO), "
        "or an action type without masks"
    )


def algorithm_class(name: str) -> type:
    """The class of algorithm ``name`` (``"ppo"``, ``"sac"``, ``"maskable_ppo"``: sb3-contrib's ``MaskablePPO``, ...)."""
    key = algorithm_name(name)
    if key in CONTRIB_ALGORITHMS:
        try:
            import sb3_contrib
        except ImportError:
            raise ImportError(f"{key} needs the sb3-contrib package (pip install sb3-contrib)") from None
        return getattr(sb3_contrib, ALGORITHMS[key])
    import stable_baselines3

    return getattr(stable_baselines3, ALGORITHMS[key])


def check_action_space(algo: str, action_space: spaces.Space) -> None:
    """Raise ``ValueError`` naming the algorithm and the space if ``algo`` cannot learn ``action_space``."""
    allowed = _ACTION_SPACES.get(algo.lower())
    if allowed is None or isinstance(action_space, allowed):
        return
    *first, last = [cls.__name__ for cls in allowed]
    names = f"{', '.join(first)} or {last}" if first else last
    hint = "a discrete action type (e.g. --set action_type=operator on Exploration-v0, heading on Navigation-v0)"
    if allowed == (spaces.Box,):
        hint = "a continuous action type"
    raise ValueError(f"{algo.lower()} needs {names} actions, but the env's action space is {action_space}; choose {hint}")


def _is_maskable(model: Any) -> bool:
    """Whether ``model.predict`` takes ``action_masks`` (sb3-contrib's ``MaskablePPO``)."""
    try:
        return "action_masks" in inspect.signature(model.predict).parameters
    except (TypeError, ValueError):
        return False


#: Trained agents shipped with the package: ``<name>.zip`` and its sidecar ``<name>.json``.
AGENT_DIR = Path(__file__).with_name("agents")


def shipped_agents() -> list[str]:
    """Names of the trained agents shipped in :data:`AGENT_DIR` (``sb3:<name>`` loads one)."""
    return sorted(path.stem for path in AGENT_DIR.glob("*.zip"))


def resolve_model(path: str | Path) -> Path:
    """The saved model file ``path`` names (``.zip`` may be left out), or the shipped agent of that name.

    A file at ``path`` wins over a shipped agent; ``FileNotFoundError`` if there is neither.
    """
    text = str(path)
    path = Path(path)
    if path.is_file():
        return path
    if path.name and path.suffix != ".zip" and path.with_name(path.name + ".zip").is_file():
        return path.with_name(path.name + ".zip")
    if text and "/" not in text and "\\" not in text and (AGENT_DIR / f"{path.stem}.zip").is_file():
        return AGENT_DIR / f"{path.stem}.zip"
    shipped = ", ".join(shipped_agents()) or "none"
    raise FileNotFoundError(f"no saved SB3 model at {text!r} (shipped agents: {shipped})")


def read_sidecar(path: str | Path) -> dict[str, Any] | None:
    """The settings ``baselines.train`` saved beside the model at ``path`` (``<model>.json``), or ``None``.

    In the sidecar format of :mod:`baselines.learned` (a file written before it reads the same).
    ``None`` when the model or its sidecar does not exist; ``ValueError`` naming the file (and the
    field) when the sidecar is not a JSON object or a field has the wrong type.
    """
    from baselines.learned import read_sidecar as read

    return read("sb3", path)


def detect_algorithm(path: str | Path) -> str | None:
    """The algorithm (``"ppo"``, ``"sac"``, ...) a saved model was trained with, or ``None`` if unknown.

    Uses the ``algo`` of a sidecar ``<model>.json`` written by ``baselines.train`` when
    present, else the saved policy class (SAC/TD3/DDPG/DQN and MaskablePPO have their own)
    and, for actor-critic policies, PPO-only hyperparameters to tell PPO from A2C.
    """
    path = resolve_model(path)
    try:
        algo = (read_sidecar(path) or {}).get("algo")
    except ValueError:  # a damaged sidecar: the zip still tells
        algo = None
    if isinstance(algo, str) and algo.lower() in ALGORITHMS:
        return algo.lower()
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
    except (OSError, KeyError, ValueError, zipfile.BadZipFile):
        return None
    module = str(data.get("policy_class", {}).get("__module__", ""))
    if module == "sb3_contrib.common.maskable.policies":
        return "maskable_ppo"
    if module == "sb3_contrib.common.recurrent.policies":
        return "recurrent_ppo"
    if module == "baselines.rl.masked_recurrent":
        return "maskable_recurrent_ppo"
    for algo in ("sac", "td3", "dqn"):  # DDPG saves TD3 policies and loads (for prediction) as TD3
        if module == f"stable_baselines3.{algo}.policies":
            return algo
    if module == "stable_baselines3.common.policies":
        return "ppo" if "clip_range" in data else "a2c"
    return None


def _policy_class(cls: type, path: Path) -> Any:
    """``cls``, or a :class:`~baselines.rl.agent_features.FeatureSB3Policy` maker when the sidecar records ``obs_features``."""
    from baselines.rl.agent_features import FeatureSB3Policy, ObservationFeatures

    try:
        features = ObservationFeatures.from_sidecar(read_sidecar(path))
    except ValueError as error:
        raise ValueError(f"the model's sidecar {str(path.with_suffix('.json'))!r}: {error}") from None
    if not features.active or not issubclass(cls, SB3Policy) or issubclass(cls, FeatureSB3Policy):
        return cls

    def make(env: Any, model: Any, deterministic: bool, codec: Any = None) -> FeatureSB3Policy:
        return FeatureSB3Policy(env, model, deterministic, codec=codec, features=features)

    return make


class SB3Policy(Policy):
    """Actions of one Stable-Baselines3 model shared by every robot.

    ``deterministic=True`` (the default) takes the model's most likely action. With
    ``deterministic=False`` actions are sampled, and :meth:`reset` reseeds Python's, numpy's
    and torch's global generators (which SB3 samples from) and the model's action space
    with the episode's seed, so a stochastic evaluation is repeatable and does not depend on
    how episodes are spread over worker processes.
    """

    name = "sb3"
    native_actions = False  # the model acts in the space it was trained on

    def __init__(self, env: TeamEnv, model: Any, deterministic: bool = True, codec: Any = None) -> None:
        from baselines.rl.recurrent import AgentMemory, is_recurrent

        super().__init__(env)
        self.model = model
        self.deterministic = deterministic
        self.algo: str | None = None
        self.path: Path | None = None
        self.maskable = _is_maskable(model)
        #: The :class:`~baselines.rl.message_actions.MessageCodec` of a model trained on flattened
        #: motion ⊕ message actions (its sidecar's ``message_actions``), else ``None``.
        self.codec = codec
        #: Each robot's LSTM state through the episode (a recurrent model), else ``None``.
        self.memory = AgentMemory(model) if is_recurrent(model) else None
        self._check_spaces()

    @classmethod
    def load(
        cls, path: str | Path, env: TeamEnv, algo: str | None = None, device: str = "cpu", deterministic: bool = True
    ) -> SB3Policy:
        """Load the model saved at ``path`` (``.zip``) for ``env``.

        ``algo`` (``"ppo"``, ``"a2c"``, ``"sac"``, ``"td3"``, ``"ddpg"``, ``"dqn"``,
        ``"maskable_ppo"``) is detected from the file when omitted (see :func:`detect_algorithm`); if detection
        fails every algorithm is tried in turn.
        """
        path = resolve_model(path)
        algo = algo or detect_algorithm(path)
        codec = _codec_of(path, env)
        candidates = [algo] if algo else list(ALGORITHMS)
        errors = []
        for name in candidates:
            try:
                model = algorithm_class(name).load(str(path), device=device)
            except Exception as error:  # noqa: BLE001 - try the next algorithm
                errors.append(f"{name}: {error}")
                continue
            try:
                policy = _policy_class(cls, path)(env, model, deterministic=deterministic, codec=codec)
            except ValueError as error:
                sidecar = path.with_suffix(".json")
                hint = f"; the training settings are in {str(sidecar)!r}" if sidecar.is_file() else ""
                raise ValueError(f"{error}{hint}") from None
            policy.algo = name
            policy.path = path
            return policy
        raise ValueError(f"could not load SB3 model {str(path)!r} ({'; '.join(errors)})")

    def reset(self, seed: int | None = None) -> None:
        """Start an episode; a stochastic policy reseeds the generators SB3 samples from (see the class docstring)."""
        super().reset(seed)
        if self.memory is not None:  # every robot's LSTM starts the episode from a zero state
            self.memory.reset()
        if not self.deterministic and seed is not None:
            from stable_baselines3.common.utils import set_random_seed

            set_random_seed(int(seed))
            self.model.action_space.seed(int(seed))

    def _input_space(self, agent: str) -> spaces.Space:
        """The observation space the model must take: the env's (a subclass may widen it)."""
        return self.env.observation_space(agent)

    def _check_spaces(self) -> None:
        env = self.env
        if not env.possible_agents:
            return
        agent = env.possible_agents[0]
        env_obs, env_act = self._input_space(agent), env.action_space(agent)
        if self.codec is not None:
            env_act = self.codec.space
        model_obs, model_act = self.model.observation_space, self.model.action_space
        if self.memory is not None and self.memory.mask_width and getattr(env_obs, "shape", None) is not None:
            env_obs = spaces.Box(-np.inf, np.inf, (env_obs.shape[0] + self.memory.mask_width,))  # the masks follow
        if getattr(model_obs, "shape", None) != getattr(env_obs, "shape", None):
            raise ValueError(
                f"the SB3 model expects observations of shape {getattr(model_obs, 'shape', None)}, "
                f"but the env's are {getattr(env_obs, 'shape', None)} (different env or config?)"
            )
        if type(model_act) is not type(env_act) or getattr(model_act, "shape", None) != getattr(env_act, "shape", None):
            raise ValueError(f"the SB3 model's action space {model_act} does not match the env's {env_act}")
        if isinstance(env_act, spaces.Discrete) and model_act.n != env_act.n:
            raise ValueError(f"the SB3 model's action space {model_act} does not match the env's {env_act}")

    def act(self, observations: dict[str, np.ndarray], infos: dict[str, dict[str, Any]] | None = None) -> dict[str, Any]:
        """Actions for every agent in ``observations`` from one batched ``model.predict`` call."""
        agents = list(observations)
        if not agents:
            return {}
        batch = np.stack([np.asarray(observations[a], dtype=np.float32) for a in agents])
        if self.memory is not None:
            masks = self._masks(agents) if self.memory.mask_width else None
            actions = self.memory.predict(agents, batch, deterministic=self.deterministic, masks=masks)
        elif self.maskable:
            actions, _ = self.model.predict(batch, deterministic=self.deterministic, action_masks=self._masks(agents))
        else:
            actions, _ = self.model.predict(batch, deterministic=self.deterministic)
        space = self.env.action_space(agents[0])
        out: dict[str, Any] = {}
        for i, agent in enumerate(agents):
            if self.codec is not None:
                out[agent] = self.codec.decode(actions[i])
            elif isinstance(space, spaces.Discrete):
                out[agent] = int(np.asarray(actions[i]).reshape(()))
            elif isinstance(space, spaces.Box):
                out[agent] = np.clip(np.asarray(actions[i], dtype=space.dtype).reshape(space.shape), space.low, space.high)
            else:
                out[agent] = actions[i]
        return out

    def _masks(self, agents: list[str]) -> np.ndarray | None:
        """The env's action masks of ``agents``, one bool row each, or ``None`` when the env gives none."""
        masks = self.env.action_masks() if hasattr(self.env, "action_masks") else {}
        if not all(a in masks for a in agents):
            return None
        if self.codec is not None:
            masks = {a: self.codec.mask(masks[a]) for a in agents}
        return np.stack([np.asarray(masks[a], dtype=bool).reshape(-1) for a in agents])


def _codec_of(path: Path, env: TeamEnv) -> Any:
    """The message codec a model's sidecar records (``message_actions``) for ``env``, else ``None``."""
    from baselines.rl.message_actions import MessageCodec, MessageSettings

    try:
        record = (read_sidecar(path) or {}).get("message_actions")
    except ValueError:  # a damaged sidecar: the model is loaded as without one
        record = None
    if record is None or not env.possible_agents:
        return None
    space = env.action_space(env.possible_agents[0])
    try:
        return MessageCodec(space, MessageSettings.from_record(record))
    except ValueError as error:
        raise ValueError(
            f"the SB3 model {str(path)!r} acts with motion ⊕ message actions (its sidecar's message_actions), which do not fit "
            f"the env's action space {space}: {error}"
        ) from None
