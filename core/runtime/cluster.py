"""Joining the Ray cluster that runs episodes and training tasks: its address, reachability and resources.

Below the stages that use it (evaluation's Ray executor, training's Ray task) because every stage's execution
record (``runtime.execution``) names the cluster it ran on. Ray itself is an optional extra, imported inside.
"""

from __future__ import annotations

import os
import socket
import threading

from foresight.core.errors import CoreError

RAY_ADDRESS_ENV = "FORESIGHT_RAY_ADDRESS"
CONNECT_TIMEOUT_S = 5.0  #: [s] to open a TCP connection to the cluster's address before joining it

_connect_lock = threading.Lock()


class RayUnreachable(CoreError):
    """Nothing answers at the configured Ray address (or Ray refused to join it)."""


def _host_port(address: str) -> tuple[str, int] | None:
    """(host, port) of ``head:6379`` or ``ray://head:10001``; None for addresses Ray resolves itself (``auto``)."""
    rest = address.split("://", 1)[-1]
    host, sep, port = rest.rpartition(":")
    return (host.strip("[]"), int(port)) if sep and host and port.isdigit() else None


def _check_reachable(address: str) -> None:
    hp = _host_port(address)
    if hp is None:
        return
    try:
        socket.create_connection(hp, timeout=CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise RayUnreachable(
            f"Ray cluster at {address} ({RAY_ADDRESS_ENV}) is unreachable: {exc.strerror or exc}; "
            "start it (ray start --head) or correct the address"
        ) from None


def connect(cpus: int) -> str:
    """Join the cluster at ``FORESIGHT_RAY_ADDRESS``, or start a local instance with ``cpus`` CPUs, once per
    process; the address in use. :class:`RayUnreachable` (one line naming the address) when it cannot."""
    import ray

    with _connect_lock:
        address = os.environ.get(RAY_ADDRESS_ENV) or None
        if not ray.is_initialized():
            quiet = {"include_dashboard": False, "log_to_driver": False, "logging_level": "ERROR"}
            if address:
                _check_reachable(address)
                try:
                    ray.init(address=address, **quiet)
                except (ConnectionError, RuntimeError, TimeoutError) as exc:
                    first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
                    raise RayUnreachable(
                        f"cannot join the Ray cluster at {address} ({RAY_ADDRESS_ENV}): {first}"
                    ) from None
            else:
                ray.init(
                    address="local", num_cpus=max(1, cpus), **quiet
                )  # a new instance, never a running one
        return address or "local"


def cluster_cpus() -> int:
    """CPUs the connected cluster offers (recorded with the run)."""
    import ray

    return int(ray.cluster_resources().get("CPU", 0))


def cluster_gpus() -> int:
    """GPUs the connected cluster offers (training asks for one when there is any)."""
    import ray

    return int(ray.cluster_resources().get("GPU", 0))
