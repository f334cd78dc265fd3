"""N-player normal-form game solver (paper 001, section 5 and 5.1: eqs. 27-31)."""

import itertools
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from baselines.game import BRANCHES, ArbiterResult, arbiter_cost, arbitrate, minmax_strategies, pure_nash_equilibria, solver

# --------------------------------------------------------------------------- brute-force references


def brute_nash(losses):
    """Eq. (27) by enumeration of every joint action and every unilateral deviation."""
    n, shape = losses.shape[0], losses.shape[1:]
    found = []
    for d in itertools.product(*map(range, shape)):
        if all(losses[i][d] <= losses[i][d[:i] + (a,) + d[i + 1 :]] for i in range(n) for a in range(shape[i])):
            found.append(d)
    return found


def brute_minmax(losses):
    """Eq. (28) by enumeration: each player's safety actions, then their Cartesian product."""
    n, shape = losses.shape[0], losses.shape[1:]
    sets = []
    for i in range(n):
        worst = [max(losses[i][d] for d in itertools.product(*map(range, shape)) if d[i] == a) for a in range(shape[i])]
        sets.append([a for a in range(shape[i]) if worst[a] == min(worst)])
    return list(itertools.product(*sets))


def brute_cost(losses, d):
    """Eq. (30) written out literally."""
    vals = [float(losses[i][tuple(d)]) for i in range(losses.shape[0])]
    mean = sum(vals) / len(vals)
    return sum(v + abs(v - mean) for v in vals)


def as_set(rows):
    return {tuple(int(a) for a in r) for r in rows}


def random_game(rng, n, ks, integer_range=None):
    shape = (n, *ks)
    if integer_range is not None:
        return rng.integers(0, integer_range, size=shape).astype(float)
    return rng.standard_normal(shape)


# --------------------------------------------------------------------------- hand-built games

# Prisoner's dilemma as years in prison; action 0 = stay silent, 1 = confess.
PRISONERS = np.array(
    [
        [[1.0, 3.0], [0.0, 2.0]],  # row player's years
        [[1.0, 0.0], [3.0, 2.0]],  # column player's years
    ]
)

# Matching pennies: player 0 wants to match, player 1 to mismatch; no pure equilibrium.
PENNIES = np.array([[[-1.0, 1.0], [1.0, -1.0]], [[1.0, -1.0], [-1.0, 1.0]]])


def test_prisoners_dilemma_unique_equilibrium_is_mutual_confession():
    assert as_set(pure_nash_equilibria(PRISONERS)) == {(1, 1)}
    assert as_set(minmax_strategies(PRISONERS)) == {(1, 1)}
    result = arbitrate(PRISONERS)
    assert result == ArbiterResult(actions=(1, 1), branch="nash-unique", n_nash=1, n_minmax=None, cost=None)


def test_matching_pennies_falls_back_to_minmax_and_arbiter():
    assert pure_nash_equilibria(PENNIES).shape == (0, 2)
    # Every action's worst case is +1 for both players: each safety set is {0, 1}.
    assert as_set(minmax_strategies(PENNIES)) == {(0, 0), (0, 1), (1, 0), (1, 1)}
    result = arbitrate(PENNIES)
    # Every candidate has losses (+1, -1) or (-1, +1): mean 0, C = 0 + (1 + 1) = 2; tie -> (0, 0).
    assert result == ArbiterResult(actions=(0, 0), branch="minmax-arbiter", n_nash=0, n_minmax=4, cost=2.0)


def test_game_without_equilibrium_with_unique_safety_strategies():
    losses = np.array([[[0.0, 3.0], [2.0, 1.0]], [[2.0, 0.0], [0.0, 1.0]]])
    assert pure_nash_equilibria(losses).shape == (0, 2)
    # Player 0's worst cases: row 0 -> 3, row 1 -> 2; player 1's: column 0 -> 2, column 1 -> 1.
    result = arbitrate(losses)
    assert result == ArbiterResult(actions=(1, 1), branch="minmax-unique", n_nash=0, n_minmax=1, cost=None)


