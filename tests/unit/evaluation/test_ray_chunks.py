"""How many episodes one Ray task runs: one while a run is small next to the cluster (each result streams back
alone, a lost node repeats one episode), a bounded chunk once a run has far more episodes than CPUs."""

from foresight.core.evaluation.ray_executor import CHUNKS_PER_CPU, MAX_CHUNK, chunk_size


def test_small_runs_send_one_episode_per_task() -> None:
    assert chunk_size(12, 2) == 1
    assert chunk_size(CHUNKS_PER_CPU * 1000 - 1, 1000) == 1
    assert chunk_size(5, 0) == 1  # a cluster that reports no CPUs yet


def test_big_runs_send_bounded_chunks() -> None:
    assert chunk_size(3 * CHUNKS_PER_CPU * 1000, 1000) == 3
    assert chunk_size(10**6, 1000) == MAX_CHUNK
