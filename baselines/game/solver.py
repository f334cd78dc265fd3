"""Pure-strategy solver for N-player normal-form games with losses (paper 001, section 5).

A game with N players, player i having K_i actions, is given by one array ``losses`` of shape
``(N, K_1, ..., K_N)``: ``losses[i][d_1, ..., d_N]`` is player i's loss I_i(d_1, ..., d_N)
for the joint action (d_1, ..., d_N). Every player *minimises* its own loss.

* :func:`pure_nash_equilibria` -- all pure Nash equilibria, eq. (27);
* :func:`minmax_strategies` -- the min-max (safety) joint actions, eq. (28);
* :func:`arbiter_cost` -- the arbiter's performance index C, eq. (30);
* :func:`arbitrate` -- the arbitration of section 5.1 / Fig. 4: Nash set if non-empty, else
  min-max set; a unique candidate is taken as is, several are resolved by eq. (31).

Everything is vectorised over the joint-action tensor (at most the N players are looped
over), so a 5-player x 5-action or a 3-player x 17-action game is solved in tens of
microseconds (``benchmarks/bench_game_solver.py``). Small games with equal action counts are
solved on one gathered (N, K, K**(N-1)) copy of the losses, the rest player by player.

Comparisons are exact by default, and ties count: eq. (27) uses <=, so a joint action at
which some player is indifferent to deviating is an equilibrium. ``tol >= 0`` loosens eqs.
(27) and (28) by an absolute amount (see each function); ``tol = 0`` gives the paper's
definitions verbatim. Losses must be finite (NaN or +-inf raise ValueError).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

__all__ = [
    "BRANCHES",
    "ArbiterResult",
    "arbiter_cost",
    "arbitrate",
    "minmax_strategies",
    "pure_nash_equilibria",
]

#: The four exits of the arbitration algorithm of Fig. 4 (which set, and whether it had one member).
BRANCHES = ("nash-unique", "nash-arbiter", "minmax-unique", "minmax-arbiter")

Selection = Literal["arbiter", "first"]


def _as_losses(losses: npt.ArrayLike, tol: float) -> np.ndarray:
    """Validate a loss tensor; return it as a C-contiguous float64 array (no copy if it already is one)."""
    arr = np.ascontiguousarray(losses, dtype=np.float64)
    if arr.ndim < 2:
        raise ValueError(f"losses must have shape (N, K_1, ..., K_N) with N >= 1; got an array of shape {arr.shape}")
    n = arr.shape[0]
    if arr.ndim != n + 1:
        raise ValueError(
            f"losses must have shape (N, K_1, ..., K_N): the first axis (N = {n} players) must be followed by "
            f"one action axis per player, i.e. {n + 1} dimensions; got shape {arr.shape} ({arr.ndim} dimensions)"
        )
    if 0 in arr.shape:
        raise ValueError(f"every player needs at least one action; got losses of shape {arr.shape}")
    if not np.isfinite(arr).all():
        what = "NaN" if np.isnan(arr).any() else "infinite"
        raise ValueError(f"losses must be finite; got {what} values")
    if not (math.isfinite(tol) and tol >= 0.0):
        raise ValueError(f"tol must be a finite number >= 0; got {tol!r}")
    return arr


#: Below this many contiguous elements after a player's axis, reducing along that axis in place
#: runs numpy's inner loop on very short rows; a transposed contiguous copy is much faster.
_SHORT_RUN = 64
#: Up to this many joint actions, the copy also pays off for the max over d_{-i} of eq. (28).
_SMALL_GAME = 1 << 16
#: Games with equal action counts and at most min(_STACK_LIMIT, _STACK_PER_PLAYER * N) loss
#: entries (N * prod K_i) use :func:`_scan_stacked` (fewer numpy calls, but gathers that are
#: slower per element and fall off a cache cliff above ~16k entries); bigger or unequal games
#: use :func:`_scan_loop`. Measured crossover, not a correctness matter: both give equal results.
_STACK_LIMIT = 1 << 14
_STACK_PER_PLAYER = 4000


@functools.lru_cache(maxsize=32)
def _stack_tables(n: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Gather tables for an N-player game with K actions each (M = K**N joint actions, R = M / K).

    ``gather`` (N*M,): ``losses.ravel()[gather]`` reshaped (N, K, R) holds player i's losses with
    its own action first and the others' joint action d_{-i} (C order, index r) second.
    ``scatter`` (N*M,): for player i and joint action d, the flat index i*R + r(d_{-i}) into an
    (N, R) array, to read a per-d_{-i} quantity back in the joint-action layout.
    """
    m = k**n
    r = m // k
    idx = np.arange(n * m).reshape((n,) + (k,) * n)
    gather = np.stack([np.moveaxis(idx[i], i, 0).reshape(k, r) for i in range(n)]).ravel()
    others = np.arange(r).reshape((k,) * (n - 1))
    scatter = np.stack([np.broadcast_to(np.expand_dims(others, i), (k,) * n).ravel() + i * r for i in range(n)]).ravel()
    gather.flags.writeable = False
    scatter.flags.writeable = False
    return gather, scatter