def test_coordination_game_arbiter_uses_eq30():
    # Two equilibria: (0, 0) with losses (1, 3) and (1, 1) with losses (2, 2); miscoordination costs 5.
    losses = np.array([[[1.0, 5.0], [5.0, 2.0]], [[3.0, 5.0], [5.0, 2.0]]])
    assert as_set(pure_nash_equilibria(losses)) == {(0, 0), (1, 1)}
    # C(0, 0) = (1 + 3) + (|1 - 2| + |3 - 2|) = 6;  C(1, 1) = (2 + 2) + 0 = 4.
    np.testing.assert_array_equal(arbiter_cost(losses, [[0, 0], [1, 1]]), [6.0, 4.0])
    result = arbitrate(losses)
    # Every action's worst case is 5 for both players, so all 4 joint actions are min-max ones.
    assert result == ArbiterResult(actions=(1, 1), branch="nash-arbiter", n_nash=2, n_minmax=None, cost=4.0)
    # The "no arbiter" ablation takes the lexicographically first equilibrium.
    first = arbitrate(losses, selection="first")
    assert first == ArbiterResult(actions=(0, 0), branch="nash-arbiter", n_nash=2, n_minmax=None, cost=6.0)


def test_three_player_arbiter_cost_by_hand():
    # Three players, two actions each; all agree -> an equilibrium (deviating costs 10).
    losses = np.full((3, 2, 2, 2), 10.0)
    losses[:, 0, 0, 0] = [1.0, 2.0, 6.0]  # sum 9, mean 3, spread 2 + 1 + 3 = 6 -> C = 15
    losses[:, 1, 1, 1] = [4.0, 4.0, 4.0]  # sum 12, spread 0 -> C = 12
    assert as_set(pure_nash_equilibria(losses)) == {(0, 0, 0), (1, 1, 1)}
    assert arbiter_cost(losses, (0, 0, 0)) == 15.0
    assert arbiter_cost(losses, (1, 1, 1)) == 12.0
    assert arbitrate(losses).actions == (1, 1, 1)
    assert arbitrate(losses).cost == 12.0
    assert arbitrate(losses, selection="first").actions == (0, 0, 0)


# --------------------------------------------------------------------------- ties and tolerance


def test_ties_are_equilibria():
    # Player 0 is indifferent between its actions whatever player 1 does; player 1 strictly prefers 1.
    losses = np.array([[[0.0, 0.0], [0.0, 0.0]], [[1.0, 0.0], [1.0, 0.0]]])
    assert as_set(pure_nash_equilibria(losses)) == {(0, 1), (1, 1)}
    assert as_set(minmax_strategies(losses)) == {(0, 1), (1, 1)}


def test_constant_game_every_joint_action_is_an_equilibrium_and_first_wins_ties():
    losses = np.full((3, 2, 3, 2), 7.0)
    eq = pure_nash_equilibria(losses)
    assert eq.shape == (12, 3)
    np.testing.assert_array_equal(eq, np.array(list(itertools.product(range(2), range(3), range(2)))))
    result = arbitrate(losses)
    assert result == ArbiterResult(actions=(0, 0, 0), branch="nash-arbiter", n_nash=12, n_minmax=None, cost=21.0)


def test_cost_ties_between_permuted_loss_vectors_go_to_lowest_index():
    # Two equilibria whose loss vectors are permutations of awkward floats: bit-identical C, first wins.
    a, b, c = 0.1, 0.2, 0.7
    losses = np.full((3, 2, 2, 2), 5.0)
    losses[:, 0, 1, 1] = [c, a, b]
    losses[:, 1, 0, 0] = [a, b, c]
    assert as_set(pure_nash_equilibria(losses)) == {(0, 1, 1), (1, 0, 0)}
    costs = arbiter_cost(losses, [[0, 1, 1], [1, 0, 0]])
    assert costs[0] == costs[1]
    assert arbitrate(losses).actions == (0, 1, 1)


def test_tolerance_accepts_small_deviation_gains():
    losses = np.array([[[0.0, 1.0], [1e-12, 1.0]], [[0.0, 1.0], [0.0, 1.0]]])
    assert as_set(pure_nash_equilibria(losses)) == {(0, 0)}
    assert as_set(pure_nash_equilibria(losses, tol=1e-9)) == {(0, 0), (1, 0)}
    shifted = losses.copy()
    shifted[0, 1, 1] = 1.0 + 1e-12  # row 1's worst case now exceeds row 0's by 1e-12
    assert as_set(minmax_strategies(shifted)) == {(0, 0)}
    assert as_set(minmax_strategies(shifted, tol=1e-9)) == {(0, 0), (1, 0)}


