"""Which executor ran a job's episodes and on how many CPUs: part of the result of every stage that runs episodes
(evaluate, diagnose, campaign, collect), so a record says where its numbers came from (they do not depend on it)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel

#: where episodes run: ``local`` (this process, or a process pool of the stage's workers) or ``ray`` (one task per
#: episode on the cluster at FORESIGHT_RAY_ADDRESS, else a local Ray instance); results do not depend on it
Executor = Literal["local", "ray"]


class Execution(BaseModel):
    executor: Executor
    #: local: the processes it may use (the stage's workers); ray: the cluster's CPUs at the start (a training
    #: task: the CPUs it holds)
    cpus: int
    gpus: int = 0  #: GPUs it holds (a training task on a GPU node)
    address: str | None = None  #: ray: the cluster's address, or "local" for an instance started for the run
    device: str | None = None  #: a training task: the torch device that trained (cpu, cuda)

    def describe(self) -> str:
        """E.g. ``ray, 8 CPUs at head:6379``, ``ray, 1 CPU, 1 GPU at head:6379, trained on cuda`` or ``local, 2 CPUs``."""
        at = f" at {self.address}" if self.address and self.address != "local" else ""
        gpus = f", {self.gpus} GPU{'s' if self.gpus != 1 else ''}" if self.gpus else ""
        on = f", trained on {self.device}" if self.device else ""
        return f"{self.executor}, {self.cpus} CPU{'s' if self.cpus != 1 else ''}{gpus}{at}{on}"


def execution(executor: Executor, workers: int | None) -> Execution:
    """The execution record of a run on ``executor`` (joins the Ray cluster when not yet joined)."""
    if executor == "local":
        return Execution(executor="local", cpus=max(1, int(workers or 1)))
    from foresight.core.runtime.cluster import cluster_cpus, connect

    address = connect(int(workers or 1))
    return Execution(executor="ray", cpus=cluster_cpus(), address=address)
