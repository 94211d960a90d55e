//! The paper's arm under a 2e-5 N tip force along +y with mass-proportional damping (10 1/s):
//! prints the tip position and energies every 0.1 s of a 1 s run, then µs per step.
use octoarm_physics::{Damping, Load, Settings, Simulation, StraightRod};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (model, state) = StraightRod::paper_arm().build()?;
    println!("stable dt ≈ {:.3e} s, using 1e-5 s", model.stable_dt());
    let mut sim = Simulation::new(model, state, Settings::with_dt(1e-5))?;
    sim.set_damping(Damping::mass_proportional(10.0))?;
    sim.add_load(Load::tip_force(100, [0.0, 2e-5, 0.0]))?;
    let start = std::time::Instant::now();
    println!(
        "{:>6} {:>10} {:>10} {:>12}",
        "t [s]", "tip x [m]", "tip y [m]", "H [J]"
    );
    for _ in 0..10 {
        sim.run(10_000)?;
        let tip = sim.tip();
        println!(
            "{:6.2} {:10.5} {:10.5} {:12.4e}",
            sim.time(),
            tip[0],
            tip[1],
            sim.energies().total()
        );
    }
    let us = start.elapsed().as_secs_f64() * 1e6 / sim.steps() as f64;
    println!("{} steps, {us:.2} µs per step", sim.steps());
    Ok(())
}
