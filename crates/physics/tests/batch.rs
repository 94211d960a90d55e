//! Claim: every lane of a `RodBatch` (SIMD lanes across rods, chunks of `LANES` in parallel)
//! equals `Simulation::step` on that rod to the last bit — positions, velocities, directors,
//! angular velocities, time, step count, dissipated energy — after ≥ 2 000 steps in which each
//! lane's rest curvatures follow their own lagged command changed every 10 steps (as the RL
//! environment drives its arms) from its own perturbed initial velocities; for batch sizes that
//! are and are not multiples of the lane width and for N = 4, 20, 100 (and N = 5, 6, 7, 21, which are not
//! multiples of the lane width of `step`'s own element lanes). The thread count (1, 2,
//! 3), the batch size (64 rods alone or among 67) and the kernel (baseline, AVX2) change no
//! bit, and a lane the guard stops reports the same `StepError` as its own simulation while the
//! other lanes go on unchanged.
//!
//! Reference: independent `Simulation`s (the one stepper, `step::step`) driven by the same
//! commands. How a wrong implementation fails: a lane that mixed in another lane's data, a
//! reordered sum, a fused multiply–add, a missed `+ 0` of the (zero) external load, another
//! branch of the rotation log/exp, a guard or re-orthonormalisation on another schedule, or a
//! padded lane leaking into a real one would differ in the last bits within a few steps;
//! comparing `to_bits` catches one ulp.

mod common;

use octoarm_physics::batch::LANES;
use octoarm_physics::kernel::Kernel;
use octoarm_physics::{Damping, RodBatch, Settings, Simulation, StraightRod, Vec3};

/// The environment's arm with `n` elements (paper geometry, 4 mm tip), dt, damping 10 1/s.
fn arm(n: usize, dt: f64) -> Simulation {
    let rod = StraightRod {
        tip_diameter: 0.004,
        ..StraightRod::paper_arm().with_elements(n)
    };
    let (model, state) = rod.build().unwrap();
    let mut sim = Simulation::new(model, state, Settings::with_dt(dt)).unwrap();
    sim.set_damping(Damping::mass_proportional(10.0)).unwrap();
    sim
}

/// Lane `lane`'s own start: small velocities that differ per lane (out of plane too).
fn perturbed(base: &Simulation, lane: usize) -> Simulation {
    let mut sim = base.clone();
    let v = &mut sim.state.velocity;
    for i in 1..v.len() {
        let s = (i as f64 * 0.37 + lane as f64 * 1.3).sin();
        v.y[i] = 0.02 * s;
        v.z[i] = 0.005 * (lane as f64 + 1.0) * s * s;
    }
    sim
}

/// The command of lane `lane` in period `p` (10 steps) at interior point k [1/m]: in-plane and
/// out-of-plane goals, followed with a first-order lag per step (`c += α (goal − c)`).
fn update(lane: usize, p: usize, kappa: &mut [Vec3]) {
    let nk = kappa.len();
    for (k, kap) in kappa.iter_mut().enumerate() {
        let seg = 4 * k / nk;
        let goal = 15.0 + 10.0 * ((lane * 7 + p * 3 + seg * 5) as f64 * 0.61).sin();
        kap[1] += 0.05 * (goal - kap[1]);
        kap[0] += 0.05 * (0.2 * goal - kap[0]);
    }
}

/// Every bit of a simulation's evolving state and rest curvatures.
fn bits(sim: &Simulation) -> Vec<u64> {
    let mut out = common::state_bits(sim);
    out.extend(sim.system.rest_kappa.iter().flatten().map(|x| x.to_bits()));
    out
}

/// The arm bent for 0.4 s under a rest curvature of 15/m in plane: the runs then start curved,
/// so that the rotation log takes its atan2 branch at some Voronoi points (see below).
fn bent_arm(n: usize, dt: f64) -> Simulation {
    let mut sim = arm(n, dt);
    for k in &mut sim.system.rest_kappa {
        k[1] = 15.0;
    }
    sim.run((0.4 / dt) as u64).unwrap();
    sim
}

