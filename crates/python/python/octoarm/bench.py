"""cosseratbench solver adapter: octoarm as the solver ``octoarm`` of the cross-simulator
benchmark (``pip install "octoarm[bench]"``, then ``cosseratbench run --solver octoarm``).

Each scenario rod becomes an octoarm rod of ``n_elements`` equal elements of its rest length,
straight at rest, started in the scenario's shape (``Rod(positions=, directors=)``); ends are
free, pinned, clamped (with the second-order clamp, ``clamp_order = 2``) or driven by the
scenario's ``Motion`` (sliding along ``slides_along`` where it says). Obstacles are octoarm
planes and cylinders with Coulomb friction (the larger of the obstacle's and the rods'
coefficients, as the benchmark asks), rods touch each other and, where the scenario allows,
themselves. Quasi-static scenarios are damped at twice the slowest mode's frequency (as the
PyElastica adapter does); dynamic ones not at all. The contact springs have octoarm's
default stiffness (β = 1: the element's own axial stiffness E A / l). The time step is a fixed
fraction of octoarm's own stability estimate (which includes the contact springs), rounded so
that whole steps fill each frame interval. A run the stability guard stops raises ``Diverged`` with the
guard's message and time.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import octoarm
from cosseratbench.scenario import Cylinder, EndCondition, Plane, Rod, Scenario
from cosseratbench.solver import Capability, Diverged
from cosseratbench.trajectory import Trajectory

# Timoshenko shear coefficient of a circular section, PyElastica's default.
_SHEAR_COEFFICIENT = 27.0 / 28.0
# Fraction of octoarm's stable time step (2 / ω_max) used.
_SAFETY = 0.4
# Contact stiffness factor: octoarm's default, k = E A / l (the element's own axial
# stiffness). Stiffer contact (the largest β the step allowed, ~17 for the capstan rope) rang
# so hard that friction lost its hold: the capstan rope slid at 0.7 of its holding overhang
# with β = 16.6 and at 0.95 with β = 4, while β = 1 and 2 hold to 0.95 and slide at 1.05; in
# the crossing it carried 3.4 % too little lift (0.2 % with β = 1).
_BETA = 1.0


def _frames(spec: Rod, n: int) -> np.ndarray:
    """Directors (n, 3, 3) of the rod as it starts: rows d1 (the scenario's), d2 = d3 × d1, d3
    (the element tangents)."""
    nodes = spec.nodes(n)
    t = np.diff(nodes, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    d1 = spec.directors(n)
    d1 = d1 - (d1 * t).sum(axis=1, keepdims=True) * t
    d1 /= np.linalg.norm(d1, axis=1, keepdims=True)
    return np.stack([d1, np.cross(t, d1), t], axis=1)


def _end(condition: EndCondition, motion: Any) -> Any:
    if motion is not None:
        return octoarm.Motion(
            np.asarray(motion.times, dtype=float),
            displacement=np.asarray(motion.displacement, dtype=float),
            rotation=np.asarray(motion.rotation, dtype=float),
            slides_along=None if motion.slides_along is None else tuple(motion.slides_along),
        )
    return {
        EndCondition.FREE: "free",
        EndCondition.PINNED: "pinned",
        EndCondition.CLAMPED: "clamped",
    }[condition]


class OctoarmSolver:
    """The ``Solver`` protocol of cosseratbench for octoarm."""

    name = "octoarm"
    backend_version = octoarm.__version__
    capabilities = frozenset(
        {
            Capability.STRETCH,
            Capability.SHEAR,
            Capability.ROD_CONTACT,
            Capability.ROD_FRICTION,
            Capability.CYLINDER_CONTACT,
            Capability.PLANE_CONTACT,
        }
    )

    def __init__(
        self, time_step_scale: float = 1.0, clamp_order: int = 2, rod_geometry: str = "smooth"
    ) -> None:
        self.time_step_scale = float(time_step_scale)
        self.clamp_order = int(clamp_order)
        self.rod_geometry = str(rod_geometry)

    # -- building ---------------------------------------------------------------------------

    @staticmethod
    def _friction(scenario: Scenario, obstacle: Any) -> float:
        return max([obstacle.friction] + [r.friction for r in scenario.rods])

    @staticmethod
    def _damping_rate(scenario: Scenario) -> float:
        return 2.0 * scenario.slowest_frequency() if scenario.quasi_static else 0.0

    def _build(
        self, scenario: Scenario, n: int, dt: float, beta: float = 1.0
    ) -> octoarm.Simulation:
        rods = []
        for i, spec in enumerate(scenario.rods):
            m = spec.material
            nodes = spec.nodes(n)
            rods.append(
                octoarm.Rod(
                    name=f"rod{i}",
                    n_elements=n,
                    length=spec.length,
                    base_diameter=2.0 * spec.radius,
                    tip_diameter=2.0 * spec.radius,
                    density=m.density,
                    youngs_modulus=m.youngs_modulus,
                    shear_modulus=m.shear_modulus,
                    shear_coefficient=_SHEAR_COEFFICIENT,
                    base_position=tuple(nodes[0]),
                    base=_end(spec.start, spec.start_motion),
                    tip=_end(spec.end, spec.end_motion),
                    positions=nodes,
                    directors=_frames(spec, n),
                )
            )
        sim = octoarm.Simulation.from_rods(rods, dt=dt, clamp_order=self.clamp_order)
        g = tuple(float(c) for c in scenario.gravity)
        rate = self._damping_rate(scenario)
        for i, spec in enumerate(scenario.rods):
            name = f"rod{i}"
            if any(g):
                sim.add_gravity(g, rod=name)
            for load in spec.loads:
                node = 0 if load.at.value == "start" else n
                sim.add_node_force(tuple(load.force), node=node, rod=name)
            if rate > 0.0:
                sim.set_damping(rate=rate, rod=name)
        for obstacle in scenario.obstacles:
            mu = self._friction(scenario, obstacle)
            if isinstance(obstacle, Plane):
                sim.add_plane(obstacle.point, tuple(obstacle.unit_normal), friction=mu)
            elif isinstance(obstacle, Cylinder):
                sim.add_cylinder(
                    obstacle.center,
                    tuple(obstacle.unit_axis),
                    obstacle.radius,
                    obstacle.length,
                    friction=mu,
                )
            else:  # pragma: no cover - cosseratbench 0.3.0 has no other kind
                raise NotImplementedError(f"octoarm has no obstacle of kind {obstacle!r}")
        rod_mu = max(r.friction for r in scenario.rods)
        sim.set_contact(
            beta=beta,
            rods=len(scenario.rods) > 1,
            self_contact=bool(scenario.self_contact),
            rod_friction=rod_mu if rod_mu > 0.0 else None,
            rod_geometry=self.rod_geometry,
        )
        return sim

    def _steps(self, scenario: Scenario, n: int, n_frames: int) -> tuple[float, int, float]:
        """The time step, the steps per frame and the contact stiffness factor: a fraction of
        octoarm's stable step (which counts the contact springs), rounded down to fill each
        frame interval."""
        beta = _BETA
        probe = self._build(scenario, n, 1e-6, beta)
        limit = _SAFETY * self.time_step_scale * probe.stable_dt
        interval = scenario.duration / (n_frames - 1)
        per_frame = max(1, math.ceil(interval / limit))
        return interval / per_frame, per_frame, beta

    # -- the protocol -----------------------------------------------------------------------

    def settings(self, scenario: Scenario, *, n_elements: int, n_frames: int) -> dict:
        """The numerical choices for a run, as JSON values."""
        dt, _, beta = self._steps(scenario, n_elements, n_frames)
        return {
            "integrator": "position Verlet (explicit), octoarm",
            "time_step": dt,
            "time_step_fraction_of_stable": _SAFETY * self.time_step_scale,
            "clamp_order": self.clamp_order,
            "damping_rate": self._damping_rate(scenario),
            "contact_beta": beta,
            "contact_zeta": 0.5,
            "friction": "Coulomb: stick spring 0.5 k against obstacles (slip test on the spring), viscous-capped between rods",
            "rod_contact": len(scenario.rods) > 1,
            "self_contact": bool(scenario.self_contact),
            "rod_geometry": self.rod_geometry,
        }

    def run(self, scenario: Scenario, *, n_elements: int, n_frames: int) -> Trajectory:
        dt, per_frame, beta = self._steps(scenario, n_elements, n_frames)
        sim = self._build(scenario, n_elements, dt, beta)
        names = [f"rod{i}" for i in range(len(scenario.rods))]
        positions: list[list[np.ndarray]] = [[] for _ in names]
        directors: list[list[np.ndarray]] = [[] for _ in names]

        def record() -> None:
            state = sim.state()
            for i, name in enumerate(names):
                positions[i].append(np.array(state[name]["positions"]))
                directors[i].append(np.array(state[name]["directors"][:, 0, :]))

        record()
        for _ in range(n_frames - 1):
            try:
                sim.step(per_frame)
            except octoarm.InstabilityError as e:
                raise Diverged(f"octoarm stability guard: {e}", time=getattr(e, "time", None)) from e
            record()
        times = np.linspace(0.0, scenario.duration, n_frames)
        return Trajectory(
            times,
            tuple(np.stack(p) for p in positions),
            tuple(np.stack(d) for d in directors),
        )
