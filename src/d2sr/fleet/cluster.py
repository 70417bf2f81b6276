"""Where a fleet runs: a local Ray cluster started for it, or one the user started (``ray start --head``)
joined at its address. An address that does not answer as a Ray cluster is refused in one line within a
few seconds (Ray itself would retry for minutes); one that speaks HTTP/2 but is not Ray's head, within
``JOIN_S`` (Ray hangs on it, or ends the process with no word)."""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import socket
import subprocess
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from d2sr.errors import ConfigError

__all__ = ["Cluster", "connected"]

PROBE_S = 5.0  # how long an address has to answer
JOIN_S = 15.0  # how long joining it may take in a child process (a real head takes a few seconds)
# Joining in a child: Ray's client retries a head that does not answer as Ray for minutes, then may end its
# process; the child's end is what tells.
_JOIN = (
    "import logging, sys, ray; "
    "ray.init(address=sys.argv[1], logging_level=logging.ERROR, log_to_driver=False); ray.shutdown()"
)
# What a gRPC server (Ray's control store) says first to a client's HTTP/2 preface: a SETTINGS frame.
_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n"
_SETTINGS = 0x4


@dataclass(frozen=True)
class Cluster:
    """``workers``: recordings repaired at once (default: a local cluster's cores, or every CPU of a
    joined cluster), each task on one core; ``address``: ``HOST:PORT`` of a running cluster's head, or
    ``auto`` (the one this machine runs); None starts a local cluster of ``workers`` cores for the run."""

    workers: int | None = None
    address: str | None = None

    def __post_init__(self) -> None:
        if self.workers is not None and self.workers < 1:
            raise ConfigError(f"workers must be at least 1, got {self.workers}", "workers")


@contextlib.contextmanager
def connected(cluster: Cluster) -> Iterator[Any]:
    """Ray, connected as ``cluster`` says, for the block: a local cluster it started is stopped at the end;
    a Ray the caller had already connected is used as it is (an address is still checked first)."""
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")  # these machines are often offline
    import ray

    address = None if cluster.address is None else _resolve(cluster.address)
    if address is not None:
        _probe(address)
        _use_token()
        _joins(address)
    if ray.is_initialized():
        yield ray
        return
    quiet: dict[str, Any] = {"logging_level": logging.ERROR, "log_to_driver": False}
    term = signal.getsignal(signal.SIGTERM)
    if address is None:
        cores = cluster.workers or os.cpu_count() or 1
        ray.init(num_cpus=cores, include_dashboard=False, **quiet)
    else:
        try:
            ray.init(address=cluster.address, **quiet)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            raise ConfigError(f"address {cluster.address}: {_first(exc)}", "address") from None
    # Ray takes SIGTERM for its own (the process then ended with exit 1 and no line): the caller's way back,
    # which unwinds as Ctrl-C does.
    if threading.current_thread() is threading.main_thread() and callable(term):
        signal.signal(signal.SIGTERM, term)
    try:
        yield ray
    finally:
        ray.shutdown()


def _use_token() -> None:
    """Present this machine's Ray token (``ray start`` makes one, ``~/.ray/auth_token``) to a cluster joined
    at its address, as Ray does by itself only for ``auto``."""
    ray_log = logging.getLogger("ray")
    level = ray_log.level
    ray_log.setLevel(logging.ERROR)  # its notice that tokens are on is no line of ours
    try:
        with contextlib.suppress(ImportError, AttributeError):
            from ray._private.authentication.authentication_token_setup import (
                maybe_enable_token_auth_if_token_available,
            )

            maybe_enable_token_auth_if_token_available(warn_if_disabled=False)
    finally:
        ray_log.setLevel(level)


def _resolve(address: str) -> str:
    """``HOST:PORT`` as given, or what ``auto`` finds (the cluster this machine runs)."""
    if address != "auto":
        return address
    from ray._private.services import canonicalize_bootstrap_address

    try:
        found = canonicalize_bootstrap_address("auto")
    except (ConnectionError, RuntimeError, ValueError) as exc:
        raise ConfigError(f"address auto: {_first(exc)}", "address") from None
    if not found:
        raise ConfigError(
            "address auto: no Ray cluster runs on this machine (start a head node with Ray's own command)",
            "address",
        )
    return str(found)


def _probe(address: str) -> None:
    """Refuse an address that is not ``HOST:PORT`` of a server that speaks gRPC, as Ray's head does."""
    host, sep, port = address.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ConfigError(f"address {address!r}: give HOST:PORT of a Ray cluster's head, or auto", "address")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=PROBE_S) as s:
            s.settimeout(PROBE_S)
            s.sendall(_PREFACE)
            head = s.recv(9)
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        raise ConfigError(f"address {address}: no Ray cluster answers there ({why})", "address") from None
    if len(head) < 9 or head[3] != _SETTINGS:
        raise ConfigError(f"address {address}: something answers there, but not a Ray cluster", "address")


def _joins(address: str) -> None:
    """Refuse an address whose server speaks HTTP/2 but does not take a Ray driver in within ``JOIN_S``."""
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    try:
        done = subprocess.run(
            [sys.executable, "-c", _JOIN, address], env=env, capture_output=True, timeout=JOIN_S
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        raise ConfigError(
            f"address {address}: something answers there, but not a Ray cluster (no Ray head took us in "
            f"within {JOIN_S:g} s)",
            "address",
        ) from None
    if done.returncode != 0:
        said = done.stderr.decode(errors="replace").strip().splitlines()
        why = said[-1][:200] if said else f"exit status {done.returncode}"
        raise ConfigError(
            f"address {address}: something answers there, but not a Ray cluster ({why})", "address"
        )


def _first(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
