"""HTTP request metrics for ``/metrics``: requests by method, route template and status class, and a latency
histogram by method and route template.

Labels are bounded: the route is the matched template (``/v1/jobs/{job_id}``), never the raw path, and a
request that matched no route counts under ``unmatched``; unusual methods count as ``OTHER``. Latency is the
time until the response starts (headers sent): for an event stream that is its set-up, not its lifetime.

The counters live in the server process that answered (``foresight serve --workers N`` has N sets, and
a scrape reads one of them): enough for one process per host, which is how ``foresight up`` runs; a
multi-process aggregate would need a shared store. Everything runs on the event loop thread, so no lock.
The exposition is written by hand, like the rest of ``/metrics``: a dozen lines do not warrant a
dependency, and per-app state keeps several apps in one process (tests) apart.
"""

from __future__ import annotations

import time
from bisect import bisect_left
from typing import Any

BUCKETS = (0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0)  #: [s] upper bounds
METHODS = frozenset({"GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS"})
UNMATCHED = "unmatched"


class HttpMetrics:
    """Request counts and latency histograms of one app."""

    def __init__(self) -> None:
        self.templates: dict[
            int, str
        ] = {}  #: id(route) -> its full path template (see :func:`route_templates`)
        self.requests: dict[tuple[str, str, str], int] = {}
        #: (method, route) -> per-bucket counts (not cumulative; the last one is +Inf), sum of seconds
        self.latency: dict[tuple[str, str], tuple[list[int], list[float]]] = {}

    def observe(self, method: str, route: str, status: int, seconds: float) -> None:
        method = method if method in METHODS else "OTHER"
        key = (method, route, f"{status // 100}xx")
        self.requests[key] = self.requests.get(key, 0) + 1
        hist = self.latency.get((method, route))
        if hist is None:
            hist = self.latency[(method, route)] = ([0] * (len(BUCKETS) + 1), [0.0])
        hist[0][bisect_left(BUCKETS, seconds)] += 1
        hist[1][0] += seconds

    def exposition(self) -> list[str]:
        """The Prometheus text-format lines of both metrics (``/metrics`` runs in the thread pool: it reads a
        snapshot, each copy taken in one C call under the GIL while the event loop keeps counting)."""
        requests = list(self.requests.items())
        latency = [(key, (list(counts), total[0])) for key, (counts, total) in list(self.latency.items())]
        lines = [
            "# HELP foresight_http_requests_total HTTP requests answered by this server process.",
            "# TYPE foresight_http_requests_total counter",
        ]
        for (method, route, status), n in sorted(requests):
            lines.append(
                f'foresight_http_requests_total{{method="{method}",route="{_esc(route)}",status="{status}"}} {n}'
            )
        lines += [
            "# HELP foresight_http_request_duration_seconds Time until the response started, per route.",
            "# TYPE foresight_http_request_duration_seconds histogram",
        ]
        for (method, route), (counts, total) in sorted(latency):
            labels = f'method="{method}",route="{_esc(route)}"'
            cumulative = 0
            for bound, n in zip((*BUCKETS, "+Inf"), counts, strict=True):
                cumulative += n
                lines.append(
                    f'foresight_http_request_duration_seconds_bucket{{{labels},le="{bound}"}} {cumulative}'
                )
            lines.append(f"foresight_http_request_duration_seconds_sum{{{labels}}} {total:.6f}")
            lines.append(f"foresight_http_request_duration_seconds_count{{{labels}}} {cumulative}")
        return lines


def route_templates(app: Any) -> dict[int, str]:
    """Each route's full path template, by the route object's id (what the router puts in ``scope["route"]``).

    FastAPI includes routers lazily: the route object in the scope is the one the router module declared,
    whose ``path`` lacks the prefixes it was included under (``/jobs/{job_id}``, not ``/v1/jobs/{job_id}``).
    """
    try:
        from fastapi.routing import iter_route_contexts
    except (
        ImportError
    ):  # FastAPI before lazy inclusion: app.routes is flat and route.path is the full template
        return {id(r): r.path for r in app.routes if isinstance(getattr(r, "path", None), str)}
    return {id(c.original_route): c.path_format for c in iter_route_contexts(app.routes) if c.path_format}


def _esc(value: str) -> str:
    return value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")


class MetricsMiddleware:
    """Pure ASGI middleware (no per-request task or body buffering, unlike ``BaseHTTPMiddleware``) that
    records every HTTP request in ``metrics``; a request whose handler raised counts as 500."""

    def __init__(self, app: Any, metrics: HttpMetrics) -> None:
        self.app, self.metrics = app, metrics

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        start = time.perf_counter()
        seen: list[Any] = [500, None]  # status, seconds until the response started

        async def send_and_note(message: dict) -> None:
            if message["type"] == "http.response.start":
                seen[0], seen[1] = message["status"], time.perf_counter() - start
            await send(message)

        try:
            await self.app(scope, receive, send_and_note)
        finally:
            matched = scope.get("route")  # set by the router on a match
            route = self.metrics.templates.get(id(matched)) or getattr(matched, "path", None) or UNMATCHED
            seconds = seen[1] if seen[1] is not None else time.perf_counter() - start
            self.metrics.observe(scope["method"], route, seen[0], seconds)
