"""``baselines.runners``: serial and process-pool runs give the same results, in order."""

import math

import pytest

from baselines.runners import Episodes, pool_map, run_episodes

CONFIG = {"n_robots": 2, "max_cycles": 40}


def _cube(x: int) -> int:
    return x**3


def _fail_on_three(x: int) -> int:
    if x == 3:
        raise ValueError("job 3 failed")
    return x


def test_serial_and_pool_play_the_same_episodes_for_the_same_seeds():
    items = Episodes(11, False, range(6))
    done = []
    serial = run_episodes("Navigation-v0", "random", CONFIG, items, 1, on_done=done.append)
    pooled = run_episodes("Navigation-v0", "random", CONFIG, items, 2, on_done=done.append)
    assert [r.seed for r in serial] == list(range(11, 17))
    assert pooled == serial  # every field: length, success, returns, metrics, trajectories of the first
    assert serial[0].trajectories and not serial[1].trajectories
    assert sum(done) == 12  # six episodes reported by each run


def test_pool_map_keeps_the_job_order_and_reports_every_job():
    jobs = list(range(23))
    done = []
    assert pool_map(_cube, jobs, 3, on_done=done.append) == [x**3 for x in jobs]
    assert sum(done) == len(jobs) and len(done) <= 4 * 3  # in chunks, about four per worker
    assert pool_map(_cube, jobs, 1) == [x**3 for x in jobs]


def test_pool_map_unpacks_jobs_with_star_in_spawned_workers():
    jobs = [(12, 18), (7, 21), (9, 6)]
    assert pool_map(math.gcd, jobs, 2, star=True, start_method="spawn") == [6, 7, 3]


def test_a_failing_job_raises_and_bad_workers_are_refused():
    with pytest.raises(ValueError, match="job 3 failed"):
        pool_map(_fail_on_three, list(range(6)), 2)
    with pytest.raises(TypeError, match="workers must be an integer"):
        pool_map(_cube, [1, 2], "2")
