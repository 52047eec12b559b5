"""The one typed parameter set of the pedestrian model, with the reference (robot_sf / fast-pysf) defaults.

Every constant of the social-force crowd lives here exactly once; force functions take a
``ForceParams`` and never look values up by name. Units in brackets; accelerations are forces on a
unit mass [m/s^2].
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class ForceParams:
    """Social-force constants (reference defaults, see docs reference-simulation §1.2)."""

    # desired (goal) force
    desired_factor: float = 1.0
    relaxation_time: float = 0.5  #: [s]
    goal_threshold: float = 0.2  #: inside this distance the desired force only brakes [m]
    # Moussaid ped-ped force
    social_factor: float = 5.1
    social_lambda: float = 2.0  #: weight of the relative velocity in the interaction direction [s]
    social_gamma: float = 0.35  #: interaction range per unit |w| [m]
    social_n: float = 2.0  #: angular decay of the sideways term
    social_n_prime: float = 3.0  #: angular decay of the deceleration term
    social_max_range: float = 20.0  #: the reference's centre-distance activation threshold [m]
    social_pair_tolerance: float = 0.01  #: largest force one ignored neighbour may contribute [m/s^2]
    social_wrap_theta: bool = False  #: False = the reference's unwrapped angle difference
    # obstacle force (segments incl. map bounds)
    obstacle_factor: float = 10.0
    obstacle_offset: float = -0.57  #: threshold + agent_radius * sigma of the reference [m]
    # group terms
    group_coherence_factor: float = 3.0
    group_repulsion_factor: float = 1.0
    group_repulsion_range: float = 0.55  #: [m]
    group_gaze_factor: float = 4.0
    # robot -> pedestrian repulsion
    robot_factor: float = 10.0
    robot_activation: float = 2.0  #: added to agent radius + robot radius to give the cutoff [m]
    agent_radius: float = 0.35  #: pysf agent radius; only enters the robot-force cutoff [m]

    def robot_cutoff(self, robot_radius: float) -> float:
        """Centre-distance cutoff of the robot repulsion [m] (3.35 m for the 1.0 m robot)."""
        return self.robot_activation + self.agent_radius + robot_radius

    def social_cutoff(self, max_speed: float) -> float:
        """Neighbour cutoff [m] for the ped-ped force given the fastest pedestrian speed [m/s].

        One neighbour at distance d contributes at most sqrt(2) * factor * exp(-d / B) with
        B = gamma * (lambda * |v_j - v_i| + 1) <= gamma * (2 * lambda * max_speed + 1). Cutting at the
        d where that bound equals ``social_pair_tolerance`` bounds the error per ignored neighbour
        (0.01 m/s^2 by default: 8.3 m at the reference speed 0.65 m/s), capped at the reference's 20 m.
        """
        b_max = self.social_gamma * (2.0 * self.social_lambda * max_speed + 1.0)
        r = b_max * math.log(math.sqrt(2.0) * self.social_factor / self.social_pair_tolerance)
        return min(self.social_max_range, max(r, 0.0))


@dataclass(frozen=True)
class CrowdParams:
    """Population and behaviour constants (reference defaults, §1.3-1.5)."""

    sidewalk_width: float = 3.0  #: route area = route length x this [m]
    spawn_speed: float = 0.5  #: reference spawn speed of route/zone peds [m/s]
    group_size_decay: float = 0.3  #: P(k) proportional to decay^(k-1)
    cluster_std: float = 0.75  #: lateral spawn std around a route anchor [m] (3.0 / 4)
    cluster_clip: float = 1.5  #: lateral spawn offsets clipped to +-this [m]
    route_threshold: float = 1.0  #: group-centroid waypoint proximity [m]
    single_threshold: float = 0.2  #: single-ped waypoint proximity [m]
    tier_clip: tuple[float, float] = (0.1, 3.0)  #: desired-speed tier range [m/s]
    robot_spawn_margin: float = 0.5  #: extra clearance of spawning peds beyond collision distance [m]
    #: half-angle [deg] of the cone ahead of a moving robot in which (re)spawns also keep clear of its
    #: stopping distance v^2 / (2 decel) (see ``core.sim.simulator.stopping_zone_clear``)
    robot_spawn_cone_deg: float = 60.0
    wall_constraint: bool = True  #: keep pedestrians out of obstacles (see core.sim.walls)
    wall_clearance: float = 1e-3  #: how far a stopped pedestrian stays off an edge line [m]
    dense_pair_limit: int = (
        64  #: up to this many peds the (N, N) grid, above a cell list (measured crossover 50-80)
    )


#: desired-speed tiers: (mean, std) of a normal clipped to ``CrowdParams.tier_clip`` [m/s]. slow/typical/brisk
#: are the reference's tiers (robot_sf ``pedestrian_speed_tiers``, std 0.2). ``realistic`` is the free walking
#: speed of pedestrians measured in the field: mean 1.34 m/s, standard deviation 0.26 m/s (U. Weidmann,
#: "Transporttechnik der Fussgaenger", Schriftenreihe des IVT Nr. 90, ETH Zuerich, 1993, from 58 studies; the
#: values Helbing & Molnar, Phys. Rev. E 51:4282, 1995, use for social-force desired speeds).
SPEED_TIERS: dict[str, tuple[float, float]] = {
    "slow": (0.65, 0.2),
    "typical": (1.3, 0.2),
    "brisk": (1.6, 0.2),
    "realistic": (1.34, 0.26),
}