def test_integer_and_list_inputs_are_accepted():
    as_lists = PRISONERS.astype(int).tolist()
    assert as_set(pure_nash_equilibria(as_lists)) == {(1, 1)}
    assert arbitrate(np.asarray(as_lists, dtype=np.int64)).actions == (1, 1)
    assert arbitrate(PRISONERS.astype(np.float32)).actions == (1, 1)


# --------------------------------------------------------------------------- sizes


@pytest.mark.parametrize(
    "ks",
    [(4, 4, 4, 4, 4, 4), (2, 3, 2, 3, 2, 3), (17, 17), (17, 17, 17), (2, 17, 5), (5, 5, 5, 5, 5), (9, 1, 3)],
    ids=str,
)
def test_shapes_against_brute_force(ks):
    rng = np.random.default_rng(len(ks) * 100 + sum(ks))
    for integer_range in (None, 3):
        losses = random_game(rng, len(ks), ks, integer_range)
        eq = pure_nash_equilibria(losses)
        assert eq.shape[1] == len(ks)
        assert eq.dtype == np.intp
        assert [tuple(r) for r in eq.tolist()] == brute_nash(losses)  # same set, lexicographic order
        mm = minmax_strategies(losses)
        assert [tuple(r) for r in mm.tolist()] == brute_minmax(losses)
        result = arbitrate(losses)
        assert len(result.actions) == len(ks)
        assert result.branch in BRANCHES
        assert (result.n_nash, result.n_minmax) == (len(eq), None if len(eq) else len(mm))


def test_six_players_seventeen_actions_has_the_right_shapes():
    rng = np.random.default_rng(6)
    losses = rng.integers(0, 2, size=(6, 3, 3, 3, 3, 3, 3)).astype(float)
    assert pure_nash_equilibria(losses).shape[1] == 6
    losses = rng.standard_normal((4, 17, 17, 17, 17))
    eq = pure_nash_equilibria(losses)
    assert eq.ndim == 2 and eq.shape[1] == 4
    assert ((eq >= 0) & (eq < 17)).all()
    assert len(arbitrate(losses).actions) == 4


# --------------------------------------------------------------------------- properties


@st.composite
def games(draw, max_players=4, max_actions=4):
    n = draw(st.integers(2, max_players))
    if draw(st.booleans()):  # equal action counts (the stacked code path for small games)
        ks = (draw(st.integers(1, max_actions)),) * n
    else:
        ks = tuple(draw(st.lists(st.integers(1, max_actions), min_size=n, max_size=n)))
    hi = draw(st.sampled_from([2, 3, 10, 1000]))
    seed = draw(st.integers(0, 2**32 - 1))
    return np.random.default_rng(seed).integers(-hi, hi, size=(n, *ks)).astype(float)


@settings(max_examples=150, deadline=None, database=None)
@given(losses=games())
def test_nash_and_minmax_match_brute_force(losses):
    assert [tuple(r) for r in pure_nash_equilibria(losses).tolist()] == brute_nash(losses)
    assert [tuple(r) for r in minmax_strategies(losses).tolist()] == brute_minmax(losses)


@settings(max_examples=150, deadline=None, database=None)
@given(losses=games(), selection=st.sampled_from(["arbiter", "first"]))
def test_arbitrate_follows_fig4(losses, selection):
    nash = [tuple(r) for r in pure_nash_equilibria(losses).tolist()]
    cands = nash or [tuple(r) for r in minmax_strategies(losses).tolist()]
    result = arbitrate(losses, selection=selection)
    assert result.n_nash == len(nash)
    assert result.n_minmax == (None if nash else len(brute_minmax(losses)))  # Fig. 4: only without equilibria
    assert result.branch == ("nash" if nash else "minmax") + ("-unique" if len(cands) == 1 else "-arbiter")
    if len(cands) == 1:
        assert result.actions == cands[0] and result.cost is None
        return
    costs = [brute_cost(losses, d) for d in cands]
    if selection == "first":
        assert result.actions == cands[0]
    else:
        best = min(costs)
        # Lowest-index minimiser (costs are exact here: integer losses).
        assert result.actions == cands[costs.index(best)]
    assert result.cost == pytest.approx(costs[cands.index(result.actions)])


