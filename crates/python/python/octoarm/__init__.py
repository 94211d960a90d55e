"""octoarm: discrete Cosserat rod simulator and energy-shaping controller of the CyberOctopus arm.

Thin Python bindings of the Rust crates (``octoarm-physics``, ``octoarm-control`` and the
application's library, without its command line). All quantities are SI. Array getters return
fresh NumPy copies (float64, C-contiguous); nothing returned aliases the simulator's memory,
because stepping rewrites it with the GIL released.

* :class:`Simulation`: one rod (``Simulation(...)``, ``Simulation.paper_arm()``) or a system of
  named rods (``Simulation.from_rods([Rod(...), ...], joints=[Joint(...)])``), with per-rod
  state (``rod_state``, ``set_rod_state``, ``state``, ``set_state``), loads, damping and rest
  strains (``rod=`` a rod's name). ``pickle`` and ``copy.deepcopy`` are exact.
* :class:`Rod`, :class:`Motion`, :class:`Joint`: a rod with its end conditions ("free",
  "pinned", "clamped" or a driven ``Motion``), and joints between rod ends ("rod.base",
  "rod.tip").
* :class:`OfflineSolver`, :class:`Design`, :class:`EnergyShapingController`: the controller.
* COOMM's muscular arm in 3D (muscles-3d spec): ``Simulation.coomm_arm()`` with
  ``set_activations`` ((7, n) arrays, rows named by :data:`MUSCLE_GROUPS`),
  :class:`MuscleDesign` (the equilibrium for given activations and the SE(3) reach design over
  activations) and :class:`MuscleShapingController` (hold a design with COOMM's 1 s ramp).
* :func:`run_scenario`: ``octoarm run`` on a scenario file, passive or controlled.
* ``octoarm.sweep(sweep_file, out, ray=None)``: ``octoarm sweep``, locally or on a Ray cluster
  (:mod:`octoarm.sweep`; :class:`Sweep` is its Rust core).

Array arguments take any real dtype (converted to float64) of exactly the stated shape, with
finite entries. Objects can be shared between threads: calls are serialised (a reader waits for
a running ``step``, with the GIL released). Type stubs ship with the package.

Importing this package registers the Gymnasium environments ``octoarm/ArmReach-v0``,
``octoarm/ArmReach-v1`` (the learnable task: reach reward, error observed, incremental
commands) and ``octoarm/ArmReachGoal-v1`` (goal-conditioned, for HER) (see :mod:`octoarm.env`) and ``octoarm/MuscleReach3D-v0``
(COOMM's muscular arm reaching a 3D pose with the seven group activations per segment, see
:mod:`octoarm.muscle_env`); :mod:`octoarm.sb3` (needs Stable-Baselines3) has ``RustVecEnv``, an
SB3 ``VecEnv`` over the Rust vector environment.
"""

from ._octoarm import (  # noqa: F401
    ArmBatch,
    Design,
    EnergyShapingController,
    InstabilityError,
    Joint,
    Motion,
    MuscleBatch,
    MuscleDesign,
    MuscleShapingController,
    OfflineSolver,
    Rod,
    Simulation,
    Sweep,
    __version__,
    run_scenario,
    rust_step_rate,
)

__all__ = [
    "ArmBatch",
    "Design",
    "EnergyShapingController",
    "InstabilityError",
    "Joint",
    "Motion",
    "MUSCLE_GROUPS",
    "MuscleBatch",
    "MuscleDesign",
    "MuscleShapingController",
    "OfflineSolver",
    "Rod",
    "Simulation",
    "Sweep",
    "__version__",
    "run_scenario",
    "rust_step_rate",
]

MUSCLE_GROUPS = ("TM", "LM0", "LM1", "LM2", "LM3", "OM+", "OM-")
"""Names of the seven muscle groups, in the row order of every (7, n) activation array:
transverse, longitudinal 0..3 (on +d1, +d2, -d1, -d2), oblique right- and left-handed."""


def _register() -> None:
    import gymnasium

    from .env import V1_EPISODE_STEPS, V1_TASK

    if "octoarm/ArmReach-v0" not in gymnasium.registry:
        gymnasium.register(
            id="octoarm/ArmReach-v0",
            entry_point="octoarm.env:ArmReachEnv",
            vector_entry_point="octoarm.env:ArmReachVectorEnv",
            max_episode_steps=200,
        )
    if "octoarm/ArmReach-v1" not in gymnasium.registry:
        # The learnable task (issue 16): a reward whose last millimetres count, the tip's
        # error observed, incremental commands; info["is_success"] within 1 cm.
        gymnasium.register(
            id="octoarm/ArmReach-v1",
            entry_point="octoarm.env:ArmReachEnv",
            vector_entry_point="octoarm.env:ArmReachVectorEnv",
            max_episode_steps=V1_EPISODE_STEPS,
            kwargs=dict(V1_TASK),
        )
    if "octoarm/ArmReachGoal-v1" not in gymnasium.registry:
        gymnasium.register(
            id="octoarm/ArmReachGoal-v1",
            entry_point="octoarm.env:ArmReachGoalEnv",
            max_episode_steps=V1_EPISODE_STEPS,
            kwargs={k: V1_TASK[k] for k in ("control_period", "targets", "damping_rate")},
        )
    if "octoarm/MuscleReach3D-v0" not in gymnasium.registry:
        from .muscle_env import EPISODE_STEPS as MUSCLE_EPISODE_STEPS

        gymnasium.register(
            id="octoarm/MuscleReach3D-v0",
            entry_point="octoarm.muscle_env:MuscleReach3DEnv",
            vector_entry_point="octoarm.muscle_env:MuscleReach3DVectorEnv",
            max_episode_steps=MUSCLE_EPISODE_STEPS,
        )


_register()

from . import env  # noqa: E402,F401  (ArmReachEnv, ArmReachVectorEnv, ArmReachGoalEnv)
from . import muscle_env  # noqa: E402,F401  (MuscleReach3DEnv, MuscleReach3DVectorEnv)
from . import sweep  # noqa: E402,F401  (callable: octoarm.sweep(...) runs a sweep)
