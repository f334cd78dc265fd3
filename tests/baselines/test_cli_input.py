"""Bad input to the command-line tools (issue 23, round 3): one line, exit code 2, before any work.

* ``--hp`` values of ``baselines.train`` (and presets' ``hyperparameters``) are checked key by key
  before any env is built (:mod:`baselines.rl.hyperparameters`);
* ``--episodes`` of ``baselines.evaluate`` and ``baselines.rl.compare`` is bounded and seeds are
  made episode by episode;
* ``--out`` of ``baselines.rl.compare`` (and ``baselines.train``) is checked before any episode;
* an empty or blank ``--env``, ``--policy``, ``--agent`` (and the other name and path options) is
  refused instead of falling back to the default.
"""

from __future__ import annotations

import importlib
import importlib.util
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import teamgym  # noqa: E402
from baselines import evaluate as evaluate_module  # noqa: E402
from baselines.evaluate import MAX_EPISODES  # noqa: E402
from baselines.evaluate import main as evaluate_main  # noqa: E402
from baselines.rl import compare as compare_module  # noqa: E402
from baselines.rl import presets as presets_module  # noqa: E402
from baselines.rl import train as train_module  # noqa: E402
from baselines.rl.hyperparameters import check_hyperparameters, check_rollout, policy_rules, rules  # noqa: E402
from baselines.rl.sb3_policy import ALGORITHMS  # noqa: E402
from baselines.runners import Episodes, chunks  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
SMALL = ["--set", "n_robots=2", "--max-cycles", "10", "--n-envs", "1", "--verbose", "0"]


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Torch on one thread (the shared fixture in conftest.py)."""


def one_line_error(err: str, needle: str) -> None:
    assert len(err.strip().splitlines()) == 1, err
    assert "error: " in err and "Traceback" not in err, err
    assert needle in err, err


@pytest.fixture
def no_env_built(monkeypatch):
    """The ids of the envs ``teamgym.make`` builds during the test (it must build none)."""
    built: list[str] = []
    make = teamgym.make

    def spy(env_id, *args, **kwargs):
        built.append(env_id)
        return make(env_id, *args, **kwargs)

    monkeypatch.setattr(teamgym, "make", spy)
    return built


def _script(name: str):
    """An ``experiments/*.py`` script as a module."""
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, ROOT / "experiments" / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


def run_cli(name: str, args: list[str]) -> int:
    """The exit code of CLI ``name`` run in this process with ``args``."""
    mains = {
        "evaluate": evaluate_main,
        "train": train_module.main,
        "compare": compare_module.main,
        "rllib": lambda a: importlib.import_module("baselines.rl.rllib").main(a),
        "paper002": lambda a: _script("paper002_foraging").main(a),
        "paper004": lambda a: _script("paper004_box_pushing").main(a),
    }
    try:
        return mains[name](args) or 0
    except SystemExit as done:
        return done.code if isinstance(done.code, int) else 2


# -- 4: --hp values --------------------------------------------------------------------------


def test_every_keyword_of_every_offered_algorithm_has_a_rule():
    for algo in ALGORITHMS:
        unchecked = [key for key, rule in rules(algo).items() if rule is None]
        unchecked += [f"policy_kwargs.{key}" for key, rule in policy_rules(algo).items() if rule is None]
        assert not unchecked, f"{algo}: add rules for {unchecked} to baselines/rl/hyperparameters.py"


@pytest.mark.parametrize(
    ("hp", "needle"),
    [
        ("learning_rate=abc", "learning_rate='abc'"),
        ("learning_rate=-1e-4", "learning_rate=-0.0001"),
        ("learning_rate=nan", "learning_rate='nan'"),
        ("n_steps=-1", "n_steps=-1"),
        ("n_steps=2.5", "n_steps=2.5"),
        ("n_steps=True", "n_steps=True"),
        ("batch_size=1", "batch_size=1"),
        ("n_epochs=0", "n_epochs=0"),
        ("gamma=2", "gamma=2"),
        ("gamma=0", "gamma=0"),
        ("gae_lambda=1.5", "gae_lambda=1.5"),
        ("clip_range=0", "clip_range=0"),
        ("clip_range_vf=-1", "clip_range_vf=-1"),
        ("ent_coef=-0.1", "ent_coef=-0.1"),
        ("max_grad_norm=0", "max_grad_norm=0"),
        ("target_kl=0", "target_kl=0"),
        ("normalize_advantage=1", "normalize_advantage=1"),
        ("policy_kwargs=5", "policy_kwargs=5"),
        ("policy_kwargs={'net_arch': [64, 0]}", "net_arch=[64, 0]"),
        ("policy_kwargs={'net_arch': {'pi': [8], 'qf': [8]}}", "net_arch="),
        ("policy_kwargs={'ortho_init': 'yes'}", "ortho_init='yes'"),
        ("policy_kwargs={'activation_fn': 'relu'}", "activation_fn='relu'"),
        ("policy_kwargs={'bogus': 1}", "'bogus' is not a hyperparameter of PPO's policy_kwargs"),
        ("policy_kwargs={'use_sde': True}", "'use_sde' is set by training"),
        ("bogus=1", "'bogus' is not a hyperparameter of PPO"),
        ("seed=1", "'seed' is set by training"),
        ("tensorboard_log=x", "use --tensorboard"),
        ("buffer_size=10", "'buffer_size' is not a hyperparameter of PPO"),
    ],
)
def test_a_bad_hp_is_one_line_before_any_env(hp, needle, tmp_path, capsys, no_env_built):
    assert train_module.main(["--hp", hp, *SMALL, "--out", str(tmp_path / "m.zip")]) == 2
    one_line_error(capsys.readouterr().err, needle)
    assert no_env_built == [] and not any(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("algo", "hp", "needle"),
    [
        ("sac", "ent_coef=auto_0", "ent_coef='auto_0'"),
        ("sac", "tau=0", "tau=0"),
        ("sac", "train_freq=[4, 'step']", "train_freq=[4, 'step']"),
        ("sac", "gradient_steps=0", "gradient_steps=0"),
        ("sac", "optimize_memory_usage=True", "handle_timeout_termination"),
        ("sac", "policy_kwargs={'net_arch': {'pi': [8]}}", "net_arch="),
        ("td3", "policy_delay=0", "policy_delay=0"),
        ("dqn", "exploration_fraction=0", "exploration_fraction=0"),
        ("dqn", "exploration_final_eps=2", "exploration_final_eps=2"),
        ("dqn", "policy_kwargs={'net_arch': {'pi': [8]}}", "net_arch="),
        ("a2c", "rms_prop_eps=0", "rms_prop_eps=0"),
        ("maskable_ppo", "batch_size=0", "batch_size=0"),
    ],
)
def test_every_algorithm_checks_its_own_keys(algo, hp, needle, tmp_path, capsys, no_env_built):
    args = ["--algo", algo, "--hp", hp, *SMALL, "--out", str(tmp_path / "m.zip")]
    assert train_module.main(args) == 2
    one_line_error(capsys.readouterr().err, needle)
    assert no_env_built == []


def test_the_reported_command_prints_one_line_and_no_traceback(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "SDL_VIDEODRIVER": "dummy"}
    env.pop("TEAMGYM_TRACEBACK", None)
    run = subprocess.run(
        [sys.executable, "-m", "baselines.train", "--hp", "learning_rate=abc", "--hp", "n_steps=-1"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=env,
    )
    assert run.returncode == 2 and "Traceback" not in run.stderr + run.stdout
    one_line_error(run.stderr, "learning_rate='abc'")
    assert not any(tmp_path.iterdir())


def test_the_python_api_checks_before_any_env(tmp_path, no_env_built):
    with pytest.raises(ValueError, match="n_epochs=0"):
        train_module.Training(out=tmp_path / "m.zip", hyperparameters={"n_epochs": 0})
    with pytest.raises(ValueError, match="hyperparameters must map"):
        train_module.Training(out=tmp_path / "m.zip", hyperparameters=[("n_epochs", 1)])
    assert no_env_built == []


def test_good_values_pass_unchanged():
    params = {
        "learning_rate": 3e-4,
        "n_steps": 1,
        "batch_size": 2,
        "gamma": 1,
        "gae_lambda": 0,
        "clip_range": 0.2,
        "clip_range_vf": None,
        "target_kl": 0.01,
        "policy_kwargs": {"net_arch": {"pi": [64], "vf": [64, 64]}, "ortho_init": False, "log_std_init": -1},
    }
    given_params = json.loads(json.dumps(params))
    check_hyperparameters("ppo", params)
    assert params == given_params
    check_hyperparameters("ppo", {"learning_rate": lambda progress: 1e-3 * progress, "normalize_advantage": False})
    check_hyperparameters("ppo", {"batch_size": 1, "normalize_advantage": False})
    check_hyperparameters("maskable_ppo", {"batch_size": None})
    check_hyperparameters("sac", {"ent_coef": "auto_0.1", "train_freq": (1, "episode"), "gradient_steps": -1})
    check_hyperparameters("sac", {"optimize_memory_usage": True, "replay_buffer_kwargs": {"handle_timeout_termination": False}})
    check_hyperparameters("dqn", {"policy_kwargs": {"net_arch": [32, 32]}, "exploration_fraction": 1})


#: Values of every kind a command line (a Python literal or a bare string) or a preset can give.
VALUES = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**6), 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
    st.lists(st.integers(-3, 300), max_size=3),
    st.dictionaries(st.sampled_from(["net_arch", "pi", "vf", "x"]), st.integers(-1, 64), max_size=2),
    st.tuples(st.integers(-2, 5), st.sampled_from(["step", "episode", "x"])),
)
KEYS = sorted((algo, key) for algo in ALGORITHMS for key in rules(algo))


@settings(max_examples=200, deadline=None)
@given(st.sampled_from(KEYS), VALUES)
def test_any_value_is_passed_or_refused_in_one_line_naming_the_key(pair, value):
    algo, key = pair
    try:
        check_hyperparameters(algo, {key: value})
    except ValueError as error:
        assert "\n" not in str(error) and key in str(error)
    else:
        assert rules(algo)[key].accepts(value)


#: Numeric keys: (algorithm, key) -> whether a finite number is in range.
RANGES = {
    ("ppo", "gamma"): lambda v: 0 < v <= 1,
    ("ppo", "gae_lambda"): lambda v: 0 <= v <= 1,
    ("ppo", "learning_rate"): lambda v: v > 0,
    ("ppo", "clip_range"): lambda v: v > 0,
    ("ppo", "ent_coef"): lambda v: v >= 0,
    ("sac", "tau"): lambda v: 0 < v <= 1,
    ("dqn", "exploration_fraction"): lambda v: 0 < v <= 1,
    ("dqn", "exploration_initial_eps"): lambda v: 0 <= v <= 1,
}
#: Integer keys: (algorithm, key) -> least value.
LEAST = {
    ("ppo", "n_steps"): 1,
    ("ppo", "batch_size"): 2,  # advantages normalised per mini-batch (SB3's default)
    ("a2c", "n_steps"): 1,
    ("ppo", "n_epochs"): 1,
    ("sac", "buffer_size"): 1,
    ("sac", "learning_starts"): 0,
    ("dqn", "target_update_interval"): 1,
    ("ppo", "sde_sample_freq"): -1,
}


def _accepted(algo: str, key: str, value) -> bool:
    try:
        check_hyperparameters(algo, {key: value})
    except ValueError:
        return False
    return True


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(sorted(RANGES)), st.one_of(st.floats(-2, 3), st.integers(-3, 3), st.floats(), st.booleans()))
def test_numbers_are_accepted_exactly_in_their_range(pair, value):
    number = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    assert _accepted(*pair, value) == (number and RANGES[pair](value))


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(sorted(LEAST)), st.one_of(st.integers(-5, 5), st.floats(-5, 5), st.booleans()))
def test_integers_are_accepted_exactly_from_their_least_value(pair, value):
    integer = isinstance(value, int) and not isinstance(value, bool)
    assert _accepted(*pair, value) == (integer and value >= LEAST[pair])


def test_the_rollout_checks_agree_with_sb3s_asserts():
    """SB3 asserts ``n_steps * n_envs > 1`` and ``batch_size > 1``: the checks refuse exactly what it asserts on."""
    import gymnasium
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    for slots, n_steps in [(1, 1), (1, 2), (2, 1)]:
        venv = DummyVecEnv([lambda: gymnasium.make("CartPole-v1")] * slots)
        space = venv.action_space
        try:
            check_rollout("ppo", {"n_steps": n_steps, "batch_size": 2}, space, slots)
            ours = True
        except ValueError as error:
            ours = False
            assert "n_steps=1" in str(error)
        try:
            PPO("MlpPolicy", venv, n_steps=n_steps, batch_size=2, device="cpu")
            theirs = True
        except AssertionError:
            theirs = False
        assert ours == theirs == (n_steps * slots > 1)
    venv = DummyVecEnv([lambda: gymnasium.make("CartPole-v1")] * 2)
    with pytest.raises(AssertionError):
        PPO("MlpPolicy", venv, batch_size=1, device="cpu")
    with pytest.raises(ValueError, match="batch_size=1"):
        check_hyperparameters("ppo", {"batch_size": 1})
    with pytest.raises(ValueError, match="use_sde=True"):
        check_rollout("ppo", {"use_sde": True}, venv.action_space, 2)  # CartPole: Discrete actions
    with pytest.raises(ValueError, match="episodes need one SB3 env"):
        check_rollout("sac", {"train_freq": (1, "episode")}, venv.action_space, 2)


def test_use_sde_on_discrete_actions_is_refused_before_the_vecenv(tmp_path, capsys, no_env_built):
    args = ["--hp", "use_sde=True", "--set", "action_type=heading", *SMALL, "--out", str(tmp_path / "m.zip")]
    assert train_module.main(args) == 2
    one_line_error(capsys.readouterr().err, "use_sde=True")
    assert no_env_built == ["Navigation-v0"]  # the probe only: no VecEnv copies


def test_every_shipped_preset_passes_the_check():
    for name in presets_module.presets():
        preset = presets_module.load_preset(name)
        check_hyperparameters(preset.algo, preset.hyperparameters)


def test_a_preset_with_a_bad_hp_is_refused_naming_it(tmp_path, monkeypatch, capsys, no_env_built):
    data = json.loads((presets_module.PRESET_DIR / "navigation-ppo.json").read_text())
    data["hyperparameters"]["gamma"] = 1.5
    (tmp_path / "bad.json").write_text(json.dumps(data))
    monkeypatch.setattr(presets_module, "PRESET_DIR", tmp_path)
    assert train_module.main(["--preset", "bad", "--out", str(tmp_path / "m.zip")]) == 2
    one_line_error(capsys.readouterr().err, "preset 'bad': hyperparameter gamma=1.5 of PPO")
    assert no_env_built == [] and not (tmp_path / "m.zip").exists()


def test_a_resumed_run_checks_against_the_saved_values():
    saved = {"hyperparameters": {"n_steps": "32", "policy_kwargs": "{'net_arch': [64]}", "learning_rate": "<function f>"}}
    parsed = train_module._saved_hyperparameters(saved)
    assert parsed == {"n_steps": 32, "policy_kwargs": {"net_arch": [64]}, "learning_rate": "<function f>"}
    assert train_module._saved_hyperparameters({}) == {}
    check_hyperparameters("ppo", {"batch_size": 1}, base={"normalize_advantage": False})  # the model's own setting
    with pytest.raises(ValueError, match="batch_size=1"):
        check_hyperparameters("ppo", {"batch_size": 1}, base={"n_steps": 32})


@pytest.mark.parametrize(("error", "code"), [(AssertionError("an SB3 assert"), 2), (RuntimeError("torch broke"), 1)])
def test_no_failure_while_setting_up_shows_a_traceback(error, code, tmp_path, monkeypatch, capsys):
    def fail(*args, **kwargs):
        raise error

    monkeypatch.delenv("TEAMGYM_TRACEBACK", raising=False)
    monkeypatch.setattr(train_module, "Training", fail)
    assert train_module.main(["--out", str(tmp_path / "m.zip")]) == code
    one_line_error(capsys.readouterr().err, str(error))


# -- 7: --episodes -------------------------------------------------------------------------


@pytest.mark.parametrize("cli", ["evaluate", "compare"])
@pytest.mark.parametrize("episodes", ["1000000000000", str(MAX_EPISODES + 1)])
def test_episodes_above_the_maximum_are_refused(cli, episodes, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert run_cli(cli, ["--episodes", episodes]) == 2
    one_line_error(capsys.readouterr().err, f"--episodes: must be <= {MAX_EPISODES}")
    assert not any(tmp_path.iterdir())


def test_the_reported_evaluate_command_fails_at_once(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "SDL_VIDEODRIVER": "dummy"}
    run = subprocess.run(
        [sys.executable, "-m", "baselines.evaluate", "--episodes", "1000000000000"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=env,
    )
    assert run.returncode == 2 and "Traceback" not in run.stderr and "MemoryError" not in run.stderr
    one_line_error(run.stderr, "--episodes")
    assert not any(tmp_path.iterdir())


def test_the_python_api_bounds_episodes_too():
    with pytest.raises(ValueError, match=f"episodes must be in \\[1, {MAX_EPISODES}\\]"):
        evaluate_module.evaluate(episodes=MAX_EPISODES + 1)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2**40), st.integers(1, 300), st.booleans(), st.integers(1, 8))
def test_streamed_seeds_are_the_listed_ones(seed, episodes, keep_all, workers):
    listed = [(seed + i, keep_all or i == 0) for i in range(episodes)]  # what evaluate() built before
    items = Episodes(seed, keep_all, range(episodes))
    assert len(items) == episodes and list(items) == listed
    assert [items[i] for i in range(-episodes, episodes)] == listed + listed
    parts = chunks(items, workers)
    assert [pair for chunk in parts for pair in chunk] == listed
    assert parts == [] or len(parts) <= 4 * workers and all(len(c) for c in parts)


def test_seeds_of_a_huge_run_are_not_listed():
    items = Episodes(7, False, range(10**12))
    parts = chunks(items, 2)
    assert len(parts) == 8 and sum(len(c) for c in parts) == 10**12
    assert parts[0][0] == (7, True) and parts[-1][-1] == (7 + 10**12 - 1, False)
    assert all(isinstance(c, Episodes) for c in parts)  # slices, not lists


def test_evaluate_plays_the_same_seeds_as_before():
    from baselines.episode import run_episode
    from baselines.registry import make_policy

    config = {"n_robots": 2, "max_cycles": 30}
    results = evaluate_module.evaluate("Navigation-v0", "goto", episodes=3, seed=11, config=config)
    env = teamgym.make("Navigation-v0", **config)
    policy = make_policy("goto", env)
    expected = [run_episode(env, policy, 11 + i, record_trajectories=i == 0) for i in range(3)]
    env.close()
    assert [r.seed for r in results] == [11, 12, 13] and results == expected


# -- 8: --out ----------------------------------------------------------------------------------


@pytest.fixture
def nothing_played(monkeypatch):
    """Fail the test if an episode is played (``baselines.evaluate.evaluate`` or ``compare``)."""

    def played(*args, **kwargs):
        raise AssertionError("an episode was played")

    monkeypatch.setattr(evaluate_module, "evaluate", played)
    monkeypatch.setattr(compare_module, "compare", played)


@pytest.mark.parametrize("cli", ["compare", "evaluate", "train"])
def test_out_under_a_file_is_refused_before_any_episode(cli, tmp_path, capsys, nothing_played, no_env_built):
    (tmp_path / "FILE").write_text("x")
    out = tmp_path / "FILE" / ("sub.zip" if cli == "train" else "sub")
    assert run_cli(cli, ["--out", str(out)]) == 2
    one_line_error(capsys.readouterr().err, f"--out {str(out)!r} is under {str(tmp_path / 'FILE')!r}, which is a file")
    assert no_env_built == [] and [p.name for p in tmp_path.iterdir()] == ["FILE"]


@pytest.mark.parametrize("cli", ["compare", "evaluate", "train"])
def test_out_in_a_directory_that_cannot_be_written_is_refused(cli, tmp_path, monkeypatch, capsys, nothing_played):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        if os.access(locked, os.W_OK):  # root writes anywhere: deny it as a normal user would be denied
            real = os.access
            monkeypatch.setattr(os, "access", lambda path, mode, **kw: Path(path) != locked and real(path, mode, **kw))
        out = locked / ("m.zip" if cli == "train" else "sub")
        assert run_cli(cli, ["--out", str(out)]) == 2
        one_line_error(capsys.readouterr().err, f"--out {str(out)!r}: cannot write under {str(locked)!r}")
        assert not any(locked.iterdir())
    finally:
        locked.chmod(0o700)


def test_compare_checks_the_learning_curve_before_playing(tmp_path, capsys, nothing_played):
    (tmp_path / "m.zip").write_bytes(b"")
    assert run_cli("compare", ["--agent", str(tmp_path / "m.zip"), "--curve", "--out", str(tmp_path / "o")]) == 2
    one_line_error(capsys.readouterr().err, "no learning curve beside the agent")
    assert not (tmp_path / "o").exists()


# -- 9: empty names ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("cli", "args", "needle"),
    [
        ("evaluate", ["--env", ""], "argument --env: expected an env id, got ''"),
        ("evaluate", ["--env", "  "], "argument --env"),
        ("evaluate", ["--policy", ""], "argument --policy"),
        ("evaluate", ["--policy", " "], "argument --policy"),
        ("evaluate", ["--policy", "sb3:"], "argument --policy: expected a model path"),
        ("evaluate", ["--out", ""], "argument --out"),
        ("train", ["--env", ""], "argument --env"),
        ("train", ["--env", " "], "argument --env"),
        ("train", ["--resume", ""], "argument --resume"),
        ("train", ["--bc-expert", ""], "argument --bc-expert"),
        ("train", ["--preset", ""], "argument --preset"),
        ("train", ["--out", ""], "argument --out"),
        ("train", ["--tensorboard", ""], "argument --tensorboard"),
        ("compare", ["--env", ""], "argument --env"),
        ("compare", ["--agent", ""], "argument --agent"),
        ("compare", ["--agent", " "], "argument --agent"),
        ("compare", ["--out", ""], "argument --out"),
        ("rllib", ["--env", ""], "argument --env"),
        ("rllib", ["--out", " "], "argument --out"),
        ("rllib", ["--evaluate", ""], "argument --evaluate"),
        ("paper002", ["consume", "--policy", ""], "argument --policy"),
        ("paper002", ["consume", "--policy", " "], "argument --policy"),
        ("paper002", ["consume", "--policy", "nope"], "argument --policy: unknown policy 'nope'"),
        ("paper004", ["static", "--env", ""], "argument --env"),
        ("paper004", ["static", "--policies", ""], "argument --policies"),
        ("paper004", ["static", "--policies", ","], "argument --policies"),
    ],
)
def test_an_empty_name_is_an_error_not_the_default(cli, args, needle, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # the default outputs would go here
    assert run_cli(cli, args) == 2
    one_line_error(capsys.readouterr().err, needle)
    assert not any(tmp_path.iterdir())


def test_the_reported_empty_env_command_fails(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "SDL_VIDEODRIVER": "dummy"}
    run = subprocess.run(
        [sys.executable, "-m", "baselines.evaluate", "--env", ""], capture_output=True, text=True, cwd=tmp_path, env=env
    )
    assert run.returncode == 2 and run.stdout == ""
    one_line_error(run.stderr, "argument --env")
    assert not any(tmp_path.iterdir())


def test_the_python_api_refuses_an_empty_expert(tmp_path):
    with pytest.raises(KeyError, match="unknown expert ''"):
        train_module.Training(out=tmp_path / "m.zip", bc_expert="", config={"n_robots": 2}, n_envs=1)
