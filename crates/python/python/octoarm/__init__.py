"""octoarm: discrete Cosserat rod simulator and energy-shaping controller of the CyberOctopus arm.

Thin Python bindings of the Rust crates (``octoarm-physics``, ``octoarm-control``). All
quantities are SI. Array getters return fresh NumPy copies (float64, C-contiguous); nothing
returned aliases the simulator's memory, because stepping rewrites it with the GIL released.

Importing this package registers the Gymnasium environment ``octoarm/ArmReach-v0``
(see :mod:`octoarm.env`).
"""

from ._octoarm import (  # noqa: F401
    ArmBatch,
    Design,
    EnergyShapingController,
    InstabilityError,
    OfflineSolver,
    Simulation,
    __version__,
    rust_step_rate,
)

__all__ = [
    "ArmBatch",
    "Design",
    "EnergyShapingController",
    "InstabilityError",
    "OfflineSolver",
    "Simulation",
    "__version__",
    "rust_step_rate",
]

try:  # run_scenario needs the app crate; present when the package was built with it.
    from ._octoarm import run_scenario  # noqa: F401

    __all__.append("run_scenario")
except ImportError:  # pragma: no cover
    pass


def _register() -> None:
    import gymnasium

    if "octoarm/ArmReach-v0" not in gymnasium.registry:
        gymnasium.register(
            id="octoarm/ArmReach-v0",
            entry_point="octoarm.env:ArmReachEnv",
            vector_entry_point="octoarm.env:ArmReachVectorEnv",
            max_episode_steps=200,
        )


_register()

from . import env  # noqa: E402,F401  (ArmReachEnv, ArmReachVectorEnv)