@settings(max_examples=100, deadline=None, database=None)
@given(losses=games(), data=st.data())
def test_nash_set_invariant_under_strategic_equivalence(losses, data):
    """Adding to I_i any function of the others' actions d_{-i} leaves eq. (27) unchanged."""
    n = losses.shape[0]
    shifted = losses.copy()
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    for i in range(n):
        shape = list(losses.shape[1:])
        shape[i] = 1
        shifted[i] += rng.integers(-50, 50, size=shape)
    assert as_set(pure_nash_equilibria(shifted)) == as_set(pure_nash_equilibria(losses))


@settings(max_examples=100, deadline=None, database=None)
@given(losses=games(), data=st.data())
def test_relabelling_players_permutes_equilibria(losses, data):
    n = losses.shape[0]
    perm = data.draw(st.permutations(range(n)))
    permuted = losses[list(perm)].transpose(0, *(1 + p for p in perm))
    expected = {tuple(d[p] for p in perm) for d in as_set(pure_nash_equilibria(losses))}
    assert as_set(pure_nash_equilibria(permuted)) == expected
    expected_mm = {tuple(d[p] for p in perm) for d in as_set(minmax_strategies(losses))}
    assert as_set(minmax_strategies(permuted)) == expected_mm


@pytest.mark.parametrize("ks", [(5,) * 5, (17,) * 3, (3,) * 7, (2, 2), (9, 9, 9), (4,) * 6], ids=str)
@pytest.mark.parametrize("tol", [0.0, 0.5])
def test_stacked_and_player_loop_paths_agree(monkeypatch, ks, tol):
    rng = np.random.default_rng(sum(ks))
    for integer_range in (None, 2, 4):
        losses = random_game(rng, len(ks), ks, integer_range)
        monkeypatch.setattr(solver, "_STACK_LIMIT", 1 << 30)
        monkeypatch.setattr(solver, "_STACK_PER_PLAYER", 1 << 30)
        stacked = (pure_nash_equilibria(losses, tol=tol), minmax_strategies(losses, tol=tol), arbitrate(losses, tol=tol))
        monkeypatch.setattr(solver, "_STACK_LIMIT", 0)
        loop = (pure_nash_equilibria(losses, tol=tol), minmax_strategies(losses, tol=tol), arbitrate(losses, tol=tol))
        np.testing.assert_array_equal(stacked[0], loop[0])
        np.testing.assert_array_equal(stacked[1], loop[1])
        assert stacked[2] == loop[2]


@pytest.mark.parametrize("n", [2, 3, 5, 7])
def test_python_and_numpy_cost_paths_agree_bitwise(monkeypatch, n):
    """Eq. (30) in plain Python (few candidates) and in numpy (many) give identical costs."""
    rng = np.random.default_rng(n)
    for scale in (1e-3, 1.0, 1e3):
        flat = rng.standard_normal((n, 40)) * scale
        flat[:, ::3] = np.round(flat[:, ::3], 1)  # exact ties and permuted loss vectors
        flat[:, 1] = flat[::-1, 0]
        idx = np.arange(40)
        monkeypatch.setattr(solver, "_PYTHON_COST_LIMIT", 1000)
        python = solver._cost_flat(flat, idx)
        monkeypatch.setattr(solver, "_PYTHON_COST_LIMIT", 0)
        vectorised = solver._cost_flat(flat, idx)
        np.testing.assert_array_equal(python, vectorised)
        assert python[0] == python[1]
        by_hand = [sum(v + abs(v - flat[:, j].mean()) for v in flat[:, j]) for j in range(40)]
        np.testing.assert_allclose(python, by_hand, rtol=1e-12)


