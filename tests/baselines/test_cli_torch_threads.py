"""The CLIs that play SB3 policies in-process run torch on one thread (as ``baselines.evaluate``'s does)."""

from __future__ import annotations

import pytest

torch = pytest.importorskip("torch")

import baselines.rl.compare as compare_module  # noqa: E402


@pytest.fixture
def two_threads():
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    yield
    torch.set_num_threads(before)


def test_single_thread_torch_sets_one_thread(two_threads):
    compare_module.single_thread_torch()
    assert torch.get_num_threads() == 1


def test_compare_cli_plays_its_episodes_on_one_torch_thread(two_threads, monkeypatch, capsys):
    seen = []

    def playing(*args, **kwargs):
        seen.append(torch.get_num_threads())
        raise RuntimeError("stop before any episode")

    monkeypatch.setattr(compare_module, "compare", playing)
    assert compare_module.main(["--env", "Navigation-v0", "--episodes", "1"]) == 1
    assert seen == [1]
    assert "stop before any episode" in capsys.readouterr().err
