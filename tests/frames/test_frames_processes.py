"""Worker processes that end with their caller (``frames.overlap.processes``)."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from d2sr.errors import ConfigError
from d2sr.frames.overlap import MAX_WORKERS, processes


def _nap(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


def _double(x: int) -> int:
    return 2 * x


def test_a_pool_left_normally_finishes_its_work():
    with processes(2) as pool:
        assert list(pool.map(_double, range(5))) == [0, 2, 4, 6, 8]


def test_a_pool_left_by_an_error_cancels_what_waits_and_ends_its_workers():
    """ProcessPoolExecutor's own exit waits for every queued task: a Ctrl-C on a long job ran on for hours."""
    with pytest.raises(KeyboardInterrupt), processes(2) as pool:
        futures = [pool.submit(_nap, 600.0) for _ in range(8)]
        workers = list(pool._processes.values())
        raise KeyboardInterrupt
    # Two run and the executor hands one more to its workers' queue ahead: the other five never start.
    assert sum(f.cancelled() for f in futures) >= 5
    assert workers and all(_ended(p.pid) for p in workers)  # and the running ones were ended


def _ended(pid: int, wait_s: float = 30.0) -> bool:
    """The process is gone or dead (a zombie awaiting its reaper). Not ``Process.is_alive``: the executor's
    own thread may reap a worker first, and is_alive then reads "started" for ever."""
    end = time.monotonic() + wait_s
    while time.monotonic() < end:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except (FileNotFoundError, ProcessLookupError):
            return True
        if state in ("Z", "X"):
            return True
        time.sleep(0.05)
    return False


@pytest.mark.parametrize("workers", [0, -1, MAX_WORKERS + 1, 100_000, 2.5, True])
def test_a_pool_of_no_or_too_many_workers_is_one_config_error(workers):
    with pytest.raises(ConfigError, match="workers must be a whole number"), processes(workers):
        pass
