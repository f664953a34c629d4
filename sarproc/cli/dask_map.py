"""Independent tasks of one stage on Dask: a map-like over a client, and the --scheduler option.

Stages whose work splits into independent pure tasks take a ``mapper`` (pfa2's sub-images,
simulate's pulse blocks); their numerics stay Dask-free. ``dask_mapper(client)`` is such a mapper:
it submits the tasks, at most ``window`` ahead of the one being consumed (so a stage that writes
each result as it comes never holds the whole product in the cluster), and yields the results in
the order of the inputs, exactly as the builtin ``map`` would.
"""

from __future__ import annotations

import collections
import contextlib
import itertools
import os
import uuid
from typing import TYPE_CHECKING

import click

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable, Iterator

    from dask.distributed import Client

scheduler_option = click.option(
    "--scheduler",
    default=None,
    metavar="ADDRESS",
    help="Run the independent tasks on Dask: 'local' (a new LocalCluster, one worker per core) or the "
    "address of a running scheduler (tcp://host:8786). Default: in this process. "
    "Needs pip install 'sarproc[distributed]'.",
)


def dask_mapper(
    client: Client, key_prefix: str = "task", window: int | None = None
) -> Callable[[Callable, Iterable], Iterator]:
    """map-like callable running ``func`` on ``client``'s workers; results in input order."""
    if window is None:
        window = 2 * max(1, sum(w.get("nthreads", 1) for w in client.scheduler_info()["workers"].values()))

    def mapper(func: Callable, items: Iterable) -> Iterator:
        # keys unique to this call: two runs on one long-lived scheduler must never share results
        prefix = f"{key_prefix}-{uuid.uuid4().hex[:12]}"
        counter = itertools.count()
        pending: collections.deque = collections.deque()
        items = iter(items)
        for item in itertools.islice(items, window):
            pending.append(client.submit(func, item, key=f"{prefix}-{next(counter)}", pure=False))
        while pending:
            future = pending.popleft()
            result = future.result()
            future.release()
            for item in itertools.islice(items, 1):
                pending.append(client.submit(func, item, key=f"{prefix}-{next(counter)}", pure=False))
            yield result

    return mapper


def worker_threads(client: Client) -> int:
    """Threads of the smallest worker: a task's compiled kernels use that many, not every core of its host
    (a LocalCluster has one single-threaded worker per core)."""
    workers = client.scheduler_info()["workers"].values()
    return max(1, min((w.get("nthreads", 1) for w in workers), default=1))


def _peak_rss_bytes() -> int:
    import resource
    import sys

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(peak if sys.platform == "darwin" else peak * 1024)  # bytes on macOS, KiB on Linux


def workers_peak_memory(client: Client) -> dict[str, int]:
    """Peak resident memory (bytes) of each Dask worker process so far, by worker address."""
    return dict(client.run(_peak_rss_bytes))


@contextlib.contextmanager
def scheduler_client(scheduler: str | None) -> Iterator[Client | None]:
    """A Dask client for ``--scheduler`` ('local' starts a LocalCluster), or None without one."""
    if scheduler is None:
        yield None
        return
    from sarproc.product.errors import InputError

    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise InputError("--scheduler: Dask is not installed; pip install 'sarproc[distributed]'") from None
    import logging

    logging.getLogger("distributed").setLevel(max(logging.getLogger().level, logging.WARNING))
    if scheduler == "local":
        with (
            LocalCluster(
                n_workers=os.cpu_count() or 1, threads_per_worker=1, processes=True, dashboard_address=":0"
            ) as cluster,
            Client(cluster) as client,
        ):
            yield client
        return
    try:
        client = Client(scheduler)
    except (OSError, ValueError) as exc:
        raise InputError(f"--scheduler: cannot reach Dask scheduler {scheduler}: {exc}") from None
    with client:
        yield client
