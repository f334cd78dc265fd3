"""Training-time tools of :mod:`baselines.rl.train`: a timestep schedule, held-out evaluation and its CSV log.

* :class:`EveryTimesteps`: an SB3 callback that calls a function once the model's
  timestep counter has crossed a multiple of ``every``, between rollouts (optionally also
  at the start and end of training); checkpoints and periodic evaluations use it.
* :func:`evaluate_model`: the current model on held-out seeds through the episode loop of
  ``python -m baselines.evaluate`` (:func:`baselines.episode.run_episode` with an
  :class:`~baselines.rl.sb3_policy.SB3Policy`, aggregated by
  :func:`baselines.summary.summarise`), so its numbers equal those of
  ``python -m baselines.evaluate --policy sb3:MODEL --seed S --episodes K`` on the saved model.
* :class:`EvalLog`: the rows of those evaluations, kept in a CSV file (columns
  ``timesteps, success_rate, mean_return, mean_episode_length, mean_<metric>...``).
* :class:`PaddingShareLog`: logs ``rollout/padding_share``, the share of slot-steps in which
  a :class:`~baselines.rl.sb3_env.TeamVecEnv` slot waited for a robot (padding).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback

__all__ = ["EvalLog", "EveryTimesteps", "PaddingShareLog", "evaluate_model", "is_better"]


class PaddingShareLog(BaseCallback):
    """Record the VecEnv's ``padding_share`` (since it was built) as ``rollout/padding_share`` after every rollout."""

    def __init__(self) -> None:
        super().__init__()
        self.padding_share: float | None = None

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        share = getattr(self.training_env, "padding_share", None)
        if share is not None:
            self.padding_share = float(share)
            self.logger.record("rollout/padding_share", self.padding_share)


class EveryTimesteps(BaseCallback):
    """Call ``fn(num_timesteps)`` once the model's timestep counter has crossed a multiple of ``every``.

    The check runs between rollouts (at the start of each, so after the update that
    followed the previous one) and at the end of training: the model passed on is the one
    trained on exactly ``num_timesteps`` transitions, as a model saved then would be. So a
    call happens at the first rollout boundary at or past each multiple (several multiples
    crossed by one rollout give one call). The schedule continues from the model's counter
    (a resumed model keeps its multiples). ``at_start``: also call once before training;
    ``at_end``: also call at the end of training unless the last call was at that timestep.
    """

    def __init__(self, every: int, fn: Callable[[int], None], *, at_start: bool = False, at_end: bool = False) -> None:
        super().__init__()
        if every < 1:
            raise ValueError(f"every must be >= 1, got {every}")
        self.every = int(every)
        self.fn = fn
        self.at_start = at_start
        self.at_end = at_end
        self.last: int | None = None

    def _call(self) -> None:
        self.last = self.num_timesteps
        self.fn(self.num_timesteps)

    def _crossed(self) -> bool:
        assert self.last is not None
        return self.num_timesteps // self.every > self.last // self.every

    def _on_training_start(self) -> None:
        self.last = self.num_timesteps
        if self.at_start:
            self._call()

    def _on_rollout_start(self) -> None:
        if self._crossed():
            self._call()

    def _on_step(self) -> bool:
        return True

    def _on_training_end(self) -> None:
        if self._crossed() or (self.at_end and self.last != self.num_timesteps):
            self._call()


def evaluate_model(
    model: Any, env: Any, episodes: int, seed: int, deterministic: bool = True, features: Any = None
) -> dict[str, Any]:
    """:func:`baselines.summary.summarise` of ``episodes`` episodes (seeds ``seed, seed+1, ...``) of ``model`` on ``env``.

    The model acts for every robot through an :class:`SB3Policy`, episode by episode with
    :func:`baselines.episode.run_episode`, exactly as ``baselines.evaluate`` runs a saved model.
    """
    from baselines.episode import run_episode
    from baselines.rl.sb3_policy import SB3Policy
    from baselines.summary import summarise

    if features is not None and features.active:  # widened observations (baselines.rl.agent_features)
        from baselines.rl.agent_features import FeatureSB3Policy

        policy: SB3Policy = FeatureSB3Policy(env, model, deterministic, features=features)
    else:
        policy = SB3Policy(env, model, deterministic=deterministic)
    results = [run_episode(env, policy, seed + i, record_trajectories=False) for i in range(episodes)]
    return summarise(results)