def _scan_stacked(arr: np.ndarray, tol: float, nash: bool, safety: bool) -> tuple[np.ndarray | None, np.ndarray | None]:
    """:func:`_scan` for equal action counts: all players at once on an (N, K, R) gathered copy."""
    n = arr.shape[0]
    k = arr.shape[1]
    m = arr[0].size
    gather, scatter = _stack_tables(n, k)
    stacked = arr.reshape(-1).take(gather).reshape(n, k, m // k)
    mask = worst = None
    if nash:
        best = stacked.min(axis=1)  # (N, R): best response value of player i to each d_{-i}
        if tol:
            best += tol
        ok = np.less_equal(arr.reshape(n, m), best.reshape(-1).take(scatter).reshape(n, m))
        mask = ok.all(axis=0) if n > 1 else ok[0]
    if safety:
        worst = stacked.max(axis=2)  # (N, K): max over d_{-i} of I_i(d_i, d_{-i})
    return mask, worst


def _scan(arr: np.ndarray, tol: float, nash: bool, safety: bool) -> tuple[np.ndarray | None, np.ndarray | None]:
    """One pass over the losses computing what eqs. (27) and (28) need.

    Returns:
        ``mask``: flat boolean array over the joint actions (C order), True where eq. (27) holds
        (None unless ``nash``); ``safe``: boolean (N, max K_i) array, ``safe[i, d]`` True when d is
        a safety action of player i in eq. (28) (padding columns False; None unless ``safety``).
    """
    n = arr.shape[0]
    ks = arr.shape[1:]
    if n > 1 and arr.size <= min(_STACK_LIMIT, _STACK_PER_PLAYER * n) and ks.count(ks[0]) == n:
        mask, worst = _scan_stacked(arr, tol, nash, safety)
    else:
        mask, worst = _scan_loop(arr, tol, nash, safety)
    safe = None
    if safety:
        thresh = worst.min(axis=1, keepdims=True)
        if tol:
            thresh += tol
        safe = worst <= thresh
    return mask, safe


def _scan_loop(arr: np.ndarray, tol: float, nash: bool, safety: bool) -> tuple[np.ndarray | None, np.ndarray | None]:
    """:func:`_scan` player by player; ``worst`` is (N, max K_i), padded with +inf.

    Player i's loss tensor is viewed as a C-contiguous (A, K_i, B) array (A = prod K_j, j < i;
    B = prod K_j, j > i), so every per-player operation is a 3-D one whatever N is.
    """
    n = arr.shape[0]
    ks = arr.shape[1:]
    m = arr[0].size
    flat = arr.reshape(n, m)
    mask = buf = worst = None
    if nash:
        mask = np.empty(m, dtype=bool)
        buf = np.empty(m, dtype=bool) if n > 1 else mask
    if safety:
        worst = np.full((n, max(ks)), np.inf)  # worst[i, d]: max over d_{-i} of I_i(d, d_{-i})
    a = 1
    for i, k in enumerate(ks):
        b = m // (a * k)
        v = flat[i].reshape(a, k, b)
        # (K_i, A*B) layout: player i's action first, everything else contiguous behind it.
        transpose = a > 1 and (b < _SHORT_RUN or (safety and m <= _SMALL_GAME))
        t = np.ascontiguousarray(v.transpose(1, 0, 2)).reshape(k, a * b) if transpose else None
        if nash:
            if t is not None:
                best = t.min(axis=0).reshape(a, 1, b)
            elif a == 1:
                best = v[0].min(axis=0).reshape(1, 1, b)
            else:
                best = v.min(axis=1, keepdims=True)
            if tol:
                best += tol
            out = mask if i == 0 else buf
            np.less_equal(v, best, out=out.reshape(a, k, b))
            if i:
                mask &= buf
        if safety:
            row = worst[i, :k]
            if t is not None:
                t.max(axis=1, out=row)
            elif a == 1:
                v[0].max(axis=1, out=row)
            else:
                v.max(axis=2).max(axis=0, out=row)
        a *= k
    return mask, worst


def _safety_sets(safe: np.ndarray) -> list[npt.NDArray[np.intp]]:
    """Each player's sorted safety-action indices from the (N, max K_i) mask of :func:`_scan`."""
    return [np.flatnonzero(row) for row in safe]


def _nash_set(mask: np.ndarray, ks: tuple[int, ...]) -> npt.NDArray[np.intp]:
    """Joint action indices (P, N), lexicographic order, of the True entries of a flat mask."""
    flat_idx = np.flatnonzero(mask)  # ascending flat (C-order) index = lexicographic order
    if flat_idx.size == 0:
        return np.empty((0, len(ks)), dtype=np.intp)
    return np.array(np.unravel_index(flat_idx, ks), dtype=np.intp).T  # (much cheaper than np.argwhere)


def pure_nash_equilibria(losses: npt.ArrayLike, *, tol: float = 0.0) -> npt.NDArray[np.intp]:
    """All pure Nash equilibria of a loss game, eq. (27).

    A joint action d0 = (d_10, ..., d_N0) is an equilibrium when no player can strictly lower its
    own loss by deviating alone: for every player i and every action d_i,
    ``I_i(d0) <= I_i(d_i, d0_{-i}) + tol``, i.e. ``I_i(d0) <= min_{d_i} I_i(d_i, d0_{-i}) + tol``.
    Ties count as equilibria (the inequality in eq. (27) is not strict), so e.g. a game with
    constant losses has every joint action as an equilibrium.

    Args:
        losses: array of shape (N, K_1, ..., K_N); ``losses[i]`` is player i's loss I_i for
            every joint action. Must be finite.
        tol: absolute slack (>= 0) on eq. (27). The default 0 is the exact definition; a small
            positive value also accepts joint actions whose deviation gain is at most ``tol``
            (useful when losses carry floating-point noise).

    Returns:
        Integer array of shape (P, N), one row per equilibrium (its joint action indices), rows in
        lexicographic order. P = 0 when the game has no pure equilibrium.

    Raises:
        ValueError: if ``losses`` has the wrong shape, contains NaN/inf, or ``tol`` is invalid.
    """
    arr = _as_losses(losses, tol)
    mask, _ = _scan(arr, tol, nash=True, safety=False)
    return _nash_set(mask, arr.shape[1:])


def _product(sets: list[npt.NDArray[np.intp]]) -> npt.NDArray[np.intp]:
    """Cartesian product of index sets as a (P, N) array in lexicographic order."""
    if all(s.size == 1 for s in sets):
        return np.array([[s[0] for s in sets]], dtype=np.intp)
    grids = np.meshgrid(*sets, indexing="ij")
    return np.stack([g.ravel() for g in grids], axis=1).astype(np.intp, copy=False)


def minmax_strategies(losses: npt.ArrayLike, *, tol: float = 0.0) -> npt.NDArray[np.intp]:
    """The min-max (safety) joint actions of a loss game, eq. (28).

    Player i's safety actions minimise its worst-case loss over the other players' actions:
    ``d_i0 in argmin_{d_i} max_{d_{-i}} I_i(d_i, d_{-i})``. Each player computes this on its own,
    so when some players have several safety actions (ties in the outer min, up to ``tol``) the
    returned set is the Cartesian product of the players' safety-action sets. It is never empty.

    Args:
        losses: array of shape (N, K_1, ..., K_N) of finite losses, as in :func:`pure_nash_equilibria`.
        tol: absolute slack (>= 0): player i's safety set is every d_i whose worst-case loss is
            at most ``min_{d_i} max_{d_{-i}} I_i + tol``. Default 0: exact ties only.

    Returns:
        Integer array of shape (P, N), P >= 1, rows in lexicographic order.

    Raises:
        ValueError: if ``losses`` has the wrong shape, contains NaN/inf, or ``tol`` is invalid.
    """
    arr = _as_losses(losses, tol)
    _, safe = _scan(arr, tol, nash=False, safety=True)
    return _product(_safety_sets(safe))


#: Up to this many candidates eq. (30) is evaluated in plain Python: a handful of numpy calls on
#: a (N, P) array cost more than the arithmetic itself. Both paths give bit-identical costs.
_PYTHON_COST_LIMIT = 16


def _sequential_sum(values: list[float]) -> float:
    """``values[0] + values[1] + ...`` in float64, left to right, as ``np.add.accumulate`` adds.

    Not the built-in ``sum()``: from Python 3.12 on it adds floats with a compensated
    (Neumaier) sum, which can differ from plain left-to-right addition in the last bit.
    """
    total = values[0]
    for v in values[1:]:
        total += v
    return total


def _cost_flat(flat_losses: np.ndarray, flat_idx: npt.NDArray[np.intp]) -> npt.NDArray[np.float64]:
    """Eq. (30) for candidates given by flat joint-action indices into ``flat_losses`` (N, M)."""
    vals = flat_losses[:, flat_idx]  # (N, P): I_i(S_n)
    # Sorting each candidate's loss vector makes C a function of the multiset of losses alone, so
    # candidates whose loss vectors are permutations of each other get bit-identical costs and
    # the lexicographic tie-break of eq. (31) is not decided by floating-point summation order.
    # Both paths add in the same order (sorted, left to right, no compensation) on every Python
    # and numpy version, so they agree to the bit: not the built-in sum() (compensated from
    # Python 3.12 on), and not ndarray.sum(), which sums pairwise (8 partial sums once N >= 8)
    # along a contiguous axis -- and the gathered (N, P) array here is Fortran-ordered.
    n = vals.shape[0]
    if vals.shape[1] <= _PYTHON_COST_LIMIT:
        costs = []
        for row in vals.T.tolist():
            row.sort()
            mean = _sequential_sum(row) / n
            costs.append(_sequential_sum([v + abs(v - mean) for v in row]))
        return np.array(costs, dtype=np.float64)
    vals = np.sort(vals, axis=0)
    mean = np.add.accumulate(vals, axis=0)[-1] / n
    return np.add.accumulate(vals + np.abs(vals - mean), axis=0)[-1]


def _cost(arr: np.ndarray, candidates: npt.NDArray[np.intp]) -> npt.NDArray[np.float64]:
    """Eq. (30) for validated losses and a (P, N) candidate array."""
    flat_idx = np.ravel_multi_index(tuple(candidates.T), arr.shape[1:])
    return _cost_flat(arr.reshape(arr.shape[0], -1), flat_idx)


def arbiter_cost(losses: npt.ArrayLike, candidates: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """The arbiter's performance index of eq. (30) for each candidate joint action.

    ``C(S_n) = sum_i (I_i(S_n) + |I_i(S_n) - Ibar|)`` with ``Ibar = (1/N) sum_i I_i(S_n)``:
    the team's total loss plus the spread of the losses around their mean (total cost and a
    uniform distribution of costs among the players).

    Args:
        losses: array of shape (N, K_1, ..., K_N) of finite losses.
        candidates: joint actions, shape (P, N) (or (N,) for a single one).

    Returns:
        Float array of shape (P,) (a 0-d array for a single (N,) candidate).
    """
    arr = _as_losses(losses, 0.0)
    cand = np.asarray(candidates)
    single = cand.ndim == 1
    cand = np.atleast_2d(cand)
    n = arr.shape[0]
    if cand.ndim != 2 or cand.shape[1] != n or not np.issubdtype(cand.dtype, np.integer):
        raise ValueError(f"candidates must be integer joint actions of shape (P, {n}); got {cand.dtype} {cand.shape}")
    if ((cand < 0) | (cand >= np.asarray(arr.shape[1:]))).any():
        raise ValueError("candidates contain an action index out of range")
    cost = _cost(arr, cand)
    return cost[0] if single else cost


@dataclass(frozen=True, slots=True)
class ArbiterResult:
    """Outcome of :func:`arbitrate` (section 5.1, Fig. 4).

    Attributes:
        actions: the chosen joint action (d_10, ..., d_N0), one action index per player.
        branch: the exit taken in Fig. 4: ``"nash-unique"`` / ``"nash-arbiter"`` when the Nash
            set (27) is non-empty and has one / several members, ``"minmax-unique"`` /
            ``"minmax-arbiter"`` when it is empty and the min-max set (28) has one / several.
            The ``*-arbiter`` branches name the path, whichever ``selection`` rule was applied.
        n_nash: number of pure Nash equilibria (P_N).
        n_minmax: number of min-max joint actions (P_M >= 1) when the Nash set was empty; None
            otherwise, because Fig. 4 only builds the min-max set when there is no equilibrium.
        cost: C of eq. (30) for the chosen joint action, or None when the candidate was unique.
    """

    actions: tuple[int, ...]
    branch: str
    n_nash: int
    n_minmax: int | None
    cost: float | None


def arbitrate(losses: npt.ArrayLike, *, selection: Selection = "arbiter", tol: float = 0.0) -> ArbiterResult:
    """Pick one joint action by the arbitration of section 5.1 (Fig. 4, eqs. 27-31).

    The candidate set S is the set of pure Nash equilibria (27) if it is non-empty, else the
    min-max joint actions (28) (Cartesian product of the players' safety sets). If |S| = 1
    that joint action is returned. Otherwise, with ``selection="arbiter"`` (the paper), the
    candidate minimising C of eq. (30) is chosen, eq. (31); exact ties in C go to the candidate
    that comes first in lexicographic order of joint action indices. ``selection="first"`` is the
    "no arbiter" ablation: the lexicographically first candidate is taken without looking at C
    (its C is still reported).

    Args:
        losses: array of shape (N, K_1, ..., K_N) of finite losses (players minimise).
        selection: ``"arbiter"`` (eq. 31, default) or ``"first"``.
        tol: absolute slack (>= 0) on eqs. (27) and (28); see :func:`pure_nash_equilibria` and
            :func:`minmax_strategies`. The cost comparison of eq. (31) is always exact.

    Returns:
        An :class:`ArbiterResult`.

    Raises:
        ValueError: on an invalid loss tensor, ``tol`` or ``selection``.
    """
    if selection not in ("arbiter", "first"):
        raise ValueError(f"selection must be 'arbiter' or 'first'; got {selection!r}")
    arr = _as_losses(losses, tol)
    ks = arr.shape[1:]
    mask, _ = _scan(arr, tol, nash=True, safety=False)
    flat_idx = np.flatnonzero(mask)
    n_nash = flat_idx.size
    n_minmax = None
    # Fast exits for the common unique cases, without building candidate arrays.
    if n_nash == 1:
        actions = tuple(int(d) for d in np.unravel_index(int(flat_idx[0]), ks))
        return ArbiterResult(actions, "nash-unique", 1, None, None)
    if n_nash:
        kind = "nash"
    else:
        _, safe = _scan(arr, tol, nash=False, safety=True)
        n_minmax = math.prod(safe.sum(axis=1).tolist())
        if n_minmax == 1:
            return ArbiterResult(tuple(safe.argmax(axis=1).tolist()), "minmax-unique", 0, 1, None)
        flat_idx, kind = np.ravel_multi_index(tuple(_product(_safety_sets(safe)).T), ks), "minmax"
    flat_losses = arr.reshape(arr.shape[0], -1)
    if selection == "first":
        k = 0
        cost = float(_cost_flat(flat_losses, flat_idx[:1])[0])
    else:
        costs = _cost_flat(flat_losses, flat_idx)
        k = int(np.argmin(costs))  # first minimum: lowest lexicographic index among exact ties
        cost = float(costs[k])
    actions = tuple(int(d) for d in np.unravel_index(int(flat_idx[k]), ks))
    return ArbiterResult(actions, f"{kind}-arbiter", n_nash, n_minmax, cost)
