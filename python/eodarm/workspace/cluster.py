"""A sweep's chunks on a Dask cluster: submitted a window at a time, gathered as they finish,
and a cluster that cannot finish is one clear error.

A worker lost while it runs chunks costs time, not the result: the scheduler runs its chunks
again elsewhere. A cluster that lost all its workers (or its scheduler), or whose workers keep
dying on a chunk, raises :class:`~eodarm.errors.ClusterError` in one line
(``docs/sweeps.md``, "A Dask cluster that loses workers").
"""

from __future__ import annotations

import asyncio
import itertools
import time
import uuid
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import CancelledError
from typing import Any, TypeVar

from eodarm.errors import ClusterError

__all__ = ["CLUSTER_POLL_S", "NO_WORKERS_GRACE_S", "lost", "run_chunks", "threads"]

R = TypeVar("R")

#: Seconds between checks that a Dask cluster still has workers while no chunk comes back.
CLUSTER_POLL_S = 1.0
#: Seconds a cluster that had workers may have none before the sweep gives up on it.
NO_WORKERS_GRACE_S = 30.0


def run_chunks(
    client: Any, chunk: Callable[[Any, int, int], R], job: Any, spans: Iterable[tuple[int, int]]
) -> Iterator[tuple[tuple[int, int], R]]:
    """``chunk(job, start, stop)`` for every span on a ``distributed.Client``; (span, result)
    in the order they finish, a window of chunks in flight (``spans`` is read lazily).

    ``job`` is scattered to every worker once. A worker lost while running a chunk costs
    nothing: the scheduler runs its chunks again elsewhere and the result is the same. A
    cluster that cannot finish raises
    :class:`~eodarm.errors.ClusterError` in one line: every worker gone for
    ``NO_WORKERS_GRACE_S`` (after having had some), chunks cancelled (the scheduler lost), or a
    chunk whose workers kept dying (Dask's ``KilledWorker``).
    """
    from distributed import KilledWorker, wait

    [remote_job] = client.scatter([job], broadcast=True)
    tag = uuid.uuid4().hex  # task keys unique to this sweep
    todo = iter(spans)
    window = max(8, 4 * threads(client))
    pending: dict[Any, tuple[int, int]] = {}
    had_workers, none_since, returned = False, None, 0
    try:
        while True:
            for a, b in itertools.islice(todo, window - len(pending)):
                key = f"eodarm-sweep-{tag}-{a}"
                pending[client.submit(chunk, remote_job, a, b, pure=False, key=key)] = (a, b)
            if not pending:
                return
            try:
                finished = wait(
                    list(pending), timeout=CLUSTER_POLL_S, return_when="FIRST_COMPLETED"
                )
                done = finished.done
            except TimeoutError:
                done = set()
            except (CancelledError, asyncio.CancelledError) as exc:
                raise lost(exc, returned) from None
            if not done:
                workers = threads(client, count_workers=True)
                had_workers |= workers > 0
                if workers > 0 or not had_workers:
                    none_since = None
                    continue
                none_since = time.monotonic() if none_since is None else none_since
                if time.monotonic() - none_since >= NO_WORKERS_GRACE_S:
                    raise ClusterError(
                        f"the Dask cluster lost all its workers: none for "
                        f"{NO_WORKERS_GRACE_S:g} s with {len(pending)} chunks in flight "
                        f"({returned} came back)"
                    )
                continue
            had_workers, none_since = True, None
            for fut in done:
                span = pending.pop(fut)
                if fut.status == "error":
                    failure = fut.exception()
                    if isinstance(failure, KilledWorker):
                        raise ClusterError(
                            f"the Dask cluster's workers kept dying on the chunk of poses "
                            f"{span[0]}:{span[1]}: {' '.join(str(failure).split())}"
                        ) from None
                try:  # an error of the chunk itself is raised here, as it is
                    res = fut.result()
                except (CancelledError, asyncio.CancelledError) as exc:
                    raise lost(exc, returned) from None
                fut.release()
                returned += 1
                yield span, res
    finally:
        if pending:
            client.cancel(list(pending))


def lost(exc: BaseException, returned: int) -> ClusterError:
    """The error of chunks cancelled under a sweep: the scheduler lost them, or the job every
    chunk needs, with the workers that held it (or the client lost the scheduler)."""
    groups = getattr(exc, "error_groups", None)  # FuturesCancelledError: several futures
    reasons = [str(g.reason) for g in groups] if groups else [str(getattr(exc, "reason", ""))]
    reason = ", ".join(dict.fromkeys(r for r in reasons if r)) or "reason unknown"
    return ClusterError(
        f"the Dask cluster lost all its workers: the sweep's chunks were cancelled (reason: "
        f"{reason}); "
        f"{returned} chunks had come back"
    )


def threads(client: Any, count_workers: bool = False) -> int:
    """Threads (or workers) of a Dask client's cluster; 0 when it cannot be asked."""
    try:
        nthreads = client.nthreads()
    except Exception:  # a lost scheduler: no workers either
        return 0
    return len(nthreads) if count_workers else int(sum(nthreads.values()))
