"""Radio channel of the simulator core: range, throughput, latency, byte budget, inboxes."""

import copy
import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from teamgym.sim import Channel, ChannelConfig, Message

AGENTS = ("a0", "a1", "a2", "a3")
FAR = 1e6


def spread(n=None, gap=1.0):
    """Positions of the first ``n`` (default all) agents on a line, ``gap`` metres apart."""
    return {name: (gap * i, 0.0) for i, name in enumerate(AGENTS[:n])}


def binomial_interval(n, p, level=0.99):
    """Smallest central interval [lo, hi] of Binomial(n, p) holding at least ``level``."""
    if p in (0.0, 1.0):
        return (0, 0) if p == 0 else (n, n)
    tail = (1 - level) / 2
    log_pmf = [
        math.lgamma(n + 1) - math.lgamma(k + 1) - math.lgamma(n - k + 1) + k * math.log(p) + (n - k) * math.log1p(-p)
        for k in range(n + 1)
    ]
    cdf = np.cumsum(np.exp(log_pmf))
    return int(np.searchsorted(cdf, tail)), int(np.searchsorted(cdf, 1 - tail))


def inbox_keys(channel):
    """Every agent's inbox as hashable tuples."""
    return {
        a: [(m.sender, m.recipient, tuple(m.payload), m.size, m.kind, m.sent_step) for m in channel.inbox(a)]
        for a in channel.agents
    }


def random_traffic(channel, traffic_rng, channel_rng, steps, start=0):
    """Random sends and a deliver per step; returns what every inbox held at every step."""
    history = []
    agents = channel.agents
    for step in range(start, start + steps):
        for _ in range(int(traffic_rng.integers(0, 6))):
            sender = agents[int(traffic_rng.integers(len(agents)))]
            others = [a for a in agents if a != sender]
            recipient = None if traffic_rng.random() < 0.5 else others[int(traffic_rng.integers(len(others)))]
            payload = traffic_rng.normal(size=int(traffic_rng.integers(0, 4)))
            channel.send(sender, payload, recipient, kind=str(traffic_rng.choice(["learned", "perception"])))
        positions = {a: tuple(traffic_rng.uniform(0, 2, size=2)) for a in agents if traffic_rng.random() < 0.9}
        channel.deliver(positions, channel_rng, step)
        history.append(inbox_keys(channel))
    return history


def all_stats(channel):
    return {a: channel.stats(a) for a in channel.agents}


LOSSY = ChannelConfig(comm_range=1.5, throughput=0.6, latency=2, byte_budget=20, inbox_size=3)


# ---------------------------------------------------------------- throughput


@pytest.mark.parametrize("throughput", [0.0, 0.3, 0.7, 1.0])
def test_delivery_rate_matches_throughput(throughput):
    n_steps, per_step = 100, 100
    channel = Channel(AGENTS[:2], ChannelConfig(throughput=throughput, inbox_size=per_step))
    rng = np.random.default_rng(12345)
    state = copy.deepcopy(rng.bit_generator.state)
    arrived = 0
    for step in range(n_steps):
        for _ in range(per_step):
            assert channel.send("a0", [1.0], "a1")
        channel.deliver(spread(2), rng, step)
        arrived += len(channel.inbox("a1"))
    n = n_steps * per_step
    lo, hi = binomial_interval(n, throughput)
    assert lo <= arrived <= hi
    assert channel.messages_delivered[1] == arrived
    assert channel.dropped["loss"][0] == n - arrived
    if throughput in (0.0, 1.0):
        assert rng.bit_generator.state == state, "a certain outcome must not consume random draws"


def test_binomial_interval_helper():
    lo, hi = binomial_interval(10_000, 0.5)
    assert lo < 5000 < hi
    assert hi - lo == pytest.approx(2 * 2.576 * 50, abs=3)


# ---------------------------------------------------------------- range


