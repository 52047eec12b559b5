"""The initial crowd of an episode: how many pedestrians, in which groups, where and how fast (reference §1.3-1.4).

Row order is the reference's: crowded-zone peds, then route peds, then single peds. Every group
(single peds are groups of one) gets a group index; behaviours address groups through these indices.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.maps.model import MapDef, SinglePedestrian
from foresight.core.scenarios.model import ResolvedScenario, SimulationConfig
from foresight.core.sim import heterogeneity
from foresight.core.sim.params import SPEED_TIERS, CrowdParams
from foresight.core.sim.trace import MAX_TRACE_BYTES, trace_bytes
from foresight.core.sim.zones import RouteGeometry, Validator, sample_free, sample_zone


@dataclass
class Population:
    """Initial pedestrian arrays (N rows) and the group bookkeeping the behaviours need."""

    pos: np.ndarray  #: (N, 2) [m]
    vel: np.ndarray  #: (N, 2) [m/s]
    goal: np.ndarray  #: (N, 2) [m]
    vmax: np.ndarray  #: (N,) desired = maximum speed [m/s]
    group: np.ndarray  #: (N,) group index
    group_size: np.ndarray  #: (G,) float, members per group
    route_groups: np.ndarray  #: (Gr,) group indices following routes
    route_of_group: np.ndarray  #: (Gr,) route index into the map's ped routes
    route_wp: np.ndarray  #: (Gr,) index of the waypoint each route group heads for
    zone_groups: np.ndarray  #: (Gz,) group indices in crowded zones
    zone_of_group: np.ndarray  #: (Gz,) crowded-zone index
    singles: list[SinglePedestrian] = field(default_factory=list)  #: scripted peds, rows N - len(singles) ...
    robot_response: np.ndarray | None = (
        None  #: (N,) multiplier of the robot repulsion per ped; None = 1 for all
    )

    @property
    def n(self) -> int:
        return len(self.pos)


def population_counts(map_def: MapDef, cfg: SimulationConfig, crowd: CrowdParams) -> tuple[int, int]:
    """(zone peds, route peds) from density: ceil(zone area x density), ceil(route length x width x density)."""
    has_zones, has_routes = bool(map_def.ped_crowded_zones), bool(map_def.ped_routes)
    if cfg.population_size is not None:
        total = cfg.population_size
        if has_zones and has_routes:
            return total // 2, total - total // 2
        if has_zones:
            return total, 0
        if has_routes or total == 0:
            return 0, total
        raise ConfigError(
            f"population_size {total} needs ped routes or crowded zones in map {map_def.name!r}"
        )
    area = sum(z.area for z in map_def.ped_crowded_zones)
    length = sum(r.length for r in map_def.ped_routes)
    return math.ceil(area * cfg.ped_density), math.ceil(length * crowd.sidewalk_width * cfg.ped_density)


def pedestrian_count(scenario: ResolvedScenario, crowd: CrowdParams | None = None) -> int:
    """How many pedestrians an episode of this scenario has (zone + route + single peds, or the replayed tracks)."""
    if scenario.replay is not None:
        return len(np.unique(scenario.replay.ids))
    n_zone, n_route = population_counts(
        scenario.map, scenario.scenario.simulation_config, crowd or CrowdParams()
    )
    return n_zone + n_route + len(scenario.map.single_pedestrians)


#: most pedestrians one episode may have (zone, route and single peds, or replayed tracks): the largest
#: ``population_size`` too. Spawning is per group, so a crowd of millions would take minutes before the first step
MAX_PEDESTRIANS = 5000
CHECK_GROUPS = 64  #: groups placed between two ``check()`` calls while a crowd spawns


def check_crowd(scenario: ResolvedScenario, horizon: int, crowd: CrowdParams | None = None) -> int:
    """The episode's pedestrian count; ConfigError naming the scenario and its setting when the crowd is over
    :data:`MAX_PEDESTRIANS` or its trace (horizon x crowd) over the trace limit. Cheap (areas and lengths): run
    before anything is spawned, at submission and at reset."""
    n = pedestrian_count(scenario, crowd)
    setting = "population_size" if scenario.scenario.simulation_config.population_size else "ped_density"
    if n > MAX_PEDESTRIANS:
        raise ConfigError(
            f"{n} pedestrians (map {scenario.map.name!r}: crowded-zone area and ped-route length x "
            f"{setting}); at most {MAX_PEDESTRIANS}: lower {setting} or shorten the map's routes",
            source=scenario.name,
            item=f"simulation_config.{setting}",
        )
    if trace_bytes(horizon, n) > MAX_TRACE_BYTES:
        raise ConfigError(
            f"an episode of {horizon} steps with {n} pedestrians needs a {trace_bytes(horizon, n) / 2**20:.0f} "
            f"MiB trace; the limit is {MAX_TRACE_BYTES / 2**20:.0f} MiB: lower max_steps or the crowd",
            source=scenario.name,
            item="max_steps",
        )
    return n


def group_sizes(n: int, max_size: int, rng: np.random.Generator, decay: float) -> list[int]:
    """Group sizes summing to n, drawn i.i.d. with P(k) ~ decay^(k - 1); the last group is truncated."""
    if n <= 0:
        return []
    p = decay ** np.arange(max_size)
    p /= p.sum()
    draws = rng.choice(np.arange(1, max_size + 1), size=n, p=p)  # n draws always suffice
    sizes, total = [], 0
    for k in draws:
        k = int(min(k, n - total))
        sizes.append(k)
        total += k
        if total == n:
            break
    return sizes


def desired_speeds(n: int, cfg: SimulationConfig, crowd: CrowdParams, rng: np.random.Generator) -> np.ndarray:
    """Per-ped desired speed (n,) [m/s]: peds_speed_mult x spawn speed, or a clipped normal speed tier (SPEED_TIERS)."""
    if cfg.ped_speed_tier == "reference":
        return np.full(n, cfg.peds_speed_mult * crowd.spawn_speed)
    mean, std = SPEED_TIERS[cfg.ped_speed_tier]
    v = rng.normal(mean, std, size=n)
    return np.clip(v, *crowd.tier_clip)


def _rows(parts: list[np.ndarray]) -> np.ndarray:
    """Stack (k, 2) blocks and (2,) rows into one (N, 2) float array (empty -> (0, 2))."""
    return np.concatenate([np.reshape(p, (-1, 2)) for p in parts]) if parts else np.zeros((0, 2))


def _toward(points: np.ndarray, goal: np.ndarray, speed: np.ndarray) -> np.ndarray:
    """Velocities (K, 2) of magnitude speed (K,) from the points' centroid towards goal."""
    d = goal - points.mean(axis=0)
    n = float(np.hypot(*d))
    e = d / n if n > 0 else np.zeros(2)
    return speed[:, None] * e


