"""Scale-out beyond one machine: a two-node Ray cluster on this host runs ``baselines.evaluate --workers
ray`` and an RLlib iteration.

The cluster is what ``ray start`` makes on real machines, here on one host: a head node
(``ray start --head``) and a second node that joins it (``ray start --address``), one CPU each,
each with its own ``--temp-dir``, every process and client in a private network namespace whose
only interface is the loopback one (:class:`tests.loopback_ns.LoopbackNamespace`): Ray picks the
node address, and in this namespace it can only be 127.0.0.1 (a fresh namespace also has every
port free). The commands are the ones a user runs against a real cluster, with ``--ray-address``
and Ray's token authentication (``RAY_AUTH_MODE=token``, one ``RAY_AUTH_TOKEN`` for every node
and driver). The cluster is stopped with ``ray stop --force`` inside the namespace (which sees
only its own processes) and the namespace is then killed, taking anything left with it.

Marked ``rllib``: runs in ``bash scripts/run_tests_rllib.sh`` (its own venv with ray[rllib]); skipped
where Linux namespaces cannot be made (in CI, ``CI`` set, that is a failure instead).
"""

import json
import os
import secrets
import shutil
import sys
import tempfile
from pathlib import Path

import pytest

from baselines import evaluate as evaluation
from tests.loopback_ns import LoopbackNamespace, available
from tests.rllib_support import TINY, needs_rllib

pytestmark = [pytest.mark.rllib, needs_rllib]

ROOT = Path(__file__).resolve().parents[2]
ADDRESS = "127.0.0.1:6379"
#: Bounds (seconds) of the commands: a node's start, a driver's query, an evaluation, an RLlib iteration.
START, QUERY, EVALUATE, TRAIN = 90, 60, 180, 240

#: Prints the cluster's alive nodes as JSON once there are two (or after 30 s).
NODES = """
import json, sys, time
import ray
ray.init(address=sys.argv[1], logging_level="ERROR")
deadline = time.monotonic() + 30
while len(alive := [n for n in ray.nodes() if n["Alive"]]) < 2 and time.monotonic() < deadline:
    time.sleep(0.5)
print(json.dumps([
    {"id": n["NodeID"], "ip": n["NodeManagerAddress"], "cpus": n["Resources"].get("CPU"),
     "head": "node:__internal_head__" in n["Resources"]}
    for n in alive
]))
"""


class Cluster:
    """The running cluster: its namespace, the environment its commands run with, its nodes."""

    def __init__(self, ns: LoopbackNamespace, env: dict[str, str], nodes: list[dict]) -> None:
        self.ns, self.env, self.nodes = ns, env, nodes
        self.node_ids = sorted(node["id"] for node in nodes)

    def python(self, *args: str, timeout: float) -> str:
        """``python ARGS`` on the cluster's side (a driver); its standard output."""
        return self.ns.run([sys.executable, *args], timeout=timeout, env=self.env, cwd=ROOT).stdout


def _ray_start(ns: LoopbackNamespace, env: dict[str, str], temp_dir: str, *args: str) -> None:
    ray = str(Path(sys.executable).with_name("ray"))
    small = ["--node-ip-address=127.0.0.1", "--num-cpus=1", "--object-store-memory=100000000", "--disable-usage-stats"]
    ns.run([ray, "start", *small, f"--temp-dir={temp_dir}", *args], timeout=START, env=env, cwd=ROOT)