# --------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    "shape",
    [(), (3,), (2, 3), (3, 2, 2), (2, 2, 2, 2), (2, 0, 3), (1, 0)],
    ids=str,
)
@pytest.mark.parametrize("func", [pure_nash_equilibria, minmax_strategies, arbitrate])
def test_wrong_shapes_raise(func, shape):
    with pytest.raises(ValueError, match="losses must have shape|at least one action"):
        func(np.zeros(shape))


@pytest.mark.parametrize("bad, word", [(np.nan, "NaN"), (np.inf, "infinite"), (-np.inf, "infinite")])
@pytest.mark.parametrize("func", [pure_nash_equilibria, minmax_strategies, arbitrate])
def test_non_finite_losses_raise(func, bad, word):
    losses = PRISONERS.copy()
    losses[1, 0, 1] = bad
    with pytest.raises(ValueError, match=word):
        func(losses)


def test_huge_but_finite_losses_are_accepted():
    losses = PRISONERS * 1.5e307  # the total would overflow; every entry is finite
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # and no overflow warning escapes the solver
        assert as_set(pure_nash_equilibria(losses)) == {(1, 1)}
        assert arbitrate(losses).actions == (1, 1)


@pytest.mark.parametrize("tol", [-1e-9, np.nan, np.inf])
def test_bad_tolerance_raises(tol):
    with pytest.raises(ValueError, match="tol"):
        pure_nash_equilibria(PRISONERS, tol=tol)
    with pytest.raises(ValueError, match="tol"):
        arbitrate(PRISONERS, tol=tol)


def test_bad_selection_and_candidates_raise():
    with pytest.raises(ValueError, match="selection"):
        arbitrate(PRISONERS, selection="best")
    with pytest.raises(ValueError, match="candidates"):
        arbiter_cost(PRISONERS, [[0, 0, 0]])
    with pytest.raises(ValueError, match="out of range"):
        arbiter_cost(PRISONERS, [[0, 2]])
    with pytest.raises(ValueError, match="candidates"):
        arbiter_cost(PRISONERS, [[0.0, 1.0]])


# --------------------------------------------------------------------------- cross-check with Gambit


def gambit_pure_equilibria(pygambit, losses):
    """All pure equilibria found by Gambit's enumpure (payoffs are maximised: pass -losses)."""
    # pygambit 16 builds strategic games with Game.from_arrays, 17 with StrategicGame.from_arrays.
    game_class = getattr(pygambit, "StrategicGame", pygambit.Game)
    game = game_class.from_arrays(*(-losses[i] for i in range(losses.shape[0])))
    result = pygambit.nash.enumpure_solve(game)
    return {_pure_indices(game, profile) for profile in result.equilibria}


def _pure_indices(game, profile):
    """Joint action indices of a pure profile (pygambit 16 and 17 expose profiles differently)."""
    players = list(game.players)
    if players and isinstance(players[0], str):  # pygambit 17: labels; a player's entry iterates (label, prob)
        return tuple(next(k for k, (_, prob) in enumerate(profile[p]) if prob == 1) for p in players)
    return tuple(next(k for k, strategy in enumerate(player.strategies) if profile[strategy] == 1) for player in players)


def test_matches_gambit_enumpure_on_random_games():
    pygambit = pytest.importorskip("pygambit")
    rng = np.random.default_rng(2024)
    counts = {"none": 0, "one": 0, "several": 0}
    n_games = 240
    for g in range(n_games):
        n = int(rng.integers(2, 5))
        ks = tuple(int(k) for k in rng.integers(2, 7, size=n))
        if g % 4 == 3:
            losses = rng.standard_normal((n, *ks))  # generic floats (Gambit stores them as decimals)
        elif g % 4 == 2:
            losses = rng.integers(-64, 64, size=(n, *ks)) / 8.0  # dyadic: exact in both
        else:
            losses = rng.integers(0, 2 + g % 4, size=(n, *ks)).astype(float)  # values {0,1} or {0,1,2}: many ties
        ours = as_set(pure_nash_equilibria(losses))
        assert ours == gambit_pure_equilibria(pygambit, losses), (n, ks, losses)
        counts["none" if not ours else "one" if len(ours) == 1 else "several"] += 1
    print(f"pure-equilibrium counts over {n_games} games: {counts}")
    assert counts["none"] > 0 and counts["several"] > 0 and counts["one"] > 0, counts