def _cluster_members(
    anchor: np.ndarray, k: int, rng: np.random.Generator, crowd: CrowdParams, valid: Validator
) -> np.ndarray | None:
    """k points around an anchor, world-axis normal offsets shrinking with failed attempts (None = give up)."""
    members: list[np.ndarray] = []
    max_attempts = 50 * k
    for attempt in range(max_attempts):
        scale = max(0.2, 1.0 - attempt / max_attempts)
        off = np.clip(rng.normal(0.0, crowd.cluster_std * scale, 2), -crowd.cluster_clip, crowd.cluster_clip)
        cand = anchor + off
        if valid(cand[None])[0]:
            members.append(cand)
            if len(members) == k:
                return np.asarray(members)
    return None


def _route_anchors(
    sizes: list[int], routes: list[RouteGeometry], cfg: SimulationConfig, rng: np.random.Generator
) -> list[tuple[int, float]]:
    """(route, arc offset) per group: length-weighted routes; uniform (cluster) or evenly spaced (spread) offsets."""
    lengths = np.array([r.length for r in routes])
    p = lengths / lengths.sum()
    choice = rng.choice(len(routes), size=len(sizes), p=p)
    if cfg.route_spawn_distribution == "cluster":
        return [(int(r), float(rng.uniform(0, routes[r].length))) for r in choice]
    out: list[tuple[int, float]] = [(0, 0.0)] * len(sizes)
    for r in range(len(routes)):
        members = np.nonzero(choice == r)[0]
        if len(members) == 0:
            continue
        spacing = routes[r].length / len(members)
        jitter = rng.uniform(-1, 1, size=len(members)) * cfg.route_spawn_jitter_frac * spacing
        for k, g in enumerate(members):
            out[g] = (r, float(np.clip((k + 0.5) * spacing + jitter[k], 0, routes[r].length)))
    return out


def spawn_route_groups(
    sizes: list[int],
    routes: list[RouteGeometry],
    cfg: SimulationConfig,
    crowd: CrowdParams,
    rng: np.random.Generator,
    valid: Validator,
    check: Callable[[], None] | None = None,
) -> list[tuple[np.ndarray, int, int]]:
    """Per group: member positions (k, 2), route index, index of the waypoint ending the anchor's section;
    ``check`` (cancellation, deadline) is called every :data:`CHECK_GROUPS` groups."""
    out = []
    anchors = _route_anchors(sizes, routes, cfg, rng)
    for i, (k, (r, s)) in enumerate(zip(sizes, anchors, strict=True)):
        if check is not None and i % CHECK_GROUPS == 0:
            check()
        for _ in range(5):
            anchor, section = routes[r].point_at(s)
            members = _cluster_members(anchor, k, rng, crowd, valid)
            if members is not None:
                out.append((members, r, section + 1))
                break
            s = float(rng.uniform(0, routes[r].length))
        else:
            raise ConfigError(
                f"could not place a group of {k} along ped route {r} (obstacles or robot in the way)"
            )
    return out


def single_start(sp: SinglePedestrian) -> tuple[np.ndarray, np.ndarray]:
    """Initial goal and spawn velocity of a scripted pedestrian (reference §1.4)."""
    start = np.asarray(sp.start, dtype=float)
    target = None
    if sp.start_delay_s <= 0:
        if sp.goal is not None:
            target = np.asarray(sp.goal, dtype=float)
        elif sp.trajectory:
            target = np.asarray(sp.trajectory[0], dtype=float)
    if target is None:
        return start, np.zeros(2)
    d = target - start
    n = float(np.hypot(*d))
    return target, (sp.speed_m_s * d / n if n > 0 else np.zeros(2))