@settings(max_examples=150, deadline=None)
@given(
    points=st.lists(st.tuples(st.floats(-3, 3), st.floats(-3, 3)), min_size=2, max_size=len(AGENTS)),
    comm_range=st.floats(0.0, 4.0),
)
def test_range_decides_delivery_with_perfect_throughput(points, comm_range):
    names = AGENTS[: len(points)]
    channel = Channel(names, ChannelConfig(comm_range=comm_range))
    for name in names:
        channel.send(name, [float(names.index(name))])
    positions = dict(zip(names, points))
    channel.deliver(positions, np.random.default_rng(0), 0)
    out_of_range = 0
    for receiver in names:
        senders = {m.sender for m in channel.inbox(receiver)}
        for sender in names:
            if sender == receiver:
                continue
            (x0, y0), (x1, y1) = positions[sender], positions[receiver]
            reachable = math.hypot(x0 - x1, y0 - y1) <= comm_range
            assert (sender in senders) == reachable
            out_of_range += not reachable
    assert channel.dropped["range"].sum() == out_of_range


def test_out_of_range_never_arrives_under_loss():
    channel = Channel(AGENTS, ChannelConfig(comm_range=1.0, throughput=0.5, inbox_size=100))
    rng, placement = np.random.default_rng(1), np.random.default_rng(2)
    for step in range(300):
        positions = placement.uniform(0, 3, size=(len(AGENTS), 2))
        for name in AGENTS:
            channel.send(name, [0.0])
        channel.deliver(positions, rng, step)
        for r, receiver in enumerate(AGENTS):
            for message in channel.inbox(receiver):
                s = AGENTS.index(message.sender)
                assert np.hypot(*(positions[s] - positions[r])) <= 1.0


# ---------------------------------------------------------------- latency


@pytest.mark.parametrize("latency", [0, 1, 3])
@pytest.mark.parametrize("sent_at", [0, 2])
def test_latency_delays_arrival_exactly(latency, sent_at):
    channel = Channel(AGENTS[:2], ChannelConfig(latency=latency))
    rng = np.random.default_rng(0)
    arrivals = {}
    for step in range(10):
        if step == sent_at:
            channel.send("a0", [7.0], "a1")
        channel.deliver(spread(2), rng, step)
        if channel.inbox("a1"):
            arrivals[step] = channel.inbox("a1")
    assert list(arrivals) == [sent_at + latency]
    (message,) = arrivals[sent_at + latency]
    assert message.sent_step == sent_at and message.payload.tolist() == [7.0]


def test_inbox_is_cleared_each_step():
    channel = Channel(AGENTS[:2])
    rng = np.random.default_rng(0)
    channel.send("a0", [1.0])
    channel.deliver(spread(2), rng, 0)
    assert len(channel.inbox("a1")) == 1
    channel.deliver(spread(2), rng, 1)
    assert channel.inbox("a1") == []


# ---------------------------------------------------------------- byte budget


def test_byte_budget_refuses_and_resets_next_step():
    channel = Channel(AGENTS[:2], ChannelConfig(byte_budget=10))
    rng = np.random.default_rng(0)
    assert channel.send("a0", [1.0, 2.0])  # 8 bytes
    before = all_stats(channel)
    assert not channel.send("a0", [3.0, 4.0])  # 16 > 10
    after = all_stats(channel)
    assert after["a0"].pop("dropped_budget") == before["a0"].pop("dropped_budget") + 1
    assert after["a0"].pop("messages_dropped") == before["a0"].pop("messages_dropped") + 1
    assert after == before
    assert channel.send("a0", [5.0], size=2)  # exactly 10
    assert channel.send("a1", [1.0, 2.0])  # budgets are per robot
    channel.deliver(spread(2), rng, 0)
    assert [m.payload.tolist() for m in channel.inbox("a1")] == [[1.0, 2.0], [5.0]]
    assert channel.send("a0", [1.0, 2.0]), "the budget starts afresh after deliver"
    assert channel.stats("a0")["bytes_sent"] == 18 and channel.stats("a0")["messages_sent"] == 3


def test_zero_size_messages_pass_an_exhausted_budget():
    channel = Channel(AGENTS[:2], ChannelConfig(byte_budget=0))
    assert not channel.send("a0", [1.0])
    assert channel.send("a0", [1.0], size=0)


# ---------------------------------------------------------------- addressing


