"""A/B helper of the benchmarks: one worker process per checkout, asked for jobs in turn.

A benchmark script calls :func:`serve` when run with ``--worker`` (it answers one JSON
request per stdin line with one JSON line) and, as the parent, starts a :class:`Worker` per
checkout (``PYTHONPATH`` set to it, so the worker imports that checkout's ``teamgym`` and
``baselines``) and sends each the same requests, alternating which goes first.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any


def serve(handle: Callable[[dict], Any]) -> None:
    """Worker loop: first a line naming the imported teamgym, then ``handle(request)`` for every stdin line."""
    import teamgym

    print(json.dumps({"teamgym": teamgym.__file__}), flush=True)
    for line in sys.stdin:
        print(json.dumps(handle(json.loads(line))), flush=True)


class Worker:
    """``python script --worker *options`` importing the packages of ``checkout``."""

    def __init__(self, script: str, checkout: Path, options: list[str]) -> None:
        path = os.pathsep.join([str(checkout), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        environment = {**os.environ, "PYTHONPATH": path}
        environment.setdefault("SDL_VIDEODRIVER", "dummy")
        command = [sys.executable, script, "--worker", *options]
        self.checkout = checkout
        self.process = subprocess.Popen(command, env=environment, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self.package = Path(self._read()["teamgym"]).parents[1]

    def _read(self) -> Any:
        line = self.process.stdout.readline()
        if not line:
            raise RuntimeError(f"the worker for {self.checkout} exited")
        return json.loads(line)

    def ask(self, request: dict) -> Any:
        """Send one request and wait for its answer."""
        self.process.stdin.write(json.dumps(request) + "\n")
        self.process.stdin.flush()
        return self._read()

    def close(self) -> None:
        self.process.stdin.close()
        self.process.wait()


def start_workers(script: str, root: Path, baseline: Path | None, options: list[str]) -> list[Worker]:
    """A worker for ``root`` and, with ``baseline``, one for it (raises ``ValueError`` if it holds no teamgym)."""
    if baseline is not None and not (baseline / "teamgym" / "__init__.py").is_file():
        raise ValueError(f"--baseline {baseline} holds no teamgym package")
    workers = [Worker(script, root, options)]
    if baseline is not None:
        workers.append(Worker(script, baseline.resolve(), options))
    return workers


def in_turn(workers: list[Worker], round_: int, request: dict) -> dict[int, Any]:
    """Ask every worker ``request``, the first first in even rounds and last in odd ones; answers by worker index."""
    order = range(len(workers)) if round_ % 2 == 0 else reversed(range(len(workers)))
    return {w: workers[w].ask(request) for w in order}
