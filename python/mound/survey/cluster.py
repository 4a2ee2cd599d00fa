"""The per-site work on Dask (dask.distributed): a local cluster sized to the machine, or an
existing one (`--scheduler ADDRESS`, workers started with `dask worker ADDRESS` from the
project's .venv, on machines that see the run directory at the same path).

A task that dies outside process_site's own error handling (a worker killed, out of
memory) comes back as a failed row; the other sites go on. On Ctrl-C the driver cancels
the tasks and tells every worker to end the tools of this run (native.end_all); the local
cluster's workers are started with SIGINT ignored, so that a terminal's Ctrl-C reaches the
driver alone and the shutdown stays orderly.
"""

from __future__ import annotations

import logging
import os
import signal
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from mound import native
from mound.errors import InputError
from mound.formats.site_row import SiteRow
from mound.jsonio import write_json
from mound.survey.site_work import SiteJob, process_site


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)))


@contextmanager
def client_for(scheduler: str | None, workers: int | None) -> Iterator[Any]:
    """A dask.distributed Client: connected to `scheduler`, or to a new local cluster of
    `workers` single-threaded worker processes (default: one per core)."""
    from distributed import Client, LocalCluster

    cluster = None
    if scheduler:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as e:
            raise InputError(f"--scheduler: cannot connect to {scheduler} ({e})") from e
    else:
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            cluster = LocalCluster(n_workers=workers or default_workers(),
                                   threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=logging.ERROR)
        finally:
            signal.signal(signal.SIGINT, previous)
        client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def describe(client: Any) -> str:
    info = client.scheduler_info()
    workers = info.get("workers", {})
    threads = sum(w.get("nthreads", 0) for w in workers.values())
    return f"{info.get('address', '?')}: {len(workers)} workers, {threads} threads"


def run_sites(client: Any, jobs: list[SiteJob], run_id: str,
              on_row: Callable[[SiteRow], None], progress: bool = True) -> None:
    """Runs every job on the cluster; `on_row` gets each site's row as it completes
    (in the driver's thread; a task that died before writing its row gets one written
    here). Ctrl-C cancels the rest and ends the workers' tools of this
    run (`run_id`, the jobs' tag), which start no more."""
    from distributed import as_completed
    from tqdm import tqdm

    if not jobs:
        return
    futures = {client.submit(process_site, job, key=f"site-{job.site.id}-{job.key[:12]}",
                             pure=False, retries=0): job for job in jobs}
    bar = tqdm(total=len(jobs), desc="3-D sites", unit="site", file=sys.stderr,
               disable=not progress, dynamic_ncols=True)
    try:
        for future in as_completed(futures):
            job = futures[future]
            try:
                row = future.result()
            except Exception as e:  # the task itself died: KilledWorker, a lost worker
                row = SiteRow(job.site.id, job.key, job.first_key, "failed",
                              reason=f"task failed on the cluster: {e!r}", retry=True)
                write_json(job.tree.result, row.to_doc())
            bar.update(1)
            bar.set_postfix_str(f"{row.id} {row.verdict.two_answer if row.verdict else row.status}")
            on_row(row)
    except BaseException:
        client.cancel(list(futures))
        try:
            client.run(native.end_all, run_id)
        except Exception:  # best effort: a worker may be gone already
            pass
        raise
    finally:
        bar.close()
