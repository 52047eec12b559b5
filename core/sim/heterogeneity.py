"""Heterogeneous route/zone pedestrians from robot_sf compositions: walking-speed archetypes and robot-response laws.

Both follow robot_sf: counts per label by largest remainder (exact, ties by name), labels in name
order shuffled by a generator seeded with the composition's own seed when given (the same
assignment every episode, as robot_sf's ``default_rng(seed)``), else with the episode's.
"""

from __future__ import annotations

import math

import numpy as np

from foresight.core.scenarios.model import SimulationConfig


def allocate_counts(n: int, composition: dict[str, float]) -> dict[str, int]:
    """n split over the labels by largest remainder; ties broken by label name."""
    raw = {name: share * n for name, share in composition.items()}
    counts = {name: math.floor(v) for name, v in raw.items()}
    order = sorted(composition, key=lambda name: (-(raw[name] - counts[name]), name))
    for i in range(n - sum(counts.values())):
        counts[order[i % len(order)]] += 1
    return counts


def assign_labels(
    n: int, composition: dict[str, float], seed: int | None, rng: np.random.Generator
) -> list[str]:
    """One label per pedestrian (n), composition counts in shuffled order."""
    counts = allocate_counts(n, composition)
    labels = np.array([name for name in sorted(counts) for _ in range(counts[name])], dtype=object)
    (np.random.default_rng(seed) if seed is not None else rng).shuffle(labels)
    return [str(x) for x in labels]


def speed_factors(n: int, cfg: SimulationConfig, rng: np.random.Generator) -> np.ndarray | None:
    """(n,) desired-speed factors of the crowd peds from ``archetype_composition``, None without one."""
    if cfg.archetype_composition is None or cfg.archetype_speed_factors is None:
        return None
    labels = assign_labels(n, cfg.archetype_composition, cfg.archetype_seed, rng)
    return np.array([cfg.archetype_speed_factors[label] for label in labels], dtype=float).reshape(n)


def robot_responses(n: int, cfg: SimulationConfig, rng: np.random.Generator) -> np.ndarray | None:
    """(n,) multipliers of the robot repulsion of the crowd peds from ``response_law_composition``, None without one."""
    if cfg.response_law_composition is None:
        return None
    law = {
        "reactive": 1.0,
        "non_reactive": cfg.non_reactive_response_multiplier,
        "non_yielding": cfg.non_reactive_response_multiplier,
        "hesitating": cfg.hesitating_response_multiplier,
    }
    labels = assign_labels(n, cfg.response_law_composition, cfg.response_law_seed, rng)
    return np.array([law[label] for label in labels], dtype=float).reshape(n)