def test_addressed_message_reaches_only_its_recipient():
    channel = Channel(AGENTS)
    channel.send("a1", [1.0], recipient="a2")
    channel.deliver(spread(), np.random.default_rng(0), 0)
    assert {a: len(channel.inbox(a)) for a in AGENTS} == {"a0": 0, "a1": 0, "a2": 1, "a3": 0}
    assert channel.inbox("a2")[0].recipient == "a2"


def test_broadcast_reaches_every_other_present_agent():
    channel = Channel(AGENTS)
    channel.send("a0", [1.0])
    positions = spread()
    del positions["a3"]  # removed robot
    channel.deliver(positions, np.random.default_rng(0), 0)
    assert {a: len(channel.inbox(a)) for a in AGENTS} == {"a0": 0, "a1": 1, "a2": 1, "a3": 0}
    assert channel.dropped["absent"].sum() == 0, "absent agents are not receivers of a broadcast"


def test_absent_agents_neither_send_nor_receive_and_array_positions_mark_them_with_nan():
    channel = Channel(AGENTS)
    positions = np.array([[0.0, 0.0], [1.0, 0.0], [np.nan, np.nan], [2.0, 0.0]])
    channel.send("a2", [1.0])  # absent sender
    channel.send("a0", [2.0], recipient="a2")  # absent recipient
    channel.send("a1", [3.0])
    channel.deliver(positions, np.random.default_rng(0), 0)
    assert {a: [m.sender for m in channel.inbox(a)] for a in AGENTS} == {"a0": ["a1"], "a1": [], "a2": [], "a3": ["a1"]}
    assert channel.dropped["absent"].tolist() == [1, 0, 1, 0]


def test_receiver_removed_during_latency_gets_nothing():
    channel = Channel(AGENTS[:2], ChannelConfig(latency=1))
    rng = np.random.default_rng(0)
    channel.send("a0", [1.0])
    channel.deliver(spread(2), rng, 0)
    channel.deliver({"a0": (0.0, 0.0)}, rng, 1)
    assert channel.inbox("a1") == [] and channel.stats("a0")["dropped_absent"] == 1


def test_inbox_order_and_overflow():
    channel = Channel(AGENTS, ChannelConfig(inbox_size=3))
    channel.send("a2", [20.0])
    channel.send("a1", [10.0])
    channel.send("a2", [21.0])
    channel.send("a1", [11.0])
    channel.deliver(spread(), np.random.default_rng(0), 0)
    assert [m.payload[0] for m in channel.inbox("a0")] == [10.0, 11.0, 20.0]
    assert channel.dropped["inbox"].tolist() == [0, 0, 2, 0]  # a2's second message, at a0 and at a3
    assert [m.payload[0] for m in channel.inbox("a3")] == [10.0, 11.0, 20.0]


# ---------------------------------------------------------------- inbox arrays


def test_inbox_array_packs_pads_and_filters():
    channel = Channel(AGENTS)
    channel.send("a2", [1.0, 2.0], kind="learned")
    channel.send("a1", [3.0], kind="perception")
    channel.deliver(spread(), np.random.default_rng(0), 0)
    packed = channel.inbox_array("a0", width=3, capacity=4)
    assert packed.payload.dtype == np.float32 and packed.payload.shape == (4, 3)
    assert packed.payload.tolist() == [[3.0, 0, 0], [1.0, 2.0, 0], [0, 0, 0], [0, 0, 0]]
    assert packed.mask.dtype == np.int8 and packed.mask.tolist() == [1, 1, 0, 0]
    assert packed.sender.tolist() == [1, 2, -1, -1]
    payload, mask, sender = channel.inbox_array("a0", width=2, capacity=1, kind="learned")
    assert payload.tolist() == [[1.0, 2.0]] and mask.tolist() == [1] and sender.tolist() == [2]
    with pytest.raises(ValueError, match="'a2'.*width=1"):
        channel.inbox_array("a0", width=1, capacity=4)


# ---------------------------------------------------------------- determinism and copies


