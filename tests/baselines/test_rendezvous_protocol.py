"""Paper 003's protocol (baselines/rendezvous/protocol.py): the timing of Phase 3 (``execution``)."""

import pytest

from baselines import make_policy
from baselines.rendezvous.protocol import EXECUTIONS, RendezvousProtocol
from teamgym.envs.rendezvous import parallel_env
from teamgym.envs.rendezvous.messages import Kind, decode

FIG5 = dict(start_places=("1", "38"), protocol_messages=True)


def first_moves(env, policy, steps=8):
    """Per step: which robots started a way, and whether robot_0 sent a PATH with a planner's count (a new plan)."""
    observations, infos = env.reset(seed=0)
    policy.reset(0)
    rows = []
    for _ in range(steps):
        actions = policy.act(observations, infos)
        moved = {a for a, x in actions.items() if int(x["move"]) != env.max_degree}
        planned = any(k == Kind.PATH and args[0] > 0 for k, args in decode(actions["robot_0"]["message"]))
        rows.append((moved, planned))
        observations, _, _, _, infos = env.step(actions)
        if not env.agents:  # met
            break
    return rows


def test_unknown_execution_is_refused_before_any_work():
    with pytest.raises(ValueError, match="unknown execution 'late'"):
        RendezvousProtocol(parallel_env(**FIG5), execution="late")
    assert EXECUTIONS == ("paper", "eager")


@pytest.mark.parametrize("stage_end", ["any", "all"])
def test_agent_1_sets_off_when_agent_2_receives_the_plan(stage_end):
    """Section 5: both agents enter Phase 3 once the path is sent; a PATH takes one step to arrive."""
    env = parallel_env(**FIG5, stage_end=stage_end)
    rows = first_moves(env, make_policy("bidir-astar", env))
    k = next(i for i, (_, planned) in enumerate(rows) if planned)
    assert rows[k][0] == set()  # Agent 1 waits while its PATH travels
    assert rows[k + 1][0] == {"robot_0", "robot_1"}  # then both robots set off together


def test_eager_agent_1_sets_off_while_its_plan_travels():
    env = parallel_env(**FIG5, stage_end="all")
    rows = first_moves(env, make_policy("bidir-astar-eager", env))
    k = next(i for i, (_, planned) in enumerate(rows) if planned)
    assert rows[k][0] == {"robot_0"} and rows[k + 1][0] == {"robot_0", "robot_1"}  # robot_0 a way ahead


def test_lockstep_robots_stand_one_step_at_each_place_they_reach():
    """stage_end="all": Step 5's answer takes a step, so the moves alternate with standing steps."""
    env = parallel_env(**FIG5, stage_end="all")
    rows = first_moves(env, make_policy("bidir-astar", env), steps=12)
    k = next(i for i, (_, planned) in enumerate(rows) if planned)
    moves = [moved for moved, _ in rows[k + 1 :]]
    assert moves[:6] == [{"robot_0", "robot_1"}, set()] * 3
    assert RendezvousProtocol(env).check_step
    assert not RendezvousProtocol(parallel_env(**FIG5, stage_end="any")).check_step  # a standing step has no fixed length
    assert not RendezvousProtocol(env, execution="eager").check_step
