# Type stubs of the extension module octoarm._octoarm (Rust, PyO3). Keep in step with
# crates/python/src; tests/test_python_typing.py checks them (mypy --strict on a usage file,
# stubtest against the built module when mypy is installed).
#
# Array arguments accept any array-like of real numbers (any float or integer dtype, converted
# to float64) of exactly the documented shape, with finite entries; array results are fresh
# float64 (observations: float32) C-contiguous NumPy copies.

import os
from typing import Any, Literal, Sequence, final

import numpy as np
import numpy.typing as npt

__version__: str
__all__ = [
    "ArmBatch",
    "Design",
    "EnergyShapingController",
    "InstabilityError",
    "Joint",
    "Motion",
    "MuscleBatch",
    "MuscleDesign",
    "MuscleShapingController",
    "OfflineSolver",
    "Rod",
    "Simulation",
    "__version__",
    "_simulation_from_bytes",
    "run_scenario",
    "rust_step_rate",
    "Sweep",
]

_F64 = npt.NDArray[np.float64]
_F32 = npt.NDArray[np.float32]
# A 3-vector argument: any array-like of three real numbers (list, tuple, NumPy array of any
# real dtype); exactly shape (3,), finite.
_Vec3 = Sequence[float] | npt.NDArray[Any]
_EndCondition = str | Motion

class InstabilityError(RuntimeError):
    """The stability guard stopped a simulation (see the attributes)."""

    what: str
    value: float
    domain: str
    index: int
    element: int
    rod: str | None
    time: float
    step: int
    dt: float
    suggested_dt: float
    advice: str
    report: dict[str, Any]

@final
class Motion:
    def __new__(
        cls,
        times: npt.ArrayLike,
        displacement: npt.ArrayLike | None = None,
        rotation: npt.ArrayLike | None = None,
        slides_along: _Vec3 | None = None,
    ) -> Motion: ...
    @staticmethod
    def constant_rotation(rate: _Vec3, until: float) -> Motion: ...
    @property
    def times(self) -> _F64: ...
    @property
    def displacement(self) -> _F64: ...
    @property
    def rotation(self) -> _F64: ...
    def at(self, t: float) -> tuple[_F64, _F64]: ...

@final
class Rod:
    def __new__(
        cls,
        name: str = "rod",
        n_elements: int = 100,
        length: float = 0.2,
        base_diameter: float = 0.02,
        tip_diameter: float = 0.0004,
        density: float = 700.0,
        youngs_modulus: float = 10000.0,
        shear_modulus: float = 1000.0,
        shear_coefficient: float = ...,
        base_position: _Vec3 | None = ...,
        direction: _Vec3 | None = ...,
        normal: _Vec3 | None = ...,
        rest_curvature: _Vec3 | None = ...,
        base: _EndCondition | None = "clamped",
        tip: _EndCondition | None = "free",
        positions: npt.ArrayLike | None = None,
        directors: npt.ArrayLike | None = None,
    ) -> Rod: ...
    @property
    def name(self) -> str: ...
    @property
    def n_elements(self) -> int: ...
    @property
    def length(self) -> float: ...
    @property
    def base_diameter(self) -> float: ...
    @property
    def tip_diameter(self) -> float: ...
    @property
    def density(self) -> float: ...
    @property
    def youngs_modulus(self) -> float: ...
    @property
    def shear_modulus(self) -> float: ...
    @property
    def shear_coefficient(self) -> float: ...
    @property
    def base_position(self) -> list[float]: ...
    @property
    def direction(self) -> list[float]: ...
    @property
    def normal(self) -> list[float]: ...
    @property
    def rest_curvature(self) -> list[float]: ...
    @property
    def base(self) -> _EndCondition: ...
    @property
    def tip(self) -> _EndCondition: ...

@final
class Joint:
    def __new__(
        cls,
        kind: str,
        first: str,
        second: str,
        axis: _Vec3 | None = None,
        stiffness: float | None = None,
        damping: float | None = None,
        rotational_stiffness: float | None = None,
        rotational_damping: float | None = None,
    ) -> Joint: ...
    @property
    def kind(self) -> str: ...
    @property
    def first(self) -> str: ...
    @property
    def second(self) -> str: ...
    @property
    def axis(self) -> list[float] | None: ...
    @property
    def stiffness(self) -> float | None: ...
    @property
    def damping(self) -> float | None: ...
    @property
    def rotational_stiffness(self) -> float | None: ...
    @property
    def rotational_damping(self) -> float | None: ...