def test_same_seed_gives_same_deliveries():
    runs = [random_traffic(Channel(AGENTS, LOSSY), np.random.default_rng(7), np.random.default_rng(8), 40) for _ in range(2)]
    assert runs[0] == runs[1]
    assert any(any(inbox for inbox in step.values()) for step in runs[0])
    other = random_traffic(Channel(AGENTS, LOSSY), np.random.default_rng(7), np.random.default_rng(9), 40)
    assert other != runs[0]


@pytest.mark.parametrize("clone", [copy.deepcopy, lambda obj: pickle.loads(pickle.dumps(obj))], ids=["deepcopy", "pickle"])
def test_copies_continue_identically(clone):
    channel, traffic, rng = Channel(AGENTS, LOSSY), np.random.default_rng(3), np.random.default_rng(4)
    random_traffic(channel, traffic, rng, 15)
    channel.send("a0", [1.0, 2.0])  # pending at copy time
    twin, twin_traffic, twin_rng = clone(channel), clone(traffic), clone(rng)
    assert all(m.payload.flags.writeable is False for a in AGENTS for m in twin.inbox(a))
    assert random_traffic(twin, twin_traffic, twin_rng, 25, start=15) == random_traffic(channel, traffic, rng, 25, start=15)
    assert all_stats(twin) == all_stats(channel)


def test_reset_forgets_everything():
    channel = Channel(AGENTS, LOSSY)
    random_traffic(channel, np.random.default_rng(3), np.random.default_rng(4), 10)
    channel.reset()
    assert all(v == 0 for stats in all_stats(channel).values() for v in stats.values())
    channel.deliver(spread(), np.random.default_rng(0), 0)  # step numbering restarts
    assert all(channel.inbox(a) == [] for a in AGENTS)


# ---------------------------------------------------------------- counters


def test_counters_add_up_on_a_perfect_channel():
    channel = Channel(AGENTS, ChannelConfig(inbox_size=100))
    received = random_traffic(channel, np.random.default_rng(5), np.random.default_rng(6), 30)
    sizes = [m[3] for step in received for inbox in step.values() for m in inbox]
    assert channel.bytes_delivered.sum() == sum(sizes)
    assert channel.messages_delivered.sum() == len(sizes)


def test_broadcast_counters_add_up_under_loss():
    channel = Channel(AGENTS, ChannelConfig(throughput=0.5, comm_range=1.5, inbox_size=2))
    rng, traffic = np.random.default_rng(0), np.random.default_rng(1)
    for step in range(50):
        for _ in range(3):
            channel.send(AGENTS[int(traffic.integers(4))], traffic.normal(size=2))
        channel.deliver(traffic.uniform(0, 2, size=(4, 2)), rng, step)
    copies = (len(AGENTS) - 1) * channel.messages_sent.sum()
    dropped = sum(channel.dropped[r].sum() for r in ("range", "loss", "inbox", "absent"))
    assert min(channel.dropped[r].sum() for r in ("range", "loss", "inbox")) > 0
    assert channel.messages_delivered.sum() + dropped == copies
    assert channel.bytes_delivered.sum() == 8 * channel.messages_delivered.sum()
    assert channel.bytes_sent.sum() == 8 * channel.messages_sent.sum()
    stats = channel.stats("a0")
    assert stats["messages_dropped"] == sum(stats[f"dropped_{r}"] for r in ("budget", "range", "loss", "inbox", "absent"))


def test_perfect_broadcast_delivers_bytes_to_every_other_agent():
    channel = Channel(AGENTS)
    channel.send("a0", [1.0, 2.0, 3.0])
    channel.send("a3", [1.0], size=100)
    channel.deliver(spread(), np.random.default_rng(0), 0)
    assert channel.bytes_sent.tolist() == [12, 0, 0, 100]
    assert channel.bytes_delivered.tolist() == [100, 112, 112, 12]
    assert channel.bytes_delivered.sum() == (len(AGENTS) - 1) * channel.bytes_sent.sum()


# ---------------------------------------------------------------- messages


