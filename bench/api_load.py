"""API load benchmark: a local server as `foresight up` starts it, under closed-loop HTTP clients.

Phases (each on a fresh temporary data dir unless --database-url is given):
1. status reads: ``GET /v1/jobs/{id}`` over existing jobs, ``--clients`` concurrent keep-alive connections;
   ``status_reads_busy``: the same while the server's worker runs a CPU-bound evaluation (clients polling a
   running job, the usual case; on a 2-core machine the worker's episodes compete with the server for CPU);
2. submissions: ``POST /v1/jobs`` (an empty ``sleep`` job) the same way, while the server's worker runs them;
3. claims: ``--claim-jobs`` empty jobs queued in the database, then ``--claim-workers`` worker processes
   drain the queue; throughput = jobs / (last finish − first claim).

The load generator is one asyncio process speaking minimal HTTP/1.1 over raw sockets, so that it takes as
little of the machine's CPU as possible. Targets (2-core machine, generator included): status reads
≥ 800 req/s with p99 ≤ 100 ms; submissions ≥ 150 req/s with p99 ≤ 250 ms; claims ≥ 200 jobs/s (SQLite).

    python bench/api_load.py --json [--duration 30] [--clients 50]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
TOKEN = "bench-token"
BUSY_JOB = {"kind": "evaluate", "seeds_per_scenario": 30, "max_steps": 300, "planner": {"name": "goal"}}
TARGETS = {
    "status_reads": {"min_rps": 800, "max_p99_ms": 100},
    "status_reads_busy": {"min_rps": 800, "max_p99_ms": 100},
    "submissions": {"min_rps": 150, "max_p99_ms": 250},
    "claims": {"min_jobs_per_s": 200},
}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _env(data_dir: Path, database_url: str | None) -> dict[str, str]:
    env = {**os.environ, "FORESIGHT_DATA_DIR": str(data_dir), "FORESIGHT_API_TOKEN": TOKEN}
    if database_url:
        env["FORESIGHT_DATABASE_URL"] = database_url
    return env


def _cli(env: dict[str, str], *args: str, **kwargs) -> subprocess.Popen:  # noqa: ANN003
    return subprocess.Popen([sys.executable, "-m", "foresight.cli.main", *args], env=env, cwd=REPO, **kwargs)


def _cpu_s(pid: int) -> float:
    """CPU seconds (user + system) used so far by a process (Linux /proc)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _wait_healthy(port: int, timeout: float = 90) -> None:
    import httpx

    deadline = time.time() + timeout
    while time.time() < deadline:
        try:
            if httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=1).status_code == 200:
                return
        except httpx.HTTPError:
            time.sleep(0.2)
    raise RuntimeError("server did not become healthy")


# --------------------------------------------------------------------------------------- HTTP client


async def _request(reader: asyncio.StreamReader, writer: asyncio.StreamWriter, raw: bytes) -> int:
    writer.write(raw)
    head = await reader.readuntil(b"\r\n\r\n")
    status = int(head[9:12])
    length = 0
    for line in head.split(b"\r\n"):
        if line[:15].lower() == b"content-length:":
            length = int(line[15:])
    if length:
        await reader.readexactly(length)
    return status


async def _client_loop(
    port: int, requests: list[bytes], stop_at: float, latencies: list[float], errors: list[int]
) -> None:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    i = 0
    try:
        while time.perf_counter() < stop_at:
            t0 = time.perf_counter()
            status = await _request(reader, writer, requests[i % len(requests)])
            latencies.append(time.perf_counter() - t0)
            if status >= 400:
                errors.append(status)
            i += 1
    finally:
        writer.close()


def _load(port: int, requests: list[bytes], clients: int, duration: float, server_pid: int) -> dict:
    """Closed-loop load; also the CPU the server process and this generator used (the machine is shared,
    so CPU per request says more about the server than wall-clock throughput alone)."""
    latencies: list[float] = []
    errors: list[int] = []

    async def main() -> None:
        stop_at = time.perf_counter() + duration
        per_client = [requests[i::clients] or requests for i in range(clients)]
        await asyncio.gather(
            *(_client_loop(port, per_client[i], stop_at, latencies, errors) for i in range(clients))
        )

    t0, server0, own0 = time.perf_counter(), _tree_cpu_s(server_pid), time.process_time()
    asyncio.run(main())
    elapsed = time.perf_counter() - t0
    server_cpu, own_cpu = _tree_cpu_s(server_pid) - server0, time.process_time() - own0
    latencies.sort()
    n = len(latencies)
    pct = lambda q: round(1000 * latencies[min(n - 1, int(q * n))], 2) if n else None  # noqa: E731
    return {
        "requests": n,
        "seconds": round(elapsed, 2),
        "rps": round(n / elapsed, 1),
        "p50_ms": pct(0.50),
        "p99_ms": pct(0.99),
        "errors": len(errors),
        "clients": clients,
        "server_cpu_s": round(server_cpu, 2),
        "generator_cpu_s": round(own_cpu, 2),
        "server_cpu_ms_per_request": round(1000 * server_cpu / n, 3) if n else None,
    }


