//! octoarm-control: strain-space statics of the arm, task costs (tip, obstacles, grasp), the
//! forward–backward sweep and the energy-shaping control law. Uses the physics crate only
//! through its public interface.
