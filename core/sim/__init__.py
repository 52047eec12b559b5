"""Crowd simulator: social-force pedestrians, a differential-drive robot, collisions, episode trace.

Modules: ``params`` (the one parameter set), ``forces`` (one function per social-force term),
``neighbours`` (pair lists), ``geometry`` (segments, polygons, distance queries), ``walls`` (hard
wall constraint), ``zones`` (sampling), ``population`` (initial crowd), ``behaviours`` (goal
updates, respawn, scripted peds), ``crowd`` (force sum and integration), ``robot`` (kinematics,
``unicycle_step`` shared with the planners), ``navigation`` (robot route), ``collision``,
``trace``, ``simulator`` (``Simulator``), ``episode`` (``run_episode``). Contract types live in
``observation``.

Follows the reference (robot_sf, docs reference-simulation §1-§4, §10) with these deliberate
differences:
- pedestrians never enter obstacles or leave the map (``walls``); the reference only has a soft
  force that vanishes at contact; scripted starts lying exactly on an edge are pushed off it;
- a pedestrian's desired speed is a per-ped parameter: the reference froze it from the spawn
  velocity, so scripted peds spawned at rest (start delay, waits) could never move;
- ``ped_speed_tier`` slow/typical/brisk draws desired speeds from N(0.65|1.3|1.6, 0.2) clipped to
  [0.1, 3.0] m/s (the reference clips at 0); ``realistic`` from measured walking speeds, N(1.34, 0.26)
  (``params.SPEED_TIERS``); scripted peds keep 1.3 x their scripted speed;
- per scenario, a share of pedestrians ignores the robot (``nonreactive_fraction``) and a share of the
  others notices it late, only within ``late_reaction_distance`` (``attention``); the reference has
  every pedestrian feel the robot within 3.35 m;
- replay scenarios (``Scenario.replay``) move recorded ETH/UCY pedestrians along their tracks (``replay``);
- no pedestrian spawns (or respawns) within r_robot + r_ped + 0.5 m of the robot (a scenario's
  ``robot_spawn_clearance`` instead of 0.5 where set; a replayed track that would begin there is left
  out; ``spawn_check`` finds episodes a standing robot loses anyway); the robot's
  start keeps the same distance from scripted peds and, where its zone allows, does not touch a
  wall (robot_sf starts some head-on corridor / T-intersection episodes in collision); a group
  whose spawn zone is blocked waits;
- the ped-ped force ignores neighbours beyond a cutoff chosen so that each ignored neighbour
  contributes < 0.01 m/s^2 (8.3 m at 0.65 m/s; the reference uses 20 m);
- the robot is commanded by (v, omega) targets tracked within its acceleration limits
  (``RobotConfig.actuation="reference_lag"`` restores the benchmark's first-order lag);
- all randomness comes from generators derived from (seed, scenario name), never global state;
- single-pedestrian roles and holds follow robot_sf except: a ``join`` pedestrian walks with its
  target but does not enter its social group; a timed wait at a hold waypoint is followed by the
  hold (robot_sf skips it); a ``hold_ref_point`` off the trajectory is an error (docs/scenarios.md).
"""