/// A batch of `b` perturbed bent arms and the same arms as separate simulations.
fn setup(n: usize, dt: f64, b: usize) -> (RodBatch, Vec<Simulation>) {
    let base = bent_arm(n, dt);
    let mut batch = RodBatch::new(&base, b).unwrap();
    let sims: Vec<Simulation> = (0..b).map(|l| perturbed(&base, l)).collect();
    for (l, s) in sims.iter().enumerate() {
        batch.set_lane(l, s).unwrap();
    }
    (batch, sims)
}

/// `periods` periods of 10 steps on the batch.
fn run_batch(batch: &mut RodBatch, periods: usize) {
    for p in 0..periods {
        batch.run_with(10, Some(&|lane: usize, k: &mut [Vec3]| update(lane, p, k)));
    }
}

/// The same on one simulation (lane `lane`); stops at the first guard failure.
fn run_single(sim: &mut Simulation, lane: usize, periods: usize) -> Result<(), String> {
    for p in 0..periods {
        for _ in 0..10 {
            update(lane, p, &mut sim.system.rest_kappa);
            sim.step().map_err(|e| format!("{e:?}"))?;
        }
    }
    Ok(())
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

#[test]
fn every_lane_equals_its_own_simulation() {
    for (n, dt) in [(4, 5e-5), (20, 5e-5), (100, 1e-5)] {
        for b in [1, 3, 4, 5, 13] {
            let (mut batch, mut sims) = setup(n, dt, b);
            run_batch(&mut batch, 200);
            for (l, sim) in sims.iter_mut().enumerate() {
                run_single(sim, l, 200).unwrap();
                assert!(batch.failure(l).is_none(), "n = {n}, b = {b}, lane {l}");
                let lane = batch.simulation(l).unwrap();
                assert_eq!(lane.state.step, sim.state.step);
                assert!(
                    bits(&lane) == bits(sim),
                    "n = {n}, b = {b}: lane {l} differs from its simulation"
                );
            }
        }
    }
}

// `step` itself runs lanes across elements (groups of `LANES` elements, the remaining n mod 4 one
// by one); the batch runs lanes across rods with every element in turn. Element counts that are
// not multiples of the lane width exercise `step`'s remainder loops in every stage (nodes,
// elements, Voronoi points), against the batch's independent element order.
#[test]
fn element_counts_off_the_lane_width_change_no_bit() {
    for n in [5, 6, 7, 21] {
        let (mut batch, mut sims) = setup(n, 5e-5, 5);
        run_batch(&mut batch, 200);
        for (l, sim) in sims.iter_mut().enumerate() {
            run_single(sim, l, 200).unwrap();
            let lane = batch.simulation(l).unwrap();
            assert!(
                bits(&lane) == bits(sim),
                "n = {n}: lane {l} differs from its simulation"
            );
        }
    }
}

#[test]
fn the_commands_reach_the_trigonometric_branch_of_the_rotation_log() {
    // The runs above must exercise both branches of `log_relative` (series below 0.05 rad per
    // Voronoi point, atan2 above) for them to test the per-lane branch.
    use octoarm_physics::RodAccess;
    for n in [4, 20] {
        let (mut batch, _) = setup(n, 5e-5, 5);
        run_batch(&mut batch, 200);
        let largest = (0..5)
            .flat_map(|l| {
                let sim = batch.simulation(l).unwrap();
                (0..n - 1)
                    .map(|k| {
                        let v = sim.view();
                        octoarm_physics::math::log_relative(&v.director(k + 1), &v.director(k)).1
                    })
                    .collect::<Vec<_>>()
            })
            .fold(0.0, f64::max);
        eprintln!("n = {n}: largest turn {largest:.3} rad per Voronoi point");
        assert!(largest > 0.05, "n = {n}: {largest}");
    }
}

#[test]
fn thread_count_and_batch_size_change_no_bit() {
    let run = |threads: usize, b: usize| {
        let (mut batch, _) = setup(20, 5e-5, b);
        pool(threads).install(|| run_batch(&mut batch, 200));
        (0..b)
            .map(|l| bits(&batch.simulation(l).unwrap()))
            .collect::<Vec<_>>()
    };
    let one = run(1, 13);
    assert_eq!(one, run(2, 13));
    assert_eq!(one, run(3, 13));
    let alone = run(2, 64);
    let among = run(2, 67);
    assert_eq!(alone[..], among[..64]);
}

#[test]
fn baseline_and_avx2_kernels_agree() {
    let run = |kernel: Kernel| {
        let (mut batch, _) = setup(20, 5e-5, 5);
        assert!(batch.set_kernel(kernel));
        run_batch(&mut batch, 200);
        (0..5)
            .map(|l| bits(&batch.simulation(l).unwrap()))
            .collect::<Vec<_>>()
    };
    if !Kernel::Avx2.is_available() {
        eprintln!("no AVX2 on this CPU: only the baseline kernel runs");
        return;
    }
    assert_eq!(run(Kernel::Baseline), run(Kernel::Avx2));
}

#[test]
fn an_unstable_lane_fails_as_its_simulation_and_alone() {
    let (n, dt, b) = (20, 5e-5, 6);
    let (mut batch, mut sims) = setup(n, dt, b);
    // Lane 2 gets an absurd rest curvature: its guard fires within a few hundred steps.
    let bad = 2;
    for k in &mut sims[bad].system.rest_kappa {
        k[1] = 4000.0;
    }
    batch.set_lane(bad, &sims[bad]).unwrap();
    let periods = 100;
    let quiet = |lane: usize, p: usize, k: &mut [Vec3]| {
        if lane != bad {
            update(lane, p, k)
        }
    };
    for p in 0..periods {
        batch.run_with(10, Some(&|lane: usize, k: &mut [Vec3]| quiet(lane, p, k)));
    }
    // The single simulations, driven the same way.
    let mut single_error = None;
    for (l, sim) in sims.iter_mut().enumerate() {
        'run: for p in 0..periods {
            for _ in 0..10 {
                quiet(l, p, &mut sim.system.rest_kappa);
                if let Err(e) = sim.step() {
                    assert_eq!(l, bad, "only lane {bad} is unstable: {e}");
                    single_error = Some(e);
                    break 'run;
                }
            }
        }
        let lane = batch.simulation(l).unwrap();
        assert!(bits(&lane) == bits(sim), "lane {l} differs");
    }
    let single_error = single_error.expect("the bad lane's simulation fails");
    assert_eq!(batch.failure(bad), Some(&single_error));
    for l in (0..b).filter(|&l| l != bad) {
        assert!(batch.failure(l).is_none());
    }
    // A reset clears the failure.
    batch.set_lane(bad, &sims[0]).unwrap();
    assert!(batch.failure(bad).is_none());
}

#[test]
fn unsupported_simulations_are_refused_by_name() {
    let mut sim = arm(20, 5e-5);
    sim.add_load(octoarm_physics::Load::tip_force(20, [0.0, 1e-3, 0.0]))
        .unwrap();
    let e = RodBatch::new(&sim, 4).unwrap_err().to_string();
    assert!(e.contains("external loads"), "{e}");
    let e = RodBatch::new(&arm(20, 5e-5), 0).unwrap_err().to_string();
    assert!(e.contains("n_lanes = 0"), "{e}");
    let mut other = arm(20, 5e-5);
    other.set_damping(Damping::mass_proportional(3.0)).unwrap();
    let mut batch = RodBatch::new(&arm(20, 5e-5), 5).unwrap();
    let e = batch.set_lane(1, &other).unwrap_err().to_string();
    assert!(e.contains("damping"), "{e}");
    assert!(batch.set_lane(5, &arm(20, 5e-5)).is_err());
    assert_eq!(LANES, 4);
}