@final
class Simulation:
    """Thread-safe: calls from several threads are serialised (readers wait for a step)."""

    def __new__(
        cls,
        n_elements: int = 100,
        length: float = 0.2,
        base_diameter: float = 0.02,
        tip_diameter: float = 0.0004,
        density: float = 700.0,
        youngs_modulus: float = 10000.0,
        shear_modulus: float = 1000.0,
        shear_coefficient: float = ...,
        base_position: _Vec3 | None = ...,
        direction: _Vec3 | None = ...,
        normal: _Vec3 | None = ...,
        rest_curvature: _Vec3 | None = ...,
        boundary: str | None = None,
        dt: float | Literal["auto"] = 1e-05,
        energy_consistent: bool = False,
        base: _EndCondition | None = None,
        tip: _EndCondition | None = None,
    ) -> Simulation: ...
    @staticmethod
    def paper_arm(dt: float | Literal["auto"] = 1e-05, n_elements: int = 100) -> Simulation: ...
    @staticmethod
    def coomm_arm(
        dt: float | Literal["auto"] = 1e-05,
        n_elements: int = 100,
        drag: bool = True,
        damping: bool = True,
    ) -> Simulation: ...
    def set_activations(self, activations: npt.ArrayLike) -> None: ...
    @property
    def activations(self) -> _F64: ...
    @staticmethod
    def from_rods(
        rods: Sequence[Rod],
        joints: Sequence[Joint] = (),
        dt: float | Literal["auto"] = 1e-05,
        energy_consistent: bool = False,
        clamp_order: int = 1,
    ) -> Simulation: ...
    def copy(self) -> Simulation: ...
    def __copy__(self) -> Simulation: ...
    def __deepcopy__(self, memo: Any, /) -> Simulation: ...
    def to_bytes(self) -> bytes: ...
    @staticmethod
    def from_bytes(data: bytes) -> Simulation: ...
    def __reduce__(self) -> tuple[Any, tuple[bytes]]: ...
    def step(self, n: int = 1) -> None: ...
    @property
    def rod_names(self) -> list[str]: ...
    @property
    def n_rods(self) -> int: ...
    def rod_state(self, name: str | None = None) -> dict[str, Any]: ...
    def set_rod_state(
        self,
        name: str | None = None,
        *,
        positions: npt.ArrayLike | None = None,
        velocities: npt.ArrayLike | None = None,
        directors: npt.ArrayLike | None = None,
        angular_velocities: npt.ArrayLike | None = None,
    ) -> None: ...
    def state(self) -> dict[str, dict[str, Any]]: ...
    def set_state(self, d: dict[str, dict[str, Any]]) -> None: ...
    def add_gravity(self, acceleration: _Vec3, rod: str | None = None) -> None: ...
    def add_node_force(
        self,
        force: _Vec3,
        node: int | None = None,
        ramp_time: float = 0.0,
        rod: str | None = None,
    ) -> None: ...
    def add_uniform_force(self, force_per_length: _Vec3, rod: str | None = None) -> None: ...
    def add_element_couple(
        self,
        couple: _Vec3,
        element: int | None = None,
        ramp_time: float = 0.0,
        follower: bool = False,
        rod: str | None = None,
    ) -> None: ...
    def add_uniform_couple(
        self, couple_per_length: _Vec3, follower: bool = False, rod: str | None = None
    ) -> None: ...
    def clear_loads(self) -> None: ...
    def add_obstacle(
        self,
        center: _Vec3,
        radius: float,
        velocity: _Vec3 | None = ...,
        friction: float | _Vec3 | None = None,
        kinetic_friction: float | _Vec3 | None = None,
    ) -> None: ...
    def add_plane(
        self,
        point: _Vec3,
        normal: _Vec3,
        friction: float | _Vec3 | None = None,
        kinetic_friction: float | _Vec3 | None = None,
    ) -> None: ...
    def add_cylinder(
        self,
        center: _Vec3,
        axis: _Vec3,
        radius: float,
        length: float,
        velocity: _Vec3 | None = ...,
        friction: float | _Vec3 | None = None,
        kinetic_friction: float | _Vec3 | None = None,
    ) -> None: ...
    def set_contact(
        self,
        beta: float = 1.0,
        zeta: float = 0.5,
        rods: bool = False,
        self_contact: bool = False,
        rod_friction: float | _Vec3 | None = None,
        rod_kinetic_friction: float | _Vec3 | None = None,
        friction_eta: float = 0.5,
        stick_stiffness: float = 0.5,
        slip_velocity: float = 0.001,
        rod_geometry: Literal["polyline", "smooth"] = "polyline",
    ) -> None: ...
    def clear_obstacles(self) -> None: ...
    def set_damping(self, rate: float = 0.0, gamma: float = 0.0, rod: str | None = None) -> None: ...
    def set_rest_strains(
        self, sigma: npt.ArrayLike, kappa: npt.ArrayLike, rod: str | None = None
    ) -> None: ...
    def rest_strains(self, rod: str | None = None) -> tuple[_F64, _F64]: ...
    @property
    def n_elements(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @property
    def auto_dt(self) -> bool: ...
    @property
    def stable_dt(self) -> float: ...
    @property
    def time(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def positions(self) -> _F64: ...
    @property
    def velocities(self) -> _F64: ...
    @property
    def directors(self) -> _F64: ...
    @property
    def angular_velocities(self) -> _F64: ...
    @property
    def tip(self) -> _F64: ...
    @property
    def rest_sigma(self) -> _F64: ...
    @property
    def rest_kappa(self) -> _F64: ...
    def strains(self, rod: str | None = None) -> tuple[_F64, _F64]: ...
    def energies(self, rod: str | None = None) -> dict[str, float]: ...
    def model(self, rod: str | None = None) -> dict[str, _F64]: ...

@final
class Design:
    @property
    def outcome(self) -> str: ...
    @property
    def iterations(self) -> int: ...
    @property
    def sweeps(self) -> int: ...
    @property
    def cost(self) -> float: ...
    @property
    def tip_error(self) -> float: ...
    @property
    def residual(self) -> float: ...
    @property
    def warnings(self) -> list[str]: ...
    @property
    def nu(self) -> _F64: ...
    @property
    def kappa(self) -> _F64: ...
    @property
    def sigma(self) -> _F64: ...
    @property
    def positions(self) -> _F64: ...
    @property
    def directors(self) -> _F64: ...

@final
class OfflineSolver:
    def __new__(
        cls,
        sim: Simulation,
        space: str = "planar",
        floor_diameter: float = 0.004,
        max_sweeps: int = 20000,
        rod: str | None = None,
    ) -> OfflineSolver: ...
    def solve(
        self,
        target: _Vec3 | None = None,
        mu_tip: float = 1000.0,
        force: _Vec3 | None = None,
        obstacles: Sequence[tuple[_Vec3, float, float]] = ...,
    ) -> Design: ...

@final
class EnergyShapingController:
    def __new__(
        cls, sim: Simulation, damping_rate: float = 10.0, rod: str | None = None
    ) -> EnergyShapingController: ...
    def set_design(self, sim: Simulation, design: Design) -> None: ...
    def step(self, sim: Simulation, n: int = 1) -> None: ...
    def shaped_hamiltonian(self, sim: Simulation) -> float: ...
    def stresses(self) -> tuple[_F64, _F64]: ...

@final
class ArmBatch:
    """Thread-safe: calls from several threads are serialised."""

    def __new__(
        cls,
        n_envs: int = 1,
        n_elements: int = 20,
        n_segments: int = 4,
        max_curvature: float = 20.0,
        control_period: float = 0.01,
        dt: float = 5e-05,
        damping_rate: float = 10.0,
        effort_weight: float = 0.01,
        tip_diameter: float = 0.004,
        activation_time: float = 0.05,
        num_threads: int | None = None,
    ) -> ArmBatch: ...
    @property
    def n_envs(self) -> int: ...
    @property
    def obs_dim(self) -> int: ...
    def observation_bounds(self) -> tuple[_F32, _F32]: ...
    @property
    def length(self) -> float: ...
    @property
    def velocity_scale(self) -> float: ...
    @property
    def action_dim(self) -> int: ...
    @property
    def control_period(self) -> float: ...
    @property
    def steps_per_action(self) -> int: ...
    def rest_tips(self, commands: npt.ArrayLike) -> _F64: ...
    def reset(self, targets: npt.ArrayLike, indices: Sequence[int] | None = None) -> _F32: ...
    def step(
        self, actions: npt.ArrayLike
    ) -> tuple[_F32, _F64, _F64, list[InstabilityError | None]]: ...
    def simulation(self, index: int) -> Simulation: ...
    def render(
        self, index: int, width: int = 400, height: int = 400
    ) -> npt.NDArray[np.uint8]: ...

@final
class MuscleDesign:
    """Statics and SE(3) reach design of COOMM's muscular arm. Thread-safe (serialised)."""

    def __new__(cls, n_elements: int = 100) -> MuscleDesign: ...
    @property
    def n_elements(self) -> int: ...
    def equilibrium(self, activations: npt.ArrayLike) -> dict[str, Any]: ...
    def coomm_orientation(
        self, target: _Vec3, rolled: bool = False
    ) -> tuple[_F64, list[float]]: ...
    def solve(
        self,
        target: _Vec3,
        orientation: npt.ArrayLike | None = None,
        orientation_weights: _Vec3 | None = None,
        position_weight: float = 1e6,
        orientation_weight: float = 1e3,
        initial: npt.ArrayLike | None = None,
        groups: Sequence[bool] | None = None,
        max_iterations: int = 2000,
        stop_when: tuple[float, float, float] | None = None,
        max_starts: int = 8,
        max_total_iterations: int = 8000,
    ) -> tuple[_F64, dict[str, Any]]: ...

@final
class MuscleShapingController:
    """Hold designed activations with COOMM's ramp. Thread-safe (serialised)."""

    def __new__(
        cls,
        activations: npt.ArrayLike,
        ramp: float = 1.0,
        period: float = 0.002,
        target: _Vec3 | None = None,
    ) -> MuscleShapingController: ...
    def factor(self, t: float) -> float: ...
    @property
    def activations(self) -> _F64: ...
    def step(self, sim: Simulation, n: int = 1) -> None: ...

@final
class MuscleBatch:
    """The physics of octoarm/MuscleReach3D-v0. Thread-safe: calls are serialised."""

    def __new__(
        cls,
        n_envs: int = 1,
        n_elements: int = 20,
        n_segments: int = 4,
        control_period: float = 0.05,
        dt: float = 5e-05,
        activation_time: float = 0.05,
        effort_weight: float = 0.01,
        orientation_weight: float = 0.1,
        num_threads: int | None = None,
    ) -> MuscleBatch: ...
    @property
    def n_envs(self) -> int: ...
    @property
    def n_elements(self) -> int: ...
    @property
    def n_segments(self) -> int: ...
    @property
    def obs_dim(self) -> int: ...
    @property
    def action_dim(self) -> int: ...
    @property
    def length(self) -> float: ...
    @property
    def control_period(self) -> float: ...
    @property
    def steps_per_action(self) -> int: ...
    def observation_bounds(self) -> tuple[_F32, _F32]: ...
    def reachable_pose(self, activations: npt.ArrayLike) -> tuple[_F64, _F64]: ...
    def reset(
        self,
        positions: npt.ArrayLike,
        orientations: npt.ArrayLike,
        indices: Sequence[int] | None = None,
    ) -> _F32: ...
    def step(
        self, actions: npt.ArrayLike
    ) -> tuple[_F32, _F64, _F64, _F64, list[InstabilityError | None]]: ...
    def render(
        self, index: int, width: int = 800, height: int = 400
    ) -> npt.NDArray[np.uint8]: ...
    def simulation(self, index: int) -> Simulation: ...

def rust_step_rate(sim: Simulation, steps: int) -> float: ...
def _simulation_from_bytes(data: bytes) -> Simulation: ...
def run_scenario(
    path: str | os.PathLike[str],
    out_dir: str | os.PathLike[str] | None = None,
    duration: float | None = None,
    *,
    source: str | None = None,
) -> dict[str, Any]: ...

@final
class Sweep:
    """A parameter sweep's plan and prepared output folder (``octoarm sweep``'s Rust code)."""

    def __new__(
        cls,
        sweep_file: str | os.PathLike[str],
        out: str | os.PathLike[str] | None = None,
        *,
        resume: bool = False,
        duration: float | None = None,
    ) -> Sweep: ...
    @property
    def out(self) -> str: ...
    @property
    def n_runs(self) -> int: ...
    @property
    def pending(self) -> list[int]: ...
    def run_source(self, index: int) -> tuple[str, str, str]: ...
    def stage_dir(self) -> str: ...
    def commit_staged(self, index: int, staged: str | os.PathLike[str]) -> dict[str, Any]: ...
    def record_failure(self, index: int, status: str, message: str) -> dict[str, Any]: ...
    def run_local(self, threads: int | None = None) -> bool: ...
    def finish(self, executor: str) -> dict[str, Any]: ...
