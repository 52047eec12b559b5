"""Gymnasium environments over the simulator (needs the ``gym`` extra: ``pip install 'foresight[gym]'``).

Importing this package registers ``foresight/CrowdNav-v0`` (``import gymnasium`` before ``import foresight``
does it too): ``gymnasium.make("foresight/CrowdNav-v0", scenario="crossing_low")``; ``gymnasium.make_vec`` gives
the vectorised form.
"""

from gymnasium.envs.registration import register, registry

ENV_ID = "foresight/CrowdNav-v0"


def register_envs() -> None:
    """Register the environments once per process."""
    if ENV_ID not in registry:
        register(id=ENV_ID, entry_point="foresight.core.gym.env:CrowdNavEnv")


register_envs()
