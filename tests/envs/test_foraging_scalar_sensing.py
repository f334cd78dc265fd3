"""Foraging's scalar cameras (``Cameras.look``/``Cameras.sight``) give the bits of the array form (``view``/``sightings``)."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from teamgym.envs.foraging.perception import landmark_positions
from teamgym.envs.foraging.sensing import SEEN_LANDMARK, SEEN_ROBOT, SEEN_TARGET, Cameras


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 10**6), n=st.integers(1, 9), t=st.integers(0, 4), spread=st.sampled_from([0.2, 0.6, 1.0, 3.0]))
def test_sight_equals_the_array_sightings(seed, n, t, spread):
    rng = np.random.default_rng(seed)
    cameras = Cameras(n, landmark_positions(3.0, 2.4, 0.6), 1.0, 1.28, 0.09)
    pose = np.column_stack([1.5 + spread * rng.uniform(-0.5, 0.5, (n, 2)), rng.uniform(-math.pi, math.pi, n)])
    targets = rng.uniform(0, (3.0, 2.4), (4, 2))
    live = np.sort(rng.choice(4, size=t, replace=False))
    rows, cols, distances, bearings = cameras.sightings(pose, cameras.view(pose, cameras.points(targets)), live)
    geometry = cameras.look(pose, cameras.points(targets))
    view = cameras.view(pose, cameras.points(targets))
    assert geometry.distance == view.distance.tolist() and geometry.rel_x == view.rel[..., 0].tolist()
    visible = [j in set(live.tolist()) for j in range(4)]
    kinds = [SEEN_TARGET if j < t else SEEN_ROBOT if j < t + n else SEEN_LANDMARK for j in cols]
    assert cameras.sight(pose.tolist(), geometry, visible) == list(zip(rows, kinds, distances, bearings))
