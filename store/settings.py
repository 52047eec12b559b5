"""Service settings: one pydantic-settings object, read from ``FORESIGHT_*`` environment variables.

Built by whoever starts a component (the app factory, the worker, the CLI), never at import.
"""

from __future__ import annotations

import json
import os
import secrets
from pathlib import Path

from pydantic import Field, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from foresight.core.dataroots import DEFAULT_SHARED, named_data_roots, parse_data_roots, pick_root
from foresight.core.jobs.budget import DEFAULT_STEP_BUDGET

REPO_ROOT = Path(__file__).resolve().parent.parent
TOKEN_FILE = "api-token"
SERVER_FILE = (
    "server.json"  #: written by `foresight up`: where its API listens (and its pid), for the CLI client
)
DEFAULT_API_URL = "http://127.0.0.1:8000"


def default_data_dir() -> Path:
    """The per-user data folder, ``$XDG_DATA_HOME/foresight`` (else ``~/.local/share/foresight``): one place for
    the local server's database, store and token, so the CLI finds them from any folder of any terminal."""
    base = os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share"
    return Path(base) / "foresight"


class Settings(BaseSettings):
    """Everything the API server, the worker and the CLI client need to know about their environment."""

    model_config = SettingsConfigDict(env_prefix="FORESIGHT_", extra="ignore")

    #: folder for the embedded SQLite database, the default artifact store, the generated token and ``--local``
    #: runs' work folders; per user (:func:`default_data_dir`), not per current directory
    data_dir: Path = Field(default_factory=default_data_dir)
    #: SQLAlchemy URL; empty means ``sqlite:///<data_dir>/foresight.db``
    database_url: str = ""
    #: artifact root; empty means ``<data_dir>/store``
    store: Path | None = None
    #: bearer token for write endpoints; empty means a generated one kept in ``<data_dir>/api-token``
    api_token: str = ""
    #: base URL the CLI client talks to; empty: the running `foresight up` of this data dir, else DEFAULT_API_URL
    api_url: str = ""
    #: extra config roots registered as bundles at start-up (``os.pathsep``-separated in the environment)
    config_dirs: str = ""
    #: close the read endpoints too (they are open by default)
    read_requires_token: bool = False
    #: shipped model registry (YAML), loaded read-only at start-up
    model_registry: Path = REPO_ROOT / "model" / "registry.yaml"
    #: project config root registered under relative names at start-up
    project_configs: Path = REPO_ROOT / "configs"

    lease_s: float = Field(30.0, gt=0)  #: [s] a claimed job's lease; renewed by heartbeats
    heartbeat_s: float = Field(1.0, gt=0)  #: [s] worker heartbeat and cancel-poll interval
    poll_s: float = Field(0.2, gt=0)  #: [s] idle worker's queue polling interval
    max_attempts: int = Field(3, ge=1, le=100)  #: default claims per job before a lost lease fails it
    shutdown_grace_s: float = Field(
        10.0, ge=0
    )  #: [s] a stopping worker waits this long before releasing jobs
    sqlite_busy_timeout_ms: int = Field(30000, ge=0)  #: [ms]
    #: processes a stage may use for parallel episodes (``StageContext.workers``); worker slots are threads
    stage_workers: int = Field(1, ge=1, le=256)
    #: [s] limit of one attempt of a job that sets no ``timeout_s`` of its own (children of pipelines too)
    job_timeout_s: float = Field(12 * 3600.0, gt=0, le=7 * 86400)
    #: simulation steps one job may ask for (episodes x horizon), checked at submission and before a stage runs
    max_job_steps: int = Field(DEFAULT_STEP_BUDGET, ge=1)
    #: [MiB] most memory a worker process may allocate (a job past it fails, naming it); unset: 3/4 of the
    #: machine's physical memory; 0: no limit (worker.memory)
    worker_memory_mb: int | None = Field(None, ge=0)
    #: named data roots on the worker's disk (``name=path,name=path``); specs name them, never the paths
    data_roots: str = ""
    #: MLflow tracking server that finished train/evaluate/campaign runs are copied to (empty: none;
    #: worker.mlflow_export, extra ``foresight[mlflow]``)
    mlflow_tracking_uri: str = ""
    mlflow_experiment: str = "foresight"  #: the MLflow experiment those runs go to (created on first use)
    #: the shared reference material; its ``reference/ethucy`` is data root ``ethucy`` unless one is named so
    shared: Path = DEFAULT_SHARED

    @field_validator("api_url")
    @classmethod
    def _strip_slash(cls, value: str) -> str:
        return value.rstrip("/")

    @field_validator("data_dir")
    @classmethod
    def _expand(cls, value: Path) -> Path:
        return value.expanduser()

    @property
    def client_url(self) -> str:
        """Where the CLI client sends requests: ``FORESIGHT_API_URL``, else the URL ``foresight up`` recorded in the
        data dir while it runs (any port, any folder it was started from), else :data:`DEFAULT_API_URL`."""
        if self.api_url:
            return self.api_url
        try:
            server = json.loads(self.server_file().read_text())
            os.kill(int(server["pid"]), 0)  # a server that died without removing its file is not used
            return str(server["url"]).rstrip("/")
        except (OSError, ValueError, KeyError, TypeError):
            return DEFAULT_API_URL

    def server_file(self) -> Path:
        return self.data_dir / SERVER_FILE

    @property
    def local_runs(self) -> Path:
        """The parent of ``--local`` runs' work folders that have no ``--out``."""
        return self.data_dir / "runs"

    @property
    def resolved_database_url(self) -> str:
        return self.database_url or f"sqlite:///{(self.data_dir / 'foresight.db').resolve()}"

    @property
    def store_root(self) -> Path:
        return (self.store or self.data_dir / "store").resolve()

    @property
    def extra_config_dirs(self) -> list[Path]:
        return [Path(p) for p in self.config_dirs.split(os.pathsep) if p.strip()]

    @field_validator("data_roots")
    @classmethod
    def _check_roots(cls, value: str) -> str:
        parse_data_roots(value)
        return value

    @property
    def named_data_roots(self) -> dict[str, Path]:
        """Data root name -> folder: ``FORESIGHT_DATA_ROOTS``, plus ``ethucy`` from the shared folder when it exists."""
        return named_data_roots(self.data_roots, self.shared)

    def data_root(self, name: str) -> Path:
        """The folder of data root ``name``; NotFoundError naming the known roots."""
        return pick_root(self.named_data_roots, name)

    def token_file(self) -> Path:
        return self.data_dir / TOKEN_FILE

    def server_token(self) -> str:
        """The write token: the configured one, else the data dir's generated one (created on first use)."""
        if self.api_token:
            return self.api_token
        path = self.token_file()
        if path.is_file():
            return path.read_text().strip()
        path.parent.mkdir(parents=True, exist_ok=True)
        token = secrets.token_urlsafe(24)
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        except FileExistsError:  # another process created it first: use theirs
            return path.read_text().strip()
        with os.fdopen(fd, "w") as handle:
            handle.write(token + "\n")
        return token

    def client_token(self) -> str | None:
        """The token a local client sends: the configured one, else the data dir's file if present."""
        if self.api_token:
            return self.api_token
        path = self.token_file()
        return path.read_text().strip() if path.is_file() else None
