"""Normal-form game solving for the game-theoretic baselines (paper 001, section 5).

See :mod:`baselines.game.solver`.
"""

from baselines.game.solver import (
    BRANCHES,
    ArbiterResult,
    arbiter_cost,
    arbitrate,
    minmax_strategies,
    pure_nash_equilibria,
)

__all__ = [
    "BRANCHES",
    "ArbiterResult",
    "arbiter_cost",
    "arbitrate",
    "minmax_strategies",
    "pure_nash_equilibria",
]
