//! Criterion benchmark: cost of rod–rod contact against the number of elements (issue 11). A
//! woven stack of rods (layers of 8 parallel rods of 50 elements, each layer crossing the one
//! below at right angles and resting on it, slightly pressed), from 2 to 32 layers (800 to
//! 12 800 elements, the same contacts per element at every size): time per step with rod contact
//! on and off, so that the contact's share (broad phase, Verlet list and narrow phase) is their
//! difference; criterion's "thrpt" is element-steps per second. Near-linear cost shows as a flat
//! time per element across sizes.
#![allow(missing_docs)] // criterion_group! generates an undocumented public function
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use octoarm_physics::{
    ContactParams, Damping, EndCondition, Material, RodSpec, Settings, Simulation, StraightRod,
    SystemBuilder,
};
use std::sync::Arc;

const RODS_PER_LAYER: usize = 8;
const ELEMENTS: usize = 50;
const LENGTH: f64 = 0.5;
const DIAMETER: f64 = 0.01;

/// The woven stack of `layers` layers, rod contact on or off.
fn stack(layers: usize, contact: bool) -> Simulation {
    let material = Material {
        density: 1000.0,
        youngs_modulus: 1e6,
        shear_modulus: 1e6 / 3.0,
        shear_coefficient: Material::DEFAULT_SHEAR_COEFFICIENT,
    };
    let mut b = SystemBuilder::new(Settings::with_dt(2e-5));
    for layer in 0..layers {
        // Layers 1 % closer than one diameter, so every crossing is in contact.
        let z = layer as f64 * 0.99 * DIAMETER;
        for k in 0..RODS_PER_LAYER {
            let across = (k as f64 + 0.5) * LENGTH / RODS_PER_LAYER as f64 - 0.5 * LENGTH;
            let mut rod = StraightRod::uniform(ELEMENTS, LENGTH, DIAMETER, material);
            if layer % 2 == 0 {
                rod.base_position = [-0.5 * LENGTH, across, z];
                rod.direction = [1.0, 0.0, 0.0];
            } else {
                rod.base_position = [across, -0.5 * LENGTH, z];
                rod.direction = [0.0, 1.0, 0.0];
            }
            rod.normal = [0.0, 0.0, 1.0];
            let (model, state) = rod.build().unwrap();
            b.rod(RodSpec {
                name: format!("l{layer}r{k}"),
                model: Arc::new(model),
                state,
                base: EndCondition::Free,
                tip: EndCondition::Free,
                damping: Damping::mass_proportional(50.0),
            });
        }
    }
    let (mut system, state) = b.build().unwrap();
    system
        .set_contact(ContactParams {
            rods: contact,
            self_contact: contact,
            ..ContactParams::default()
        })
        .unwrap();
    let mut sim = Simulation::from_parts(system, state);
    sim.run(200).unwrap();
    sim
}

fn bench_rod_contact(c: &mut Criterion) {
    let mut group = c.benchmark_group("rod_contact");
    group.sample_size(20);
    for layers in [2usize, 4, 8, 16, 32] {
        let n = layers * RODS_PER_LAYER * ELEMENTS;
        group.throughput(Throughput::Elements(n as u64));
        for contact in [false, true] {
            let mut sim = stack(layers, contact);
            if contact {
                eprintln!(
                    "{n} elements: {} candidate pairs in the Verlet list",
                    sim.workspace.rod_contact.candidate_pairs().len()
                );
            }
            let id = BenchmarkId::new(if contact { "contact_on" } else { "contact_off" }, n);
            group.bench_with_input(id, &n, |b, _| b.iter(|| sim.step().unwrap()));
        }
    }
    group.finish();
}

criterion_group!(benches, bench_rod_contact);
criterion_main!(benches);
