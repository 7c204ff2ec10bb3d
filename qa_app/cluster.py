"""Where a lot is computed: a Dask cluster named by address (checked first, so that a wrong
address fails in seconds with its reason) or a local one on this machine's cores."""

from __future__ import annotations

import contextlib
import logging
import os


CONNECT_S = 5.0
"""Seconds a Dask scheduler named by ``--scheduler`` has to accept the connection, and as many
to answer Dask's handshake (one on the same network answers in milliseconds): a closed port, or
a port where another service listens (an HTTP server, the dashboard's port), is said within
seconds, not after Dask's own 30 s of retries, or never (Dask waits for the handshake's answer
without end)."""


def probe_scheduler(address: str, seconds: float = CONNECT_S) -> None:
    """Connect to the Dask scheduler at ``address`` (``tcp://HOST:PORT``; ``tls://`` and
    Dask's other schemes too), shake hands with it, and hang up: first a plain connection
    (within ``seconds``; a refusal is final), then Dask's handshake (within ``seconds``).

    Raises ConnectionError naming the address and the reason: the address is none, nothing
    listens there, nothing answers, or what accepted the connection did not answer as a Dask
    scheduler does (another service on that port)."""
    import asyncio
    import socket

    from distributed.comm import connect, parse_address, parse_host_port

    def refused(reason: str) -> ConnectionError:
        return ConnectionError(f"cannot reach the Dask scheduler {address}: {reason}")

    other = "another service on that port? a scheduler listens on 8786 by default, its " \
            "dashboard on 8787"

    try:
        scheme, location = parse_address(address)
        if scheme in ("tcp", "tls"):
            with socket.create_connection(parse_host_port(location), timeout=seconds):
                pass
    except ConnectionRefusedError as e:
        raise refused("the connection was refused (nothing listens on that port)") from e
    except (socket.timeout, TimeoutError) as e:
        raise refused(f"no answer within {seconds:.0f} s") from e
    except (OSError, ValueError, TypeError) as e:
        raise refused(f"{e.strerror or e}" if isinstance(e, OSError) else f"{e}") from e

    async def shake_hands():
        comm = await connect(address, timeout=seconds)
        await comm.close()

    try:
        asyncio.run(asyncio.wait_for(shake_hands(), seconds))
    except (asyncio.TimeoutError, TimeoutError) as e:
        raise refused(f"something accepted the connection but did not answer as a Dask "
                      f"scheduler within {seconds:.0f} s ({other})") from e
    except Exception as e:  # noqa: BLE001 - whatever the answer was, it was not a scheduler's
        raise refused(f"what answered is not a Dask scheduler (its answer could not be read: "
                      f"{type(e).__name__}; {other})") from e


@contextlib.contextmanager
def dask_client(scheduler: str | None, workers: int | None, wait_s: float = 60.0):
    """A Dask client: of the existing cluster at ``scheduler`` (tcp://HOST:PORT), or of a local
    cluster of ``workers`` single-threaded worker processes (default: the cores) started here
    and closed at the end. Distributed's log messages below ERROR are silenced.

    Raises ConnectionError when the scheduler cannot be reached or does not answer as one
    (:func:`probe_scheduler`, within seconds), or has no worker within ``wait_s`` seconds.
    """
    from distributed import Client, LocalCluster

    logging.getLogger("distributed").setLevel(logging.ERROR)
    with contextlib.ExitStack() as stack:
        if scheduler is None:
            with _sigint_ignored():  # inherited by the worker processes: see _sigint_ignored
                cluster = stack.enter_context(LocalCluster(
                    n_workers=workers or _cores(), threads_per_worker=1, processes=True,
                    # Any free port for its web server (None is Dask's fixed 8787): two
                    # batches, or a batch beside another Dask user, run side by side.
                    dashboard_address=":0", silence_logs=logging.ERROR))
            client = stack.enter_context(Client(cluster))
        else:
            probe_scheduler(scheduler)
            try:
                client = stack.enter_context(Client(scheduler, timeout=CONNECT_S))
            except (OSError, TimeoutError, ValueError) as e:
                raise ConnectionError(f"cannot reach the Dask scheduler {scheduler}: {e}") from e
            try:
                client.wait_for_workers(1, timeout=wait_s)
            except TimeoutError as e:
                raise ConnectionError(f"the Dask scheduler {scheduler} has no worker (none "
                                      f"joined within {wait_s:.0f} s)") from e
        yield client


@contextlib.contextmanager
def _sigint_ignored():
    """Ignore SIGINT while the local cluster's processes start, which keep it ignored: Ctrl-C
    in a terminal reaches every process of its group, and a worker interrupted by it prints
    tracebacks; this process alone takes it, cancels the parts and closes the cluster."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


# ---------------------------------------------------------------------------- the summary
