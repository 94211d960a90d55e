//! Claim (muscles-3d spec §6.2–6.3): holding designed activations with COOMM's 1 s ramp at
//! 500 Hz, in water (drag) with the `coomm` damping, the shaped Hamiltonian
//! 𝓗 = K_t + K_r + U_s + U_b + Σ W (the fibres' stored energy) does not rise after the ramp:
//! sampled every 10 ms it is non-increasing up to 1e-3 (𝓗(1 s) − 𝓗(T)), and 𝓗(T) ≤ 𝓗(1 s);
//! and the arm approaches the design (tip error falls).
//!
//! Independent reference: the energy balance of a passive mechanical system with constant
//! conservative actuation and dissipation. How a wrong implementation fails: activations
//! written to the wrong elements or groups, a ramp that never ends, or a muscle force that is
//! not (nearly) the gradient of the stored energy make 𝓗 rise.

use octoarm_control::{
    Controller, MuscleDesign, MuscleShapingController, MuscleStatics, ReachTask,
};
use octoarm_physics::muscles::Strains;
use octoarm_physics::{
    energies, strains, Damping, Load, MuscleModel, MuscleSpec, Settings, Simulation, StraightRod,
    N_GROUPS,
};

#[test]
fn shaped_hamiltonian_decreases_after_the_ramp() {
    let arm = StraightRod::coomm_arm();
    let (model, state) = arm.build().unwrap();
    let n = model.n_elements;
    let mm = MuscleModel::new(MuscleSpec::coomm(), &model).unwrap();
    let st = MuscleStatics::new(&model, mm.clone(), state.position[0], state.director[0]);
    let task = ReachTask::coomm([0.01, 0.15, 0.06], [0.0; 3], state.position[n]);
    let mut design = MuscleDesign::new(st);
    design.config.max_iterations = 60;
    let (a, rep) = design.solve(&task, &vec![0.0; N_GROUPS * n]);
    let shape = design.statics().pose(design.statics().solution()).position;
    let mut ctrl = MuscleShapingController::coomm(
        0,
        a.clone(),
        Some(task.target),
        shape,
        rep.costs.tip_error,
        0.2,
    )
    .unwrap();
    let drag = Load::coomm_drag(&model);
    let mut sim = Simulation::new(model.clone(), state, Settings::with_dt(1e-5)).unwrap();
    sim.set_damping(Damping::coomm(1050.0, 0.012)).unwrap();
    sim.add_load(drag).unwrap();
    sim.set_muscles(Some(MuscleSpec::coomm())).unwrap();
    let act: [&[f64]; N_GROUPS] = std::array::from_fn(|g| &a[g * n..(g + 1) * n]);
    let hamiltonian = |sim: &Simulation| {
        let s = sim.rod_state();
        let e = energies(&model, &s, false);
        let mut sigma = vec![[0.0; 3]; n];
        let mut kappa = vec![[0.0; 3]; n - 1];
        strains(&model, &s, &mut sigma, &mut kappa);
        let comp = |v: &[[f64; 3]], c: usize| v.iter().map(|x| x[c]).collect::<Vec<f64>>();
        let (s0, s1, s2) = (comp(&sigma, 0), comp(&sigma, 1), comp(&sigma, 2));
        let (k0, k1, k2) = (comp(&kappa, 0), comp(&kappa, 1), comp(&kappa, 2));
        let dil: Vec<f64> = sigma
            .iter()
            .map(|v| (v[0] * v[0] + v[1] * v[1] + (1.0 + v[2]) * (1.0 + v[2])).sqrt())
            .collect();
        let eps: Vec<f64> = (0..n - 1)
            .map(|k| {
                0.5 * (model.rest_length[k] * dil[k] + model.rest_length[k + 1] * dil[k + 1])
                    / model.rest_voronoi_length[k]
            })
            .collect();
        let strains = Strains {
            sigma: [&s0, &s1, &s2],
            dilatation: &dil,
            kappa: [&k0, &k1, &k2],
            voronoi_dilatation: &eps,
        };
        e.kinetic() + e.potential() + mm.stored_energy(act, &strains)
    };
    let (t_end, dt) = (2.0, 1e-5);
    let steps_per_update = 200; // 2 ms
    let steps_per_sample = 1000; // 10 ms
    let mut samples = Vec::new();
    let mut first_error = None;
    let total = (t_end / dt) as usize;
    for k in 0..total {
        let t = k as f64 * dt;
        if k % steps_per_update == 0 {
            ctrl.update(t, &sim.system, &sim.state, &mut sim.actuation)
                .unwrap();
        }
        if k % steps_per_sample == 0 && t >= 1.0 - 1e-12 {
            samples.push(hamiltonian(&sim));
            if first_error.is_none() {
                first_error = Some(ctrl.signals(t, &sim.system, &sim.state).distance);
            }
        }
        sim.step().unwrap();
    }
    samples.push(hamiltonian(&sim));
    let last_error = ctrl.signals(t_end, &sim.system, &sim.state).distance;
    let (h1, ht) = (samples[0], *samples.last().unwrap());
    let mut rise: f64 = 0.0;
    for w in samples.windows(2) {
        rise = rise.max(w[1] - w[0]);
    }
    eprintln!("H(1 s) = {h1:e}, H(T) = {ht:e}, largest rise {rise:e}, tip error/L0 {first_error:?} -> {last_error}");
    assert!(ht <= h1, "H rose over the run: {h1:e} -> {ht:e}");
    assert!(
        rise <= 1e-3 * (h1 - ht),
        "largest 10 ms rise {rise:e} vs {:e}",
        h1 - ht
    );
    assert!(
        last_error < first_error.unwrap(),
        "the arm does not approach the design"
    );
}