def _zone_groups(
    sizes: list[int],
    map_def: MapDef,
    cfg: SimulationConfig,
    rng: np.random.Generator,
    valid: Validator,
    check: Callable[[], None] | None = None,
) -> list[tuple[np.ndarray, np.ndarray, int]]:
    """Per crowded-zone group: member positions (k, 2), shared goal (2,), zone index (area-weighted choice)."""
    zones = map_def.ped_crowded_zones
    if not sizes:
        return []
    areas = np.array([z.area for z in zones])
    out = []
    for i, k in enumerate(sizes):
        if check is not None and i % CHECK_GROUPS == 0:
            check()
        z = int(rng.choice(len(zones), p=areas / areas.sum()))
        members = sample_free(zones[z], k, rng, cfg.zone_sampling, valid, what="crowded zone")
        out.append((members, sample_free(zones[z], 1, rng, cfg.zone_sampling, valid)[0], z))
    return out


def _crowd_velocities(
    blocks: list[tuple[np.ndarray, np.ndarray]], vmax: np.ndarray, mult: float
) -> np.ndarray:
    """Spawn velocities (N, 2): each group heads for its goal at desired speed / peds_speed_mult (0.5 m/s reference)."""
    vel = np.zeros((len(vmax), 2))
    start = 0
    for members, goal in blocks:
        sl = slice(start, start + len(members))
        vel[sl] = _toward(members, goal, vmax[sl] / mult)
        start += len(members)
    return vel


def build_population(
    map_def: MapDef,
    cfg: SimulationConfig,
    crowd: CrowdParams,
    rng: np.random.Generator,
    spread_rng: np.random.Generator,
    valid: Validator,
    check: Callable[[], None] | None = None,
) -> Population:
    """Spawn the whole crowd: crowded-zone groups, route groups, then single peds.

    ``valid`` rejects candidate points (inside obstacles, or too close to the robot's start);
    ``spread_rng`` drives route placement in ``spread`` mode (the reference's route_spawn_seed); ``check``
    (cancellation, deadline) is called while groups are placed.
    """
    n_zone, n_route = population_counts(map_def, cfg, crowd)
    zoned = _zone_groups(
        group_sizes(n_zone, cfg.max_peds_per_group, rng, crowd.group_size_decay),
        map_def,
        cfg,
        rng,
        valid,
        check,
    )
    route_sizes = group_sizes(n_route, cfg.max_peds_per_group, rng, crowd.group_size_decay)
    routes = [RouteGeometry(r) for r in map_def.ped_routes]
    placement_rng = spread_rng if cfg.route_spawn_distribution == "spread" else rng
    placed = (
        spawn_route_groups(route_sizes, routes, cfg, crowd, placement_rng, valid, check)
        if route_sizes
        else []
    )
    blocks = [(m, g) for m, g, _ in zoned] + [(m, routes[r].points[wp]) for m, r, wp in placed]
    n_crowd = sum(len(m) for m, _ in blocks)
    vmax = desired_speeds(n_crowd, cfg, crowd, rng)
    factors = heterogeneity.speed_factors(n_crowd, cfg, rng)
    if factors is not None:
        vmax = vmax * factors
    response = heterogeneity.robot_responses(n_crowd, cfg, rng)
    vel = _crowd_velocities(blocks, vmax, cfg.peds_speed_mult)
    singles = list(map_def.single_pedestrians)
    starts = [single_start(sp) for sp in singles]
    # the reference's bug fix: a single ped's desired speed is its scripted speed, even when it spawns at rest
    s_vmax = np.array([cfg.peds_speed_mult * sp.speed_m_s for sp in singles])
    sizes = [len(m) for m, _ in blocks] + [1] * len(singles)
    group_arr = np.repeat(np.arange(len(sizes)), sizes).astype(np.intp)
    return Population(
        pos=_rows([m for m, _ in blocks] + [sp.start for sp in singles]),
        vel=np.concatenate([vel, _rows([v for _, v in starts])]),
        goal=_rows(
            [np.repeat(np.reshape(g, (1, 2)), len(m), axis=0) for m, g in blocks] + [t for t, _ in starts]
        ),
        vmax=np.concatenate([vmax, s_vmax]),
        group=group_arr,
        group_size=np.asarray(sizes, dtype=float),
        route_groups=np.arange(len(zoned), len(blocks)),
        route_of_group=np.array([r for _, r, _ in placed], dtype=np.intp),
        route_wp=np.array([wp for _, _, wp in placed], dtype=np.intp),
        zone_groups=np.arange(len(zoned)),
        zone_of_group=np.array([z for _, _, z in zoned], dtype=np.intp),
        singles=singles,
        robot_response=None if response is None else np.concatenate([response, np.ones(len(singles))]),
    )


__all__ = [
    "Population",
    "build_population",
    "pedestrian_count",
    "population_counts",
    "group_sizes",
    "sample_zone",
]
