"""Shots spread over a Dask cluster (``dask.distributed``): a LocalCluster on this machine by default, or any
running scheduler by its address (docs/pipeline.md).

Each shot is one task: the worker loads the spec (a path every worker can read), bakes it with as many
solver threads as the worker has (unless the spec names them) and returns a ``ShotResult``; a failing shot
comes back as a result with its error and log and never stops the others. A worker that dies mid-shot makes
the scheduler run the task again elsewhere (up to its ``allowed-failures``), and the bake resumes from the
shot's last checkpoint; past that the shot is reported as failed. Bits are those of ``python -m opdeform
bake`` run with the same threads.
"""

import io as text_io
import logging
import os
import socket
import struct
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from . import shot as shots
from .io import FilePath

__all__ = ["ShotResult", "bake_shot", "connect", "run", "submit", "gather"]


@dataclass
class ShotResult:
    spec: str
    ok: bool
    seconds: float = 0.0
    frames: int = 0
    outputs: dict[str, str] = field(default_factory=dict)
    error: str = ""
    log: str = ""


def bake_shot(spec: str, threads: int | None = 1) -> ShotResult:
    """Loads and bakes one spec; every failure comes back inside the result (with the log of the bake)."""
    captured = text_io.StringIO()
    handler = logging.StreamHandler(captured)
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    logger = logging.getLogger("opdeform")
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    t0 = time.perf_counter()
    try:
        shot = shots.load(spec)
        logger.info("%s: baking frames %d-%d with %d threads", shot.name, shot.first, shot.last,
                    shot.threads(threads or 1))  # what shots.bake runs with
        rows = shots.bake(shot, threads)
        outputs = {key: path for key in ("pc2", "frames", "report", "plot") if (path := shot.output(key))}
        return ShotResult(spec, True, time.perf_counter() - t0, len(rows), outputs, log=captured.getvalue())
    except Exception as exc:  # a failed shot is a result, not the end of the batch
        logger.error("%s", traceback.format_exc())
        return ShotResult(spec, False, time.perf_counter() - t0, error=f"{type(exc).__name__}: {exc}",
                          log=captured.getvalue())
    finally:
        logger.removeHandler(handler)


def _bake_on_worker(spec: str) -> ShotResult:
    from distributed import get_worker
    return bake_shot(spec, get_worker().state.nthreads)


def connect(scheduler: str | None = None, workers: int = 2, threads_per_worker: int = 1,
            timeout: float = 10.0) -> Any:
    """A ``distributed.Client``: to the scheduler at ``scheduler`` (ConnectionError naming it when it does not
    answer within ``timeout`` seconds, or answers not as a Dask scheduler), or to a new LocalCluster of
    ``workers`` processes."""
    from distributed import Client, LocalCluster
    if scheduler:
        _check_scheduler(scheduler, timeout)
        try:
            return Client(scheduler, timeout=timeout)
        except (OSError, TimeoutError) as exc:
            raise ConnectionError(f"scheduler {scheduler}: no answer within {timeout:g} s ({exc})") from None
    cluster = LocalCluster(n_workers=workers, threads_per_worker=threads_per_worker, processes=True,
                           dashboard_address=None)
    return Client(cluster)


# The first thing a Dask scheduler sends on a TCP connection is its handshake: 8 bytes giving the length of
# the message (a few hundred bytes), then the message. Dask's Client allocates whatever length it reads (an
# HTTP reply asked for 2.82 EiB: MemoryError) and waits for the handshake without a time limit (a service that
# says nothing held it for 58 s and more with timeout=2), so a tcp address is checked here first.
HANDSHAKE_LIMIT = 1 << 20


def _check_scheduler(address: str, timeout: float) -> None:
    """ConnectionError naming ``address`` unless what listens there sends a Dask handshake within ``timeout``
    seconds. An address nothing listens at is left to the Client (it retries until the timeout, for a
    scheduler that is starting); schemes other than tcp (tls, inproc) are not checked."""
    from distributed.comm import get_address_host_port, normalize_address, parse_address
    if parse_address(normalize_address(address))[0] != "tcp":
        return
    deadline = time.monotonic() + timeout
    try:
        sock = socket.create_connection(get_address_host_port(address), timeout=timeout)
    except TimeoutError:
        raise ConnectionError(f"scheduler {address}: no answer within {timeout:g} s") from None
    except OSError:
        return
    with sock:
        head = _receive(sock, 8, deadline, address, timeout)
        length = struct.unpack("Q", head)[0]  # native order, as Dask writes it
        if length > HANDSHAKE_LIMIT:
            raise ConnectionError(f"scheduler {address}: what answers there is not a Dask scheduler (it began "
                                  f"with {head!r}, not the length of a Dask handshake)")
        _receive(sock, length, deadline, address, timeout)


def _receive(sock: socket.socket, size: int, deadline: float, address: str, timeout: float) -> bytes:
    data = b""
    while len(data) < size:
        sock.settimeout(max(deadline - time.monotonic(), 1e-3))
        try:
            chunk = sock.recv(size - len(data))
        except TimeoutError:
            raise ConnectionError(f"scheduler {address}: a connection opened but no Dask handshake came within "
                                  f"{timeout:g} s (another service listening there?)") from None
        except OSError as exc:
            raise ConnectionError(f"scheduler {address}: the connection failed before a Dask handshake ({exc})") \
                from None
        if not chunk:
            raise ConnectionError(f"scheduler {address}: the connection closed before a Dask handshake (another "
                                  f"service listening there?)")
        data += chunk
    return data


def submit(client: Any, specs: Sequence[FilePath]) -> list[Any]:
    """One task per spec (absolute paths; a worker must be able to read them); returns the futures in order."""
    paths = [os.path.abspath(os.fspath(s)) for s in specs]
    return [client.submit(_bake_on_worker, p, pure=False, key=f"bake-{k}-{os.path.basename(p)}")
            for k, p in enumerate(paths)]


def gather(specs: Sequence[FilePath], futures: Sequence[Any],
           on_result: Callable[[ShotResult], object] | None = None) -> list[ShotResult]:
    """The ShotResult of every future, in the order of the specs; a task that could not run (its worker died
    too often, the cluster went away) becomes a failed result naming the reason. on_result(result) as each ends."""
    from distributed import as_completed
    index = {f.key: k for k, f in enumerate(futures)}
    results: list[Any] = [None] * len(futures)
    for future in as_completed(futures):
        k = index[future.key]
        try:
            results[k] = future.result()
        except Exception as exc:  # KilledWorker, CommClosedError, CancelledError: the task itself never returned
            results[k] = ShotResult(os.path.abspath(os.fspath(specs[k])), False,
                                    error=f"{type(exc).__name__}: {exc} (the worker running it died or the "
                                          f"cluster went away)")
        if on_result:
            on_result(results[k])
    return results


def run(specs: Sequence[FilePath], scheduler: str | None = None, workers: int = 2, timeout: float = 10.0,
        on_result: Callable[[ShotResult], object] | None = None) -> list[ShotResult]:
    """Bakes the specs over a cluster (see ``connect``); returns their ShotResults in order."""
    with connect(scheduler, workers, timeout=timeout) as client:
        results = gather(specs, submit(client, specs), on_result)
        if not scheduler:
            client.cluster.close()
    return results
