"""The batch tasks (``usvips.app.batch``) on a Dask distributed cluster instead of this machine's cores.

``scheduler`` is a Dask scheduler's address (``tcp://host:8786``; its workers need USVIPS installed and
the tasks' files at the same paths), or ``local:N`` for a cluster of N worker processes started here for
the run (one thread each; stopped afterwards). The tasks are the same plain functions, run through the
same wrapper as on a local pool, so their outputs are identical to a serial run; a failing task comes
back as one line naming its input and does not stop the others; progress is reported as each finishes;
Ctrl-C cancels the tasks not yet finished (reported ``cancelled``).
"""

from __future__ import annotations

import uuid
from collections.abc import Callable, Iterable

from usvips.app.batch import Outcome, Task, _execute
from usvips.core.errors import InvalidParameterError, UsvipsError, concerning

CONNECT_TIMEOUT_S = 10
#: the most worker processes ``local:N`` starts here (each holds its own copy of the libraries), as --jobs
MAX_LOCAL_WORKERS = 256


def local_workers(scheduler: str) -> int | None:
    """N of ``local:N`` (a positive whole number), None for a scheduler's address."""
    if not scheduler.startswith("local:"):
        return None
    count = scheduler.removeprefix("local:")
    if not count.isdigit() or int(count) < 1:
        raise InvalidParameterError("scheduler", f"local:N needs a positive whole number of workers, got {count!r}",
                                    label="scheduler")
    if int(count) > MAX_LOCAL_WORKERS:
        raise InvalidParameterError("scheduler", f"local:N starts at most {MAX_LOCAL_WORKERS} worker processes "
                                                 f"on this machine, got {int(count)}", label="scheduler")
    return int(count)


def _client(scheduler: str):
    """A Dask client of the scheduler (or of a local cluster started for it), with the cluster to close."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise concerning(UsvipsError("a Dask scheduler needs Dask distributed: pip install 'usvips[cluster]'"),
                         "scheduler") from None
    workers = local_workers(scheduler)
    if workers is not None:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        return Client(cluster), cluster
    if "://" not in scheduler and ":" not in scheduler:
        raise InvalidParameterError("scheduler", f"give a scheduler's address (tcp://HOST:PORT) or local:N, "
                                                 f"got {scheduler!r}", label="scheduler")
    try:
        return Client(scheduler, timeout=CONNECT_TIMEOUT_S), None
    except Exception as error:  # any failure to connect (refused, unreachable, timed out, a bad address) is one
        raise concerning(UsvipsError(f"scheduler {scheduler}: cannot reach the Dask scheduler there "
                                     f"({' '.join(str(error).split()) or type(error).__name__})"),
                         "scheduler") from None


def run_on_cluster(tasks: Iterable[Task], scheduler: str,
                   progress: Callable[[Outcome, int, int], None] | None = None) -> list[Outcome]:
    """Run ``tasks`` on the Dask cluster ``scheduler`` (see the module docstring), calling
    ``progress(outcome, finished, total)`` as each finishes; returns the outcomes in the tasks' order."""
    tasks = list(tasks)
    local_workers(scheduler)  # a bad local:N is refused before anything starts
    if not tasks:
        return []
    outcomes: dict[int, Outcome] = {}

    def finish(index: int, outcome: Outcome) -> None:
        outcomes[index] = outcome
        if progress is not None:
            progress(outcome, len(outcomes), len(tasks))

    from dask.distributed import as_completed

    client, cluster = _client(scheduler)
    run_id = uuid.uuid4().hex
    try:
        futures = {client.submit(_execute, task.function, task.arguments, key=f"usvips-{run_id}-{i}", pure=False): i
                   for i, task in enumerate(tasks)}
        try:
            for future in as_completed(futures):
                index = futures[future]
                try:
                    status, summary, message = future.result()
                except Exception as error:  # a worker lost, a task that cannot be unpickled there ...
                    status, summary, message = "failed", None, f"the cluster could not run it ({error})"
                finish(index, Outcome(tasks[index], status, summary, " ".join(message.split())))
        except KeyboardInterrupt:
            for future, index in futures.items():
                if index not in outcomes:
                    future.cancel()
                    finish(index, Outcome(tasks[index], "cancelled", message="interrupted before it finished"))
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return [outcomes[i] for i in range(len(tasks))]
