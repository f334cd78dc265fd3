"""Time the normal-form game solver (``baselines.game``) beside Gambit's ``enumpure_solve``.

Random loss games (i.i.d. standard normal losses) of three sizes -- 3 players x 17 actions,
5 x 5 and 5 x 17 -- are solved by

* ``pure_nash_equilibria`` (all pure equilibria, eq. 27 of paper 001),
* ``arbitrate`` (eqs. 27-31: Nash set, min-max fallback, arbiter),
* ``pygambit.nash.enumpure_solve`` if ``pygambit`` imports (payoffs = -losses). Only the solve
  is timed; building the Gambit game (``Game.from_arrays``) is not. Its equilibria are
  checked against ours.

For every game each solver is timed with ``--repeat`` rounds (best round kept, the least
disturbed by other load); the table shows the median over ``--games`` games and the speed-up
of ours over Gambit. Issue bar: ours >= 50x faster than enumpure on 3 x 17 and 5 x 5, judged on
the like-for-like solve (all pure equilibria); the arbiter's ratio is printed beside it.

Gambit on 5 x 17 (1.4 M joint actions) needs about 80 s and 2.5 GB just to build the game
(then ~2.6 s to solve), so it runs only with ``--gambit-large``, on a single game.

    python benchmarks/bench_game_solver.py [--games 10] [--repeat 5] [--gambit-large] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
import timeit

import numpy as np

from baselines.game import arbitrate, pure_nash_equilibria

try:
    import pygambit
except ImportError:  # optional: the comparison column is left out
    pygambit = None

SIZES = [(3, 17), (5, 5), (5, 17)]  # (players, actions per player)
BAR = 50.0
BAR_SIZES = {(3, 17), (5, 5)}


def best_time(fn, repeat: int, min_total: float = 0.02) -> float:
    """Best-of-``repeat`` seconds per call, each round looping long enough to be measurable."""
    number = 1
    while True:  # calibrate like timeit.autorange, but against a smaller total
        t = timeit.timeit(fn, number=number)
        if t >= min_total or number >= 1 << 20:
            break
        number *= 4
    rounds = timeit.repeat(fn, number=number, repeat=repeat)
    return min(rounds) / number


def gambit_game(losses: np.ndarray):
    # pygambit 16: Game.from_arrays; 17: StrategicGame.from_arrays.
    game_class = getattr(pygambit, "StrategicGame", pygambit.Game)
    return game_class.from_arrays(*(-losses[i] for i in range(losses.shape[0])))


def gambit_equilibria(game) -> set[tuple[int, ...]]:
    found = set()
    players = list(game.players)
    for profile in pygambit.nash.enumpure_solve(game).equilibria:
        if players and isinstance(players[0], str):  # pygambit 17
            found.add(tuple(next(k for k, (_, prob) in enumerate(profile[p]) if prob == 1) for p in players))
        else:
            found.add(tuple(next(k for k, s in enumerate(p.strategies) if profile[s] == 1) for p in players))
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--games", type=int, default=10, help="random games per size")
    parser.add_argument("--repeat", type=int, default=5, help="timing rounds per game and solver (best kept)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--gambit-large", action="store_true", help="also run Gambit on 5 x 17 (slow to build)")
    parser.add_argument("--json", help="write the results here")
    args = parser.parse_args()

    rng = np.random.default_rng(args.seed)
    rows = []
    for n, k in SIZES:
        use_gambit = pygambit is not None and (k**n <= 100_000 or args.gambit_large)
        games = args.games if k**n <= 100_000 else (1 if use_gambit else max(1, min(args.games, 3)))
        times: dict[str, list[float]] = {"pure_nash_equilibria": [], "arbitrate": [], "enumpure_solve": []}
        n_nash = []
        for _ in range(games):
            losses = rng.standard_normal((n,) + (k,) * n)
            rep = args.repeat if k**n <= 100_000 else 1
            times["pure_nash_equilibria"].append(best_time(lambda L=losses: pure_nash_equilibria(L), rep))
            times["arbitrate"].append(best_time(lambda L=losses: arbitrate(L), rep))
            ours = {tuple(r) for r in pure_nash_equilibria(losses).tolist()}
            n_nash.append(len(ours))
            if use_gambit:
                game = gambit_game(losses)
                times["enumpure_solve"].append(best_time(lambda g=game: pygambit.nash.enumpure_solve(g), rep, 0.0))
                theirs = gambit_equilibria(game)
                if theirs != ours:
                    raise AssertionError(f"{n} x {k}: ours {sorted(ours)} != Gambit's {sorted(theirs)}")
        row = {"players": n, "actions": k, "joint_actions": k**n, "games": games, "mean_n_nash": float(np.mean(n_nash))}
        for name, ts in times.items():
            row[name] = statistics.median(ts) if ts else None
        rows.append(row)

    print(f"python {platform.python_version()}, numpy {np.__version__}, pygambit {getattr(pygambit, '__version__', 'n/a')}")
    print("median over games of the best-of-repeats time per solve; ratio = enumpure_solve / ours")
    header = (
        f"{'game':>8} {'joint':>9} {'games':>5} {'pure_nash_eq':>13} {'arbitrate':>11} {'enumpure':>11}"
        f" {'ratio nash':>10} {'ratio arb':>10}"
    )
    print(header)
    print("-" * len(header))
    verdicts = []
    for r in rows:
        g = r["enumpure_solve"]
        rn = g / r["pure_nash_equilibria"] if g else None
        ra = g / r["arbitrate"] if g else None
        r["ratio_pure_nash"], r["ratio_arbitrate"] = rn, ra

        def fmt(t):
            return f"{t * 1e6:9.1f}us" if t is not None else f"{'-':>11}"

        print(
            f"{r['players']:>4} x{r['actions']:>2} {r['joint_actions']:>9} {r['games']:>5} {fmt(r['pure_nash_equilibria']):>13}"
            f" {fmt(r['arbitrate'])} {fmt(g)} {(f'{rn:9.0f}x' if rn else '-'):>10} {(f'{ra:9.0f}x' if ra else '-'):>10}"
        )
        if (r["players"], r["actions"]) in BAR_SIZES and rn is not None:
            verdicts.append((r["players"], r["actions"], rn, ra))
    for n, k, pure, arbiter in verdicts:
        print(
            f"bar {n} x {k}: pure equilibria (the job enumpure_solve does) {pure:.0f}x faster (>= {BAR:.0f}x): "
            f"{'PASS' if pure >= BAR else 'FAIL'}; the whole arbiter (also eqs. 28-31) {arbiter:.0f}x: "
            f"{'PASS' if arbiter >= BAR else 'below'}"
        )
    if pygambit is None:
        print("pygambit not importable: no comparison (pip install pygambit)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"rows": rows, "time": time.strftime("%Y-%m-%dT%H:%M:%S")}, f, indent=2)


if __name__ == "__main__":
    main()