def _get(path: str) -> bytes:
    return f"GET {path} HTTP/1.1\r\nHost: bench\r\n\r\n".encode()


def _post(path: str, body: dict) -> bytes:
    data = json.dumps(body).encode()
    head = (
        f"POST {path} HTTP/1.1\r\nHost: bench\r\nAuthorization: Bearer {TOKEN}\r\n"
        f"Content-Type: application/json\r\nContent-Length: {len(data)}\r\n\r\n"
    )
    return head.encode() + data


# --------------------------------------------------------------------------------------- phases


def _tree_cpu_s(pid: int) -> float:
    """CPU seconds of a process and its children (server worker processes), from /proc."""
    total = _cpu_s(pid)
    try:
        children = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
    except OSError:
        return total
    return total + sum(_tree_cpu_s(int(c)) for c in children)


def bench_http(
    database_url: str | None,
    clients: int,
    duration: float,
    server_workers: int,
    phases: tuple[str, ...] = ("status_reads", "submissions"),
) -> dict:
    import httpx

    with tempfile.TemporaryDirectory(prefix="foresight-bench-") as tmp:
        env = _env(Path(tmp), database_url)
        port = _free_port()
        server = _cli(
            env,
            "up",
            "--port",
            str(port),
            "--workers",
            str(server_workers),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        try:
            _wait_healthy(port)
            with httpx.Client(
                base_url=f"http://127.0.0.1:{port}", headers={"Authorization": f"Bearer {TOKEN}"}
            ) as c:
                ids = [c.post("/v1/jobs", json={"spec": {"kind": "sleep"}}).json()["id"] for _ in range(200)]
            out = {}
            if "status_reads" in phases:
                out["status_reads"] = _load(
                    port, [_get(f"/v1/jobs/{i}") for i in ids], clients, duration, server.pid
                )
            if "status_reads_busy" in phases:
                out["status_reads_busy"] = _load_while_busy(port, ids, clients, duration, server.pid)
            if "submissions" in phases:
                out["submissions"] = _load(
                    port, [_post("/v1/jobs", {"spec": {"kind": "sleep"}})], clients, duration, server.pid
                )
        finally:
            server.send_signal(signal.SIGTERM)
            try:
                server.wait(timeout=30)
            except subprocess.TimeoutExpired:
                server.kill()
    return out


def _load_while_busy(port: int, ids: list[str], clients: int, duration: float, server_pid: int) -> dict:
    """Status reads while the worker runs :data:`BUSY_JOB` (started first, cancelled after)."""
    import httpx

    with httpx.Client(base_url=f"http://127.0.0.1:{port}", headers={"Authorization": f"Bearer {TOKEN}"}) as c:
        while c.get("/v1/jobs", params={"status": "queued", "limit": 1}).json()["count"]:
            time.sleep(0.2)  # the sleep jobs drained: the worker is free
        busy = c.post("/v1/jobs", json={"spec": BUSY_JOB}).json()["id"]
        while c.get(f"/v1/jobs/{busy}").json()["status"] != "running":
            time.sleep(0.1)
        time.sleep(2)  # its episodes under way
        try:
            return _load(port, [_get(f"/v1/jobs/{i}") for i in [busy, *ids]], clients, duration, server_pid)
        finally:
            c.post(f"/v1/jobs/{busy}/cancel")


def bench_claims(database_url: str | None, jobs: int, workers: int) -> dict:
    from sqlalchemy import func, insert, select

    from foresight.store import queue
    from foresight.store.session import make_engine, upgrade, write_tx

    with tempfile.TemporaryDirectory(prefix="foresight-bench-") as tmp:
        env = _env(Path(tmp), database_url)
        url = database_url or f"sqlite:///{Path(tmp) / 'foresight.db'}"
        upgrade(url)
        engine = make_engine(url)
        if database_url:  # a shared database: start from an empty queue
            with write_tx(engine) as conn:
                conn.execute(queue.events.delete())
                conn.execute(queue.artifacts.delete())
                conn.execute(queue.jobs.delete())
        now = time.time()
        rows = [
            dict(
                id=queue.new_id(),
                kind="sleep",
                spec={"kind": "sleep"},
                status="queued",
                priority=0,
                attempts=0,
                max_attempts=3,
                cancel_requested=False,
                progress=0.0,
                message="",
                created_at=now + i * 1e-6,
            )
            for i in range(jobs)
        ]
        with write_tx(engine) as conn:
            conn.execute(insert(queue.jobs), rows)
        procs = [
            _cli(env, "worker", stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) for _ in range(workers)
        ]
        cpu = 0.0
        try:
            deadline = time.time() + 300
            while time.time() < deadline:
                with engine.connect() as conn:
                    done = conn.execute(
                        select(func.count()).select_from(queue.jobs).where(queue.jobs.c.status == "succeeded")
                    ).scalar()
                if done == jobs:
                    break
                time.sleep(0.2)
            with engine.connect() as conn:
                first, last = conn.execute(
                    select(func.min(queue.jobs.c.started_at), func.max(queue.jobs.c.finished_at))
                ).one()
                owners = conn.execute(select(func.count(func.distinct(queue.jobs.c.lease_owner)))).scalar()
            cpu = sum(_cpu_s(p.pid) for p in procs)  # includes each worker's start-up (imports)
        finally:
            for p in procs:
                p.send_signal(signal.SIGTERM)
            for p in procs:
                p.wait(timeout=30)
            engine.dispose()
    span = (last or 0) - (first or 0)
    return {
        "jobs": jobs,
        "done": done,
        "workers": workers,
        "workers_used": owners,
        "seconds": round(span, 2),
        "jobs_per_s": round(done / span, 1) if span > 0 else None,
        "database": "postgresql" if database_url else "sqlite",
        "workers_cpu_s_incl_startup": round(cpu, 2),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--duration", type=float, default=30.0, help="[s] per HTTP phase")
    parser.add_argument("--clients", type=int, default=50)
    parser.add_argument("--claim-jobs", type=int, default=2000)
    parser.add_argument("--claim-workers", type=int, default=2)
    parser.add_argument("--server-workers", type=int, default=1, help="`foresight up --workers`")
    parser.add_argument("--database-url", help="benchmark this database instead of a temporary SQLite file")
    parser.add_argument(
        "--phases",
        default="status_reads,submissions,claims",
        help="comma-separated subset of status_reads, status_reads_busy, submissions, claims "
        "(default: status_reads, submissions, claims)",
    )
    args = parser.parse_args(argv)
    phases = tuple(p.strip() for p in args.phases.split(","))
    unknown = set(phases) - set(TARGETS)
    if unknown:
        parser.error(f"unknown phases {sorted(unknown)}; choose from {sorted(TARGETS)}")

    load0 = round(os.getloadavg()[0], 2)
    result: dict = {}
    if {"status_reads", "status_reads_busy", "submissions"} & set(phases):
        result.update(bench_http(args.database_url, args.clients, args.duration, args.server_workers, phases))
    if "claims" in phases:
        result["claims"] = bench_claims(args.database_url, args.claim_jobs, args.claim_workers)
    result["targets"] = {p: TARGETS[p] for p in phases}
    result["machine"] = {
        "cpus": os.cpu_count(),
        "loadavg_1m_at_start": load0,
        "loadavg_1m_at_end": round(os.getloadavg()[0], 2),
    }

    def http_ok(r: dict, target: dict) -> bool:
        return (
            r["rps"] >= target["min_rps"]
            and r["p99_ms"] is not None
            and r["p99_ms"] <= target["max_p99_ms"]
            and r["errors"] == 0
        )

    result["meets_targets"] = {
        p: (result[p]["jobs_per_s"] or 0) >= TARGETS[p]["min_jobs_per_s"]
        if p == "claims"
        else http_ok(result[p], TARGETS[p])
        for p in phases
    }
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    for p in ("status_reads", "status_reads_busy", "submissions"):
        if p in result:
            r = result[p]
            print(
                f"{p + ':':14s}{r['rps']} req/s, p50 {r['p50_ms']} ms, p99 {r['p99_ms']} ms, errors {r['errors']}"
            )
    if "claims" in result:
        c = result["claims"]
        print(
            f"claims:       {c['jobs_per_s']} jobs/s ({c['done']}/{c['jobs']} jobs, {c['workers']} workers, {c['database']})"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