def test_message_defaults_and_read_only_payload():
    source = np.array([1.0, 2.0])
    message = Message("a0", None, source, kind="learned", sent_step=4)
    source[0] = 9.0
    assert message.payload.dtype == np.float32 and message.payload.tolist() == [1.0, 2.0]
    assert message.size == 8
    with pytest.raises(ValueError):
        message.payload[0] = 3.0
    assert message == Message("a0", None, [1.0, 2.0], 8, "learned", 4)
    assert message != Message("a0", None, [1.0, 2.5], 8, "learned", 4)


# ---------------------------------------------------------------- bad input


def snapshot(channel):
    """Observable state: what a deep copy receives and counts in the next two steps."""
    twin = copy.deepcopy(channel)
    rng = np.random.default_rng(99)
    out = []
    for step in (10**6, 10**6 + 1):  # later than any step the tests use
        twin.deliver(spread(), rng, step)
        out.append((inbox_keys(twin), all_stats(twin)))
    return out


def busy_channel():
    channel = Channel(AGENTS, LOSSY)
    random_traffic(channel, np.random.default_rng(3), np.random.default_rng(4), 5)
    channel.send("a1", [0.5])
    return channel


def assert_one_line_error(error_type, names, call, channel):
    before = snapshot(channel)
    with pytest.raises(error_type) as caught:
        call()
    text = str(caught.value)
    assert "\n" not in text
    for name in names:
        assert name in text
    assert snapshot(channel) == before


@pytest.mark.parametrize(
    ("kwargs", "error_type", "culprit"),
    [
        ({"sender": "ghost"}, KeyError, "'ghost'"),
        ({"recipient": "nobody"}, KeyError, "'nobody'"),
        ({"recipient": "a1"}, ValueError, "'a1'"),  # addressed to itself
        ({"payload": [[1.0]]}, ValueError, "1-D"),
        ({"payload": ["x"]}, TypeError, "numeric"),
        ({"size": 2.5}, TypeError, "2.5"),
        ({"kind": 3}, TypeError, "kind"),
    ],
)
def test_bad_send_names_the_culprit_and_changes_nothing(kwargs, error_type, culprit):
    channel = busy_channel()
    args = {"sender": "a1", "payload": [1.0], "recipient": None} | kwargs
    assert_one_line_error(error_type, [culprit], lambda: channel.send(**args), channel)


@settings(max_examples=60, deadline=None)
@given(
    good=st.lists(st.floats(-1e30, 1e30), max_size=4),
    bad=st.sampled_from([math.nan, math.inf, -math.inf, 1e39]),
    where=st.integers(0, 4),
)
def test_non_finite_payload_is_rejected(good, bad, where):
    channel = busy_channel()
    payload = good[:where] + [bad] + good[where:]
    assert_one_line_error(ValueError, ["'a2'", "non-finite"], lambda: channel.send("a2", payload), channel)


@settings(max_examples=40, deadline=None)
@given(size=st.integers(max_value=-1))
def test_negative_size_is_rejected(size):
    channel = busy_channel()
    assert_one_line_error(ValueError, ["'a0'", str(size)], lambda: channel.send("a0", [1.0], size=size), channel)


@pytest.mark.parametrize(
    "positions",
    [{"ghost": (0.0, 0.0)}, {"a0": (math.nan, 0.0)}, {"a0": (1.0,)}, np.zeros((3, 2))],
    ids=["unknown", "nan", "short", "shape"],
)
def test_bad_deliver_changes_nothing(positions):
    channel = busy_channel()
    error = KeyError if "ghost" in positions else ValueError
    assert_one_line_error(error, [], lambda: channel.deliver(positions, np.random.default_rng(0), 100), channel)


def test_deliver_rejects_repeated_step_and_foreign_rng():
    channel = busy_channel()
    assert_one_line_error(ValueError, ["step=4"], lambda: channel.deliver(spread(), np.random.default_rng(0), 4), channel)
    assert_one_line_error(TypeError, ["rng"], lambda: channel.deliver(spread(), np.random.RandomState(0), 5), channel)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("comm_range", -1.0),
        ("comm_range", math.nan),
        ("throughput", 1.5),
        ("throughput", -0.1),
        ("throughput", math.nan),
        ("latency", -1),
        ("latency", 1.5),
        ("byte_budget", -5),
        ("inbox_size", 0),
        ("inbox_size", True),
    ],
)
def test_invalid_config_names_field_and_value(field, value):
    config = ChannelConfig(**{field: value})
    with pytest.raises(ValueError, match=f"{field}={value!r}") as caught:
        config.check()
    assert "\n" not in str(caught.value)
    with pytest.raises(ValueError, match=field):
        Channel(AGENTS, config)