def _number(value: Any) -> float:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else math.nan


def is_better(summary: Mapping[str, Any], best: Mapping[str, Any] | None) -> bool:
    """Whether ``summary`` beats ``best``: a higher success rate, or an equal one with a higher mean return."""
    if best is None:
        return True

    def key(s: Mapping[str, Any]) -> tuple[float, float]:
        rate, ret = _number(s.get("success_rate")), _number(s.get("mean_return"))
        return (-math.inf if math.isnan(rate) else rate, -math.inf if math.isnan(ret) else ret)

    return key(summary) > key(best)


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return str(int(value))
    if isinstance(value, int):
        return str(value)
    return repr(float(value))


class EvalLog:
    """Rows of periodic evaluations in the CSV file ``path`` (rewritten whole after every row).

    Columns: ``timesteps, success_rate, mean_return, mean_episode_length`` and the
    ``mean_<metric>`` columns of :func:`baselines.summary.summarise` in first-seen order
    (``mean_success``, equal to ``success_rate``, is left out). A metric first reported in a
    later evaluation (such as ``time_to_goal`` once a robot arrives) adds a column; earlier
    rows leave it empty. Non-finite values are written as ``inf``/``nan``.
    """

    BASE = ("timesteps", "success_rate", "mean_return", "mean_episode_length")

    def __init__(self, path: str | Path, rows: Sequence[Mapping[str, Any]] = ()) -> None:
        self.path = Path(path)
        self.rows: list[dict[str, Any]] = [dict(r) for r in rows]
        self.columns: list[str] = list(self.BASE)
        for row in self.rows:
            self._add_columns(row)

    def _add_columns(self, row: Mapping[str, Any]) -> None:
        self.columns += [k for k in row if k not in self.columns]

    @classmethod
    def read_rows(cls, path: str | Path) -> list[dict[str, Any]]:
        """The rows of an eval CSV (``timesteps`` as ``int``, the rest as ``float``; empty cells left out)."""
        with Path(path).open(newline="") as handle:
            reader = csv.DictReader(handle)
            if reader.fieldnames is None or "timesteps" not in reader.fieldnames:
                raise ValueError(f"{str(path)!r} is not an eval CSV (no 'timesteps' column)")
            rows = []
            for record in reader:
                row: dict[str, Any] = {"timesteps": int(float(record["timesteps"]))}
                row.update({k: float(v) for k, v in record.items() if k != "timesteps" and k is not None and v not in ("", None)})
                rows.append(row)
        return rows

    @classmethod
    def continued(cls, path: str | Path, upto: int) -> EvalLog:
        """The log at ``path`` with its rows after timestep ``upto`` dropped (a resumed run replaces them)."""
        path = Path(path)
        rows = cls.read_rows(path) if path.is_file() else []
        return cls(path, [r for r in rows if r["timesteps"] <= upto])

    @staticmethod
    def row_of(timesteps: int, summary: Mapping[str, Any]) -> dict[str, Any]:
        """One CSV row from a :func:`summarise` result."""
        row: dict[str, Any] = {"timesteps": int(timesteps)}
        for key in EvalLog.BASE[1:]:
            row[key] = _number(summary.get(key))
        for key, value in summary.items():
            if key.startswith("mean_") and key not in row and key != "mean_success":
                row[key] = _number(value)
        return row

    def append(self, timesteps: int, summary: Mapping[str, Any]) -> dict[str, Any]:
        """Add the row of one evaluation and rewrite the file; returns the row."""
        row = self.row_of(timesteps, summary)
        self.rows.append(row)
        self._add_columns(row)
        self.write()
        return row

    def write(self) -> Path:
        """Write every row to :attr:`path`."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self.path.open("w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(self.columns)
            for row in self.rows:
                writer.writerow([_cell(row.get(c)) for c in self.columns])
        return self.path
