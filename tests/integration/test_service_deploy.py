"""docker-compose.yaml and the Dockerfile, checked for structure (Docker does not run on our machines)."""

from __future__ import annotations

import re
from pathlib import Path

import yaml

from foresight.cli.main import build_parser

REPO = Path(__file__).resolve().parents[2]


def _compose() -> dict:
    return yaml.safe_load((REPO / "docker-compose.yaml").read_text())


def test_services_and_shared_store() -> None:
    services = _compose()["services"]
    assert {"api", "worker", "postgres"} <= services.keys()
    for name in ("api", "worker"):
        svc = services[name]
        env = svc["environment"]
        assert (
            env["FORESIGHT_DATABASE_URL"].startswith("postgresql+psycopg://")
            and "@postgres:5432/" in env["FORESIGHT_DATABASE_URL"]
        )
        assert "store:/data/store" in svc["volumes"] and env["FORESIGHT_STORE"] == "/data/store"
        assert svc["depends_on"]["migrate"]["condition"] == "service_completed_successfully"
    assert set(_compose()["volumes"]) >= {"store", "pgdata"}


def test_ray_head_and_nodes_serve_the_workers() -> None:
    services = _compose()["services"]
    assert services["ray-head"]["command"][:3] == ["ray", "start", "--head"]
    assert services["ray-node"]["command"][:4] == ["ray", "start", "--address", "ray-head:6379"]
    assert services["worker"]["environment"]["FORESIGHT_RAY_ADDRESS"] == "ray-head:6379"


def test_worker_is_scalable_and_stops_gracefully() -> None:
    worker = _compose()["services"]["worker"]
    assert "ports" not in worker and "container_name" not in worker
    assert worker["deploy"]["replicas"] >= 1
    assert worker.get("stop_signal", "SIGTERM") == "SIGTERM"
    assert int(re.match(r"(\d+)s", worker["stop_grace_period"]).group(1)) >= 10


def test_commands_are_real_cli_commands() -> None:
    parser = build_parser()
    for name, svc in _compose()["services"].items():
        command = svc.get("command")
        if command and command[0] == "ray":  # the Ray head and its nodes (episodes of `executor: ray` jobs)
            assert command[1] == "start" and "--block" in command, name
        elif command:
            assert command[0] == "foresight", name
            parser.parse_args(command[1:])  # exits (SystemExit) on an unknown command or flag
    cmd = re.search(r"^CMD \[(.*)\]$", (REPO / "Dockerfile").read_text(), re.M).group(1)
    args = [a.strip().strip('"') for a in cmd.split(",")]
    assert args[0] == "foresight"
    parser.parse_args(args[1:])


def test_dockerfile_copies_every_package_the_service_needs() -> None:
    text = (REPO / "Dockerfile").read_text()
    for path in (
        "foresight",
        "core",
        "api",
        "worker",
        "cli",
        "migrations",
        "configs",
        "model",
        "setup.py",
        "pyproject.toml",
    ):
        assert re.search(rf"^COPY .*\b{re.escape(path)}\b", text, re.M), path
    assert re.search(r"pip install '?\.\[server", text) and "torch==2.13.0" in text
    assert re.search(r"^USER (?!root)", text, re.M)
    assert "EXPOSE 8000" in text and "/healthz" in text


def test_published_ports_are_bound_to_this_machine_only() -> None:
    """Reads are open by default: a port published on every interface served every job to the network."""
    for name, svc in _compose()["services"].items():
        for port in svc.get("ports", []):
            assert str(port).startswith("127.0.0.1:"), (name, port)