@settings(max_examples=50, deadline=None)
@given(
    throughput=st.floats(allow_nan=True, allow_infinity=True),
    latency=st.integers(-5, 5),
    inbox_size=st.integers(-5, 5),
)
def test_config_check_accepts_exactly_the_valid_values(throughput, latency, inbox_size):
    config = ChannelConfig(throughput=throughput, latency=latency, inbox_size=inbox_size)
    valid = 0 <= throughput <= 1 and latency >= 0 and inbox_size >= 1
    if valid:
        config.check()
    else:
        with pytest.raises(ValueError, match="ChannelConfig: (throughput|latency|inbox_size)="):
            config.check()


def test_bad_agent_lists():
    with pytest.raises(ValueError, match="unique"):
        Channel(["a", "a"])
    with pytest.raises(ValueError, match="at least one"):
        Channel([])
    with pytest.raises(KeyError, match="'zz'"):
        Channel(AGENTS).stats("zz")


# ---------------------------------------------------------------- env-generated arrays


def test_send_array_delivers_and_counts_as_send_does():
    sent, packed = Channel(AGENTS, LOSSY), Channel(AGENTS, LOSSY)
    traffic = np.random.default_rng(11)
    rngs = np.random.default_rng(12), np.random.default_rng(12)
    for step in range(30):
        for _ in range(int(traffic.integers(0, 5))):
            sender = AGENTS[int(traffic.integers(len(AGENTS)))]
            payload = traffic.normal(size=int(traffic.integers(0, 4))).astype(np.float32)
            size, kind = int(traffic.integers(0, 12)), str(traffic.choice(["perception", "learned"]))
            assert sent.send(sender, payload, size=size, kind=kind) == packed.send_array(sender, payload.copy(), size, kind)
        positions = {a: tuple(traffic.uniform(0, 2, size=2)) for a in AGENTS}
        for channel, rng in zip((sent, packed), rngs):
            channel.deliver(positions, rng, step)
        assert inbox_keys(packed) == inbox_keys(sent)
        for agent in AGENTS:
            expected = [(AGENTS.index(m.sender), m.payload.tolist()) for m in sent.inbox(agent) if m.kind == "perception"]
            assert [(s, p.tolist()) for s, p in packed.inbox_payloads(agent, "perception")] == expected
    assert all_stats(packed) == all_stats(sent)


def test_send_array_keeps_the_array_read_only():
    channel = Channel(AGENTS)
    payload = np.array([1.0, 2.0], dtype=np.float32)
    channel.send_array("a0", payload, 8, "perception")
    assert not payload.flags.writeable
    channel.deliver(spread(), np.random.default_rng(0), 0)
    (sender, received), *_ = channel.inbox_payloads("a1", "perception")
    assert sender == 0 and received.tolist() == [1.0, 2.0] and not received.flags.writeable


@pytest.mark.parametrize(
    ("args", "error_type", "culprit"),
    [
        (("ghost", np.zeros(2, np.float32), 8, "k"), KeyError, "'ghost'"),
        (("a1", [1.0, 2.0], 8, "k"), TypeError, "float32"),
        (("a1", np.zeros(2), 8, "k"), TypeError, "float32"),
        (("a1", np.zeros((2, 2), np.float32), 8, "k"), TypeError, "1-D"),
        (("a1", np.zeros(2, np.float32), 2.5, "k"), TypeError, "2.5"),
        (("a1", np.zeros(2, np.float32), -1, "k"), ValueError, "-1"),
        (("a1", np.zeros(2, np.float32), 8, 3), TypeError, "kind"),
    ],
)
def test_bad_send_array_names_the_culprit_and_changes_nothing(args, error_type, culprit):
    channel = busy_channel()
    assert_one_line_error(error_type, [culprit], lambda: channel.send_array(*args), channel)
