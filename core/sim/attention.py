"""Who reacts to the robot, and from how far: a per-pedestrian robot reaction range.

The reference has every pedestrian feel the robot's repulsion within 3.35 m of its centre
(``ForceParams.robot_cutoff``). Real pedestrians are often distracted, talking, or simply expect the
robot to give way, so a scenario sets two shares:

- ``nonreactive_fraction``: pedestrians that ignore the robot entirely; they still avoid each other
  and walls, and walk through the robot's spot as if it were not there;
- ``late_reaction_fraction``: of the remaining ones, pedestrians that notice the robot late, only
  within ``late_reaction_distance`` (centre to centre), instead of at the force's own cutoff.

Exactly round-half-up(share x N) pedestrians are chosen, uniformly without replacement, by a
generator of their own: changing a share changes no other draw of the episode, so two settings of
the same (scenario, seed) run the same crowd (paired comparisons). A respawned pedestrian keeps its
row's reaction, so the shares hold over the whole episode.
"""

from __future__ import annotations

import numpy as np

from foresight.core.scenarios.model import SimulationConfig


def _count(share: float, n: int) -> int:
    return int(np.floor(share * n + 0.5))


def reaction_ranges(n: int, cfg: SimulationConfig, cutoff: float, rng: np.random.Generator) -> np.ndarray:
    """(n,) centre distance within which each pedestrian feels the robot [m]; 0 = never."""
    if not cfg.peds_have_robot_repulsion:
        return np.zeros(n)
    reach = np.full(n, cutoff)
    order = rng.permutation(n)
    k_non = _count(cfg.nonreactive_fraction, n)
    k_late = _count(cfg.late_reaction_fraction, n - k_non)
    reach[order[:k_non]] = 0.0
    reach[order[k_non : k_non + k_late]] = min(cfg.late_reaction_distance, cutoff)
    return reach