@pytest.fixture(scope="module")
def cluster():
    """A head node and a second node joined to it, 1 CPU each, loopback only; stopped and killed after the module."""
    reason = available()
    if reason is not None:
        (pytest.fail if os.environ.get("CI") else pytest.skip)(f"cannot make a loopback-only namespace: {reason}")
    env = {key: value for key, value in os.environ.items() if key != "RAY_ADDRESS"}
    env.update(RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=secrets.token_hex(32), RAY_USAGE_STATS_ENABLED="0")
    env["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "1"  # multi-node on (run_tests_rllib.sh turns it off outside)
    temp_dirs = [tempfile.mkdtemp(prefix=f"ray{i}-", dir="/tmp") for i in range(2)]  # short: Unix socket paths
    ns = LoopbackNamespace()
    try:
        _ray_start(ns, env, temp_dirs[0], "--head", f"--port={ADDRESS.split(':')[1]}", "--include-dashboard=false")
        _ray_start(ns, env, temp_dirs[1], f"--address={ADDRESS}", "--dashboard-agent-listen-port=52366")
        nodes = json.loads(ns.run([sys.executable, "-c", NODES, ADDRESS], timeout=QUERY, env=env).stdout.splitlines()[-1])
        yield Cluster(ns, env, nodes)
    finally:
        ray = str(Path(sys.executable).with_name("ray"))
        try:
            ns.run([ray, "stop", "--force"], timeout=60, env=env, check=False)
        finally:
            ns.close()
            for path in temp_dirs:
                shutil.rmtree(path, ignore_errors=True)
    assert not ns.alive()


def test_the_cluster_has_two_alive_nodes_on_loopback_only(cluster):
    assert len(cluster.nodes) == 2 and len(set(cluster.node_ids)) == 2
    assert [node["head"] for node in cluster.nodes].count(True) == 1
    assert all(node["ip"] == "127.0.0.1" and node["cpus"] == 1 for node in cluster.nodes)
    listening = cluster.ns.listening()
    assert ("127.0.0.1", 6379) in listening  # the head's GCS
    assert all(address in ("127.0.0.1", "::1") for address, _ in listening), listening


def test_evaluate_on_two_nodes_equals_one_worker(cluster, tmp_path):
    common = ["--env", "Navigation-v0", "--policy", "goto", "--episodes", "8", "--seed", "3", "--max-cycles", "120"]
    common += ["--quiet", "--no-plot"]
    ray_out, one_out = tmp_path / "ray", tmp_path / "one"
    cluster.python(
        "-m", "baselines.evaluate", *common, "--workers", "ray", "--ray-address", ADDRESS, "--out", str(ray_out), timeout=EVALUATE
    )
    assert evaluation.main([*common, "--workers", "1", "--out", str(one_out)]) == 0
    assert (ray_out / "episodes.csv").read_text() == (one_out / "episodes.csv").read_text()
    on_ray, one = (json.loads((out / "summary.json").read_text()) for out in (ray_out, one_out))
    assert on_ray.pop("workers") == "ray" and one.pop("workers") == 1
    episodes_per_node = on_ray.pop("ray_nodes")
    assert sorted(episodes_per_node) == cluster.node_ids  # an actor on each node ran episodes
    assert all(count >= 1 for count in episodes_per_node.values()) and sum(episodes_per_node.values()) == 8
    assert on_ray == one


def test_one_rllib_iteration_with_an_env_runner_on_each_node(cluster, tmp_path):
    out = tmp_path / "nav"
    hp = [f"--hp={key}={value}" for key, value in TINY.items()]
    args = ["--env", "Navigation-v0", "--iterations", "1", "--set", "max_cycles=50", *hp, "--env-runners", "2"]
    printed = cluster.python("-m", "baselines.rl.rllib", *args, "--ray-address", ADDRESS, "--out", str(out), timeout=TRAIN)
    assert "iteration 1:" in printed and f"saved {out}" in printed
    sidecar = json.loads((out / "teamgym.json").read_text())
    assert sorted(sidecar["env_runner_nodes"]) == cluster.node_ids  # one CPU per node: one runner on each
    (row,) = sidecar["history"]
    assert row["env_steps"] >= TINY["train_batch_size_per_learner"] and row["episodes"] >= 2
    assert (out / "learner_group" / "learner" / "rl_module" / "shared").is_dir()
