use octoarm_physics::*;
fn main() {
    let mut out = Vec::new();
    for case in 0..4 {
        let mut arm = StraightRod::paper_arm();
        if case == 1 || case == 2 { arm.rest_curvature = [0.0, 10.0, 0.0]; }
        if case == 3 { arm = StraightRod::uniform(50, 0.5, 0.02, Material{density:1000.0,youngs_modulus:5e7,shear_modulus:5e7/3.0,shear_coefficient:27.0/28.0}); }
        let (m, s) = arm.build().unwrap();
        let dt = if case == 3 { 5e-6 } else { 1e-5 };
        let mut sim = Simulation::new(m, s, Settings::with_dt(dt)).unwrap();
        sim.set_damping(Damping::mass_proportional(if case==3 {20.0} else {10.0})).unwrap();
        match case {
            0 => sim.add_scheduled_load(Load::NodeForce{node:100, force:[0.0,2e-5,0.0]}, Schedule::Ramp{duration:0.3}).unwrap(),
            2 => sim.add_obstacle(Sphere::fixed([0.054,0.06,0.0],0.04)).unwrap(),
            3 => sim.add_load(Load::Gravity{acceleration:[0.0,-9.81,0.0]}).unwrap(),
            _ => {}
        }
        sim.run(50000).unwrap();
        let s = sim.rod_state();
        let mut h: u64 = 0;
        for v in s.position.iter().flatten().chain(s.velocity.iter().flatten()).chain(s.omega.iter().flatten()).chain(s.director.iter().flatten().flatten()) { h = h.wrapping_mul(31).wrapping_add(v.to_bits()); }
        out.push(format!("case {case}: {h:x} work {:e} diss {:e} t {:e}", sim.external_work(), sim.dissipated_energy(), sim.state.time));
    }
    for l in out { println!("{l}"); }
}
