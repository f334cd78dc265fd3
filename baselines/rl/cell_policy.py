"""A per-cell actor for go-to-cell actions over grid observations (``--net cells``).

Foraging-v0's ``goto_cell`` action picks one of the world-model grid's ``ny × nx`` cells, and
with ``observe_world_model`` / ``observe_novelty`` the observation holds layers over that same
grid. An MLP over the flat observation has to learn a separate weight for every (input cell,
output cell) pair to say "go to the best cell of a field"; paper 002's planner computes that
field cell by cell (section 4.3: novelty, distance, turning and teammate terms of the search
field; the target's cell for an approach). :class:`CellExtractor` gives the policy the same
shape: every cell gets the grid layers at that cell, its own coordinates, its offset from the
robot's estimated pose (distance and bearing relative to the heading) and the robot's other
readings (broadcast to every cell); 1 × 1 convolutions mix them per cell, dilated 3 × 3
convolutions with a pooled team summary add neighbourhood and global context, and one 1 × 1
convolution scores every cell: those scores are the action logits (flat index ``gy * nx + gx``,
the env's cell index). The critic reads pooled cell features and the readings.

* :func:`grid_layout`: where the grid layers, the readings and the pose sit in the env's flat
  observation (from its :class:`~teamgym.envs.spaces.ObservationLayout`);
* :class:`CellExtractor`: SB3's ``mlp_extractor`` slot (``latent_dim_pi`` = the number of cells);
* :class:`CellPolicy` (PPO/A2C) and :class:`MaskableCellPolicy` (MaskablePPO): the actor-critic
  policies with that extractor (keyword ``layout``); the action head is the identity, so a cell's
  logit is its score. Saved models record the class and ``layout`` and load with the
  algorithm's plain ``load``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.policies import ActorCriticPolicy
from torch import nn

__all__ = ["CellExtractor", "CellPolicy", "MaskableCellPolicy", "NETS", "cell_policy_class", "grid_layout"]

#: ``--net`` choices: SB3's MLP (default) or the per-cell actor of this module.
NETS = ("mlp", "cells")
#: names of the pose field (x, y, θ) the egocentric channels are computed from
POSE_FIELDS = ("pose_estimate", "pose")


def grid_layout(env: Any) -> dict[str, Any]:
    """Where the go-to-cell grid sits in ``env``'s flat observation, as plain data (a ``policy_kwargs`` value).

    ``env`` is a teamgym env whose action is one of ``n`` cells and whose observation layout
    holds fields over an ``(ny, nx)`` grid with ``ny * nx == n`` (e.g. Foraging-v0's
    ``world_model`` and ``novelty``). Returns ``grid_shape`` ``[ny, nx]``, ``cell_size`` (m, for
    the egocentric channels; cell ``(gx, gy)`` is centred at ``((gx + ½), (gy + ½)) · cell_size``),
    ``grids`` (``[start, channels]`` per grid field), ``pose`` (start of ``(x, y, θ)``, or ``None``)
    and ``size`` (the observation's width, a record). ``ValueError`` of one line otherwise.
    """
    from gymnasium import spaces

    base = getattr(env, "unwrapped", env)
    agent = base.possible_agents[0]
    action_space = base.action_space(agent)
    if not isinstance(action_space, spaces.Discrete):
        raise ValueError(f"--net cells needs a go-to-cell (Discrete) action, e.g. Foraging-v0's goto_cell; got {action_space}")
    layout = getattr(base, "layout", None)
    if layout is None or getattr(base.config, "obs_format", "flat") != "flat":
        raise ValueError("--net cells needs flat observations with a named layout (obs_format='flat')")
    n = int(action_space.n)
    grids, shape = [], None
    for field in layout.fields:
        if len(field.shape) >= 2 and int(np.prod(field.shape[-2:])) == n:
            shape = shape or [int(field.shape[-2]), int(field.shape[-1])]
            if [int(field.shape[-2]), int(field.shape[-1])] != shape:
                continue
            channels = int(np.prod(field.shape[:-2])) if len(field.shape) > 2 else 1
            grids.append([int(layout.slices[field.name].start), channels])
    if not grids:
        raise ValueError(
            f"--net cells needs grid layers in the observation over the {n} action cells "
            f"(Foraging-v0: --set observe_world_model=True and/or observe_novelty=True)"
        )
    pose = next((int(layout.slices[f].start) for f in POSE_FIELDS if f in layout.slices), None)
    grid = getattr(base, "grid", None)
    cell_size = float(getattr(grid, "cell_size", 1.0))
    return {"grid_shape": shape, "grids": grids, "pose": pose, "cell_size": cell_size, "size": int(layout.size)}


class _Block(nn.Module):
    """A residual block: dilated 3 × 3 convolution plus a pooled (team-wide) summary broadcast back to every cell."""

    def __init__(self, channels: int, dilation: int) -> None:
        super().__init__()
        self.conv = nn.Conv2d(channels, channels, 3, padding=dilation, dilation=dilation)
        self.pooled = nn.Linear(2 * channels, channels)

    def forward(self, h: th.Tensor) -> th.Tensor:
        summary = th.cat([h.mean(dim=(2, 3)), h.amax(dim=(2, 3))], dim=1)
        return h + th.relu(self.conv(h) + self.pooled(summary)[:, :, None, None])


class CellExtractor(nn.Module):
    """SB3 ``mlp_extractor``: per-cell scores as the actor latent, pooled features as the critic latent.

    ``feature_dim`` may exceed the layout's ``size`` (features appended after the env's
    observation, e.g. ``--agent-id``): the extra inputs join the broadcast readings.
    """

    def __init__(
        self,
        feature_dim: int,
        layout: Mapping[str, Any],
        channels: int = 32,
        dilations: tuple[int, ...] = (1, 2, 4),
        value_dim: int = 64,
    ) -> None:
        super().__init__()
        ny, nx = (int(v) for v in layout["grid_shape"])
        self.ny, self.nx = ny, nx
        grid_index = np.concatenate([np.arange(start, start + c * ny * nx) for start, c in layout["grids"]])
        if grid_index.max() >= feature_dim:
            raise ValueError(f"the grid layout reaches input {int(grid_index.max())}, the features have {feature_dim}")
        readings = np.setdiff1d(np.arange(feature_dim), grid_index)
        self.register_buffer("grid_index", th.as_tensor(grid_index, dtype=th.long), persistent=False)
        self.register_buffer("reading_index", th.as_tensor(readings, dtype=th.long), persistent=False)
        self.n_grid = sum(c for _, c in layout["grids"])
        self.pose = layout.get("pose")
        cell = float(layout.get("cell_size", 1.0))
        gy, gx = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
        centres = np.stack([(gx + 0.5) * cell, (gy + 0.5) * cell])  # (2, ny, nx), m
        self.register_buffer("centres", th.as_tensor(centres, dtype=th.float32), persistent=False)
        self.scale = float(max(nx, ny) * cell)  # normalises offsets and distances to about [-1, 1]
        coords = np.stack([gx / max(1, nx - 1), gy / max(1, ny - 1)]) * 2.0 - 1.0
        self.register_buffer("coords", th.as_tensor(coords, dtype=th.float32), persistent=False)
        ego = 5 if self.pose is not None else 0  # dx, dy, distance, cos and sin of the bearing from the heading
        self.readings_in = nn.Linear(len(readings), channels)
        self.cells_in = nn.Conv2d(self.n_grid + 2 + ego, channels, 1)
        self.per_cell = nn.Conv2d(channels, channels, 1)
        self.blocks = nn.ModuleList(_Block(channels, d) for d in dilations)
        self.score = nn.Conv2d(channels, 1, 1)
        self.value = nn.Sequential(nn.Linear(3 * channels, value_dim), nn.Tanh(), nn.Linear(value_dim, value_dim), nn.Tanh())
        self.latent_dim_pi = ny * nx
        self.latent_dim_vf = value_dim

    def _ego(self, features: th.Tensor) -> th.Tensor:
        pose = features[:, self.pose : self.pose + 3]
        dx = self.centres[0][None] - pose[:, 0, None, None]
        dy = self.centres[1][None] - pose[:, 1, None, None]
        bearing = th.atan2(dy, dx) - pose[:, 2, None, None]
        distance = th.sqrt(dx * dx + dy * dy)
        return th.stack([dx / self.scale, dy / self.scale, distance / self.scale, th.cos(bearing), th.sin(bearing)], 1)

    def _trunk(self, features: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        batch = features.shape[0]
        grid = features[:, self.grid_index].reshape(batch, self.n_grid, self.ny, self.nx)
        readings = th.relu(self.readings_in(features[:, self.reading_index]))
        parts = [grid, self.coords.expand(batch, -1, -1, -1)]
        if self.pose is not None:
            parts.append(self._ego(features))
        h = th.relu(self.cells_in(th.cat(parts, 1)) + readings[:, :, None, None])
        h = th.relu(self.per_cell(h))
        for block in self.blocks:
            h = block(h)
        return h, readings

    def _scores(self, h: th.Tensor) -> th.Tensor:
        return self.score(h).flatten(1)  # (batch, ny * nx): index gy * nx + gx

    def _value(self, h: th.Tensor, readings: th.Tensor) -> th.Tensor:
        return self.value(th.cat([h.mean(dim=(2, 3)), h.amax(dim=(2, 3)), readings], 1))

    def forward_actor(self, features: th.Tensor) -> th.Tensor:
        return self._scores(self._trunk(features)[0])

    def forward_critic(self, features: th.Tensor) -> th.Tensor:
        return self._value(*self._trunk(features))

    def forward(self, features: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        h, readings = self._trunk(features)
        return self._scores(h), self._value(h, readings)


class _Cells:
    """Mixin of an actor-critic policy: a :class:`CellExtractor` (keyword ``layout``) and an identity action head."""

    def __init__(self, *args: Any, layout: Mapping[str, Any], cell_channels: int = 32, **kwargs: Any) -> None:
        self.layout, self.cell_channels = dict(layout), int(cell_channels)
        kwargs.setdefault("ortho_init", False)  # the per-cell scores start near 0: a near-uniform first policy
        super().__init__(*args, **kwargs)

    def _build_mlp_extractor(self) -> None:
        self.mlp_extractor = CellExtractor(self.features_dim, self.layout, channels=self.cell_channels)

    def _build(self, lr_schedule: Any) -> None:
        super()._build(lr_schedule)
        n = int(self.action_space.n)
        if n != self.mlp_extractor.latent_dim_pi:
            raise ValueError(f"--net cells: the grid has {self.mlp_extractor.latent_dim_pi} cells, the action {n}")
        self.action_net = nn.Identity()  # a cell's score is its logit
        self.optimizer = self.optimizer_class(self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return {**super()._get_constructor_parameters(), "layout": self.layout, "cell_channels": self.cell_channels}


class CellPolicy(_Cells, ActorCriticPolicy):
    """PPO/A2C policy whose action logits are per-cell scores (:class:`CellExtractor`)."""


try:
    from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy
except ImportError:  # sb3-contrib is optional: MaskablePPO (and this class) need it
    pass
else:

    class MaskableCellPolicy(_Cells, MaskableActorCriticPolicy):
        """MaskablePPO policy whose action logits are per-cell scores (:class:`CellExtractor`)."""


def cell_policy_class(algo: str) -> type:
    """The per-cell policy class of ``algo`` (``maskable_ppo``, ``ppo`` or ``a2c``)."""
    if algo == "maskable_ppo":
        return MaskableCellPolicy
    if algo in ("ppo", "a2c"):
        return CellPolicy
    raise ValueError(f"--net cells needs ppo, a2c or maskable_ppo (a Discrete cell action), not {algo}")
