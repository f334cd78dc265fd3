"""A private network and process namespace for tests that start servers (``tests/baselines/test_ray_cluster.py``).

:class:`LoopbackNamespace` starts a holder process in new network, PID and mount namespaces
(``unshare --net --pid --mount-proc``): the only network interface there is the loopback one
(brought up by the holder), so whatever runs inside can reach 127.0.0.1 and nothing else, and
its process table holds only what was started inside. ``run`` starts a command inside
(``nsenter``); ``close`` kills the holder, the namespace's init, and the kernel then kills every
process left inside. Needs root or unprivileged user namespaces, and util-linux's ``unshare``
and ``nsenter``; :func:`available` says whether this machine has them.
"""

from __future__ import annotations

import ctypes
import ipaddress
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

#: The namespace's init: brings the loopback interface up (SIOCGIFFLAGS/SIOCSIFFLAGS), says so, then reaps orphans.
_HOLDER = """
import fcntl, os, socket, struct, sys, time
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
flags = struct.unpack('16sH', fcntl.ioctl(s, 0x8913, struct.pack('16sH', b'lo', 0)))[1]
fcntl.ioctl(s, 0x8914, struct.pack('16sH', b'lo', flags | 0x1))
print('up', flush=True)
while True:
    try:
        os.waitpid(-1, 0)
    except ChildProcessError:
        time.sleep(0.2)
"""


def _user_flags() -> list[str]:
    """Without root, a user namespace (mapped to root) makes the other namespaces."""
    return [] if os.geteuid() == 0 else ["--user", "--map-root-user"]


def available() -> str | None:
    """``None`` if a :class:`LoopbackNamespace` can be made here, else why not."""
    for tool in ("unshare", "nsenter"):
        if shutil.which(tool) is None:
            return f"{tool} (util-linux) is not installed"
    probe = ["unshare", *_user_flags(), "--net", "--pid", "--fork", "--mount-proc", "true"]
    try:
        done = subprocess.run(probe, capture_output=True, text=True, timeout=30, check=False)
    except (OSError, subprocess.TimeoutExpired) as error:
        return f"unshare failed: {error}"
    return None if done.returncode == 0 else f"unshare cannot make namespaces here: {done.stderr.strip()}"


def _die_with_parent() -> None:
    """In the child before exec: get SIGKILL when the parent dies (``PR_SET_PDEATHSIG``), so a killed test run
    takes ``unshare``, and with it the namespace, along."""
    ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)


def _children(pid: int) -> list[int]:
    """Host pids of the processes whose parent is ``pid``."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            status = (entry / "status").read_text()
        except OSError:
            continue
        if f"\nPPid:\t{pid}\n" in status:
            found.append(int(entry.name))
    return found


def _socket_address(text: str) -> tuple[str, int]:
    """``/proc/net/tcp*``'s ``HEX_ADDRESS:HEX_PORT`` (address in 32-bit words of host byte order) as (address, port)."""
    address, port = text.split(":")
    raw = bytes.fromhex(address)
    words = raw if sys.byteorder == "big" else b"".join(raw[i : i + 4][::-1] for i in range(0, len(raw), 4))
    ip = ipaddress.ip_address(words)
    if isinstance(ip, ipaddress.IPv6Address) and ip.ipv4_mapped is not None:
        ip = ip.ipv4_mapped
    return str(ip), int(port, 16)


class LoopbackNamespace:
    """Network, PID and mount namespaces with loopback only; commands run inside with :meth:`run`."""

    def __init__(self, timeout: float = 30.0) -> None:
        command = ["unshare", *_user_flags(), "--net", "--pid", "--fork", "--mount-proc", "--kill-child"]
        self._unshare = subprocess.Popen(
            [*command, sys.executable, "-c", _HOLDER],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=_die_with_parent,
        )
        try:
            ready = self._unshare.stdout.readline() if self._unshare.stdout else ""
            if ready.strip() != "up":
                raise RuntimeError(
                    f"the namespace holder did not start: {self._unshare.stderr.read() if self._unshare.stderr else ''}"
                )
            deadline = time.monotonic() + timeout
            holders = _children(self._unshare.pid)
            while not holders and time.monotonic() < deadline:
                time.sleep(0.1)
                holders = _children(self._unshare.pid)
            if len(holders) != 1:
                raise RuntimeError(f"expected one namespace holder under unshare, found {holders}")
            self.holder = holders[0]
        except BaseException:
            self.close()
            raise

    def command(self, argv: Sequence[str], cwd: str | Path | None = None) -> list[str]:
        """``argv`` run inside the namespaces, in directory ``cwd`` (default: the current one)."""
        enter = ["nsenter", "--target", str(self.holder), "--net", "--pid", "--mount"]
        if os.geteuid() != 0:
            enter += ["--user", "--preserve-credentials"]
        return [*enter, f"--wd={cwd or os.getcwd()}", "--", *argv]

    def run(
        self,
        argv: Sequence[str],
        *,
        timeout: float,
        env: Mapping[str, str] | None = None,
        cwd: str | Path | None = None,
        check: bool = True,
    ) -> subprocess.CompletedProcess[str]:
        """Run ``argv`` inside and wait at most ``timeout`` seconds; ``check``: raise with its output on a non-zero exit."""
        done = subprocess.run(
            self.command(argv, cwd), capture_output=True, text=True, timeout=timeout, env=None if env is None else dict(env)
        )
        if check and done.returncode != 0:
            raise AssertionError(f"{' '.join(argv)} exited {done.returncode}:\n{done.stdout}\n{done.stderr}")
        return done

    def listening(self) -> set[tuple[str, int]]:
        """The (address, port) of every TCP socket listening inside the namespace (``/proc/net/tcp``, ``tcp6``)."""
        found = set()
        for table in ("/proc/net/tcp", "/proc/net/tcp6"):
            for line in self.run(["cat", table], timeout=30).stdout.splitlines()[1:]:
                local, state = line.split()[1], line.split()[3]
                if state == "0A":  # TCP_LISTEN
                    found.add(_socket_address(local))
        return found

    def alive(self) -> bool:
        """Whether the namespace's init still runs."""
        return self._unshare.poll() is None

    def close(self) -> None:
        """Kill the holder (and so every process in the namespace); wait until it is gone."""
        if self._unshare.poll() is None:
            self._unshare.send_signal(signal.SIGKILL)  # --kill-child: the kernel then kills the holder
        self._unshare.wait(timeout=30)
        holder = getattr(self, "holder", None)
        deadline = time.monotonic() + 30
        while holder is not None and Path(f"/proc/{holder}").exists() and time.monotonic() < deadline:
            time.sleep(0.1)

    def __enter__(self) -> LoopbackNamespace:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
