//! A scene run as several ranks (threads of this process, `ThreadRank`) gives every particle
//! the state the single process gives it, bit for bit, and a pipeline a rank cannot yet split
//! is refused with its reason. The same steps under `mpirun` are `tools/tests/mpi_run.rs`.

use fractum_engine::communicator::{Communicator, thread_ranks};
use fractum_engine::decomposition::{Ownership, RankRebuild, rank_grid};
use fractum_engine::dim::{Dim, Three, Two};
use fractum_engine::health::EscapedParticles;
use fractum_engine::resources::Grid;
use fractum_engine::series::SeriesColumns;
use fractum_io::run::distributed::{self, owned_particle_ids, state_of_particles};
use fractum_scene::{SceneFile, build_rank_simulation, build_simulation};
use std::collections::BTreeMap;

type States = BTreeMap<u32, Vec<Vec<u8>>>;

/// The system-published series columns: each published name and its value.
type Columns = Vec<(String, f64)>;

fn columns(world: &bevy_ecs::world::World) -> Columns {
    let Some(columns) = world.get_resource::<SeriesColumns>() else {
        return Vec::new();
    };
    columns
        .published()
        .into_iter()
        .map(|name| {
            let value = columns.value(&name).unwrap();
            (name, value)
        })
        .collect()
}

fn scene(pipeline: &str, end_steps: u64) -> String {
    format!(
        r#"(
    title: "two disks",
    units: SI,
    time: (step: Fixed(1.0e-3), end: Steps({end_steps})),
    grid: (min: (0.0, 0.0), max: (1.0, 1.0), spacing: 0.05),
    materials: {{
        "elastic": (density: 1000.0, youngs_modulus: 1000.0, poisson_ratio: 0.3),
    }},
    bodies: [
        (name: "lower-left", shape: Disk(center: (0.25, 0.3), radius: 0.2), material: "elastic",
         particles_per_cell: 2, velocity: Uniform((0.4, 0.1)), contact_group: 0),
        (name: "upper-right", shape: Disk(center: (0.75, 0.7), radius: 0.2), material: "elastic",
         particles_per_cell: 2, velocity: Uniform((-0.4, -0.1)), contact_group: 1),
    ],
    pipeline: [{pipeline}],
)"#
    )
}

fn parse(text: &str) -> SceneFile {
    SceneFile::parse("two_disks.ron", text.to_string()).unwrap()
}

const USL: &str = r#"(system: "basis/linear"), (system: "predictor/usl"),
    (system: "stress/linear_elastic"), (system: "advection/usl")"#;
const NEWMARK_GIMP: &str = r#"(system: "basis/gimp"), (system: "predictor/newmark"),
    (system: "stress/neo_hookean"), (system: "corrector/newmark"), (system: "advection/newmark")"#;

fn serial<D: Dim>(text: &str, steps: u64) -> (States, Columns) {
    let mut built = build_simulation(&parse(text), &fractum_systems::stock_registry()).unwrap();
    for _ in 0..steps {
        built.simulation.step().unwrap();
    }
    let world = &mut built.simulation.world;
    (state_of_particles::<D>(world).unwrap(), columns(world))
}

/// Builds rank `r`'s part of `text` on each of `ranks` ranks (threads) and hands it to `work`;
/// each rank's result, by rank.
fn each_rank<T: Send + 'static>(
    text: &str,
    ranks: usize,
    work: impl Fn(&mut fractum_engine::Simulation, &dyn Communicator) -> T + Copy + Send + 'static,
) -> Vec<T> {
    let threads: Vec<_> = thread_ranks(ranks)
        .into_iter()
        .map(|comm| {
            let file = parse(text);
            std::thread::spawn(move || {
                let registry = fractum_systems::stock_registry();
                let mut built =
                    build_rank_simulation(&file, &registry, comm.rank(), comm.size()).unwrap();
                work(&mut built.simulation, &comm)
            })
        })
        .collect();
    threads.into_iter().map(|t| t.join().unwrap()).collect()
}

/// A rank's nodes after a run: how many it held and owned of the grid's, whether they were
/// those its slabs at the end reach, and how often its world was built afresh for re-cut
/// slabs.
#[derive(Clone, Debug)]
struct RankNodes {
    held: usize,
    owned: usize,
    grid: usize,
    follow_the_slabs: bool,
    rebuilds: u64,
}

fn rank_nodes<D: Dim>(world: &bevy_ecs::world::World) -> RankNodes {
    let grid = world.resource::<Grid<D>>();
    let ownership = world.resource::<Ownership>();
    let reach = world.resource::<RankRebuild>().node_reach;
    let wanted = rank_grid(grid, &ownership.layout, ownership.rank, reach);
    RankNodes {
        held: grid.node_count(),
        owned: ownership.nodes.iter().filter(|&&o| o).count(),
        grid: grid.global_node_count(),
        follow_the_slabs: wanted == *grid,
        rebuilds: ownership.rebuilds,
    }
}

/// Each rank holds the nodes its slabs reach, and every node is owned by one rank.
fn assert_nodes_follow_the_slabs(nodes: &[RankNodes]) {
    let ranks = nodes.len();
    assert!(nodes.iter().all(|n| n.follow_the_slabs), "{nodes:?}");
    let owned: usize = nodes.iter().map(|n| n.owned).sum();
    assert_eq!(owned, nodes[0].grid, "{ranks} ranks: {nodes:?}");
}

/// On 4 ranks a re-cut moved some rank's nodes, so that its world was built afresh for them
/// during the run (and its particles stayed the single process's).
fn assert_worlds_rebuilt(nodes: &[RankNodes]) {
    assert!(nodes.iter().any(|n| n.rebuilds > 0), "{nodes:?}");
}

/// Each rank's owned particles and its series columns after `steps`, how many particles each
/// rank owned over the run that were first seeded on another rank, its re-cuts and its nodes.
fn on_ranks<D: Dim>(text: &str, ranks: usize, steps: u64) -> Vec<RankResult> {
    each_rank(text, ranks, move |sim, comm| {
        let first = owned_particle_ids::<D>(&mut sim.world);
        let mut arrived = std::collections::BTreeSet::<u32>::new();
        for _ in 0..steps {
            distributed::step(sim, comm).unwrap();
            let owned = owned_particle_ids::<D>(&mut sim.world);
            arrived.extend(
                owned
                    .into_iter()
                    .filter(|id| first.binary_search(id).is_err()),
            );
        }
        let owned = state_of_particles::<D>(&mut sim.world).unwrap();
        let rebalances = sim.world.resource::<Ownership>().rebalances;
        let nodes = rank_nodes::<D>(&sim.world);
        (owned, columns(&sim.world), arrived.len(), rebalances, nodes)
    })
}

/// What [`on_ranks`] gives for each rank.
type RankResult = (States, Columns, usize, u64, RankNodes);

/// Every particle is owned by one rank of `results`, with the state it has in `reference`.
fn assert_states_match<'a>(
    reference: &States,
    results: impl IntoIterator<Item = &'a States>,
    ranks: usize,
) {
    let mut merged = States::new();
    for owned in results {
        for (id, state) in owned {
            assert!(
                merged.insert(*id, state.clone()).is_none(),
                "particle {id} owned twice"
            );
        }
    }
    assert_eq!(merged.len(), reference.len(), "{ranks} ranks");
    let differing: Vec<u32> = reference
        .iter()
        .filter(|(id, state)| merged.get(id) != Some(state))
        .map(|(id, _)| *id)
        .collect();
    assert!(
        differing.is_empty(),
        "{ranks} ranks: {} particles differ from the single process, the first {:?}",
        differing.len(),
        &differing[..differing.len().min(5)]
    );
}

/// Runs `pipeline` on 1 to 4 ranks: every particle's state is the single process's, bit for
/// bit; each published column, summed over ranks, is the single process's to 1e-12 of its
/// magnitude (the ranks add their parts in another order). Returns the single process's
/// columns.
fn assert_ranks_match_serial(pipeline: &str, steps: u64) -> (Columns, Vec<RankNodes>) {
    assert_scene_ranks_match_serial::<Two>(&scene(pipeline, steps), steps)
}

/// [`assert_ranks_match_serial`] for scene `text` in dimension `D`.
fn assert_scene_ranks_match_serial<D: Dim>(text: &str, steps: u64) -> (Columns, Vec<RankNodes>) {
    let (reference, reference_columns) = serial::<D>(text, steps);
    let mut rebalances_seen = Vec::new();
    let mut nodes_on_four = Vec::new();
    for ranks in 1..=4 {
        let results = on_ranks::<D>(text, ranks, steps);
        rebalances_seen.push(results[0].3);
        let nodes: Vec<RankNodes> = results.iter().map(|r| r.4.clone()).collect();
        assert_nodes_follow_the_slabs(&nodes);
        nodes_on_four = nodes;
        for (k, (name, value)) in reference_columns.iter().enumerate() {
            let summed: f64 = results.iter().map(|r| r.1[k].1).sum();
            assert!(
                (summed - value).abs() <= 1e-12 * value.abs(),
                "{ranks} ranks: {name} is {summed}, the single process's {value}"
            );
        }
        assert_states_match(&reference, results.iter().map(|r| &r.0), ranks);
        if ranks > 1 {
            // The disks cross the slabs: particles changed hands.
            let moved: usize = results.iter().map(|r| r.2).sum();
            assert!(
                moved >= 10,
                "{ranks} ranks: only {moved} particles changed rank"
            );
        }
    }
    // The bodies crowd the middle slabs as they meet: on 3 and 4 ranks the slabs were re-cut
    // (more than 10% over the mean), and the results stayed the single process's.
    assert!(
        rebalances_seen[2..].iter().all(|&r| r > 0),
        "re-cuts on 1 to 4 ranks: {rebalances_seen:?}"
    );
    (reference_columns, nodes_on_four)
}

#[test]
fn two_disks_colliding_on_one_to_four_ranks_are_the_single_process_bit_for_bit() {
    // 0.4 m/s each over 0.5 s: the disks cross the slab boundaries and meet.
    let (_, nodes) = assert_ranks_match_serial(USL, 500);
    // A halo of 3 layers on a 20-cell grid: each of 4 ranks holds fewer nodes than the grid.
    assert!(nodes.iter().all(|n| n.held < n.grid), "{nodes:?}");
    assert_worlds_rebuilt(&nodes);
}

/// Modified update-stress-last maps the updated particle velocities back to the grid: a second
/// round trip, which the halo must hold.
#[test]
fn musl_on_one_to_four_ranks_is_the_single_process_bit_for_bit() {
    let musl = USL.replace(
        r#"(system: "predictor/usl")"#,
        r#"(system: "predictor/usl", params: (scheme: Musl))"#,
    );
    assert_ranks_match_serial(&musl, 300);
}

#[test]
fn newmark_with_gimp_on_one_to_four_ranks_is_the_single_process_bit_for_bit() {
    assert_ranks_match_serial(NEWMARK_GIMP, 300);
}

#[test]
fn newmark_with_b_splines_on_one_to_four_ranks_is_the_single_process_bit_for_bit() {
    // The quadratic splines reach 1½ cells: the halo the basis declares must hold them.
    let splines = NEWMARK_GIMP.replace(r#"(system: "basis/gimp")"#, r#"(system: "basis/bspline")"#);
    assert_ranks_match_serial(&splines, 300);
}

#[test]
fn lme_with_neighbour_lists_on_one_to_four_ranks_is_the_single_process_bit_for_bit() {
    // LME's Newton warm starts go with their particles; its and the kd-tree's cached lists are
    // rebuilt on every rank after each step. 250 steps: on two ranks the slabs meet half way
    // between the disks, which the disks' leading particles cross after 160 steps.
    let lme = r#"(system: "neighbour/kdtree", params: (c_epsilon: 2.0)),
        (system: "basis/lme", params: (gamma: 1.8)), (system: "predictor/newmark"),
        (system: "stress/linear_elastic"), (system: "corrector/newmark"),
        (system: "advection/newmark")"#;
    assert_ranks_match_serial(lme, 250);
}

#[test]
fn eigensoftening_with_lme_on_one_to_four_ranks_is_the_single_process() {
    // The disks crack where they rebound; the damage columns are sums over owned particles.
    let softening = r#"(system: "neighbour/kdtree", params: (c_epsilon: 2.0)),
        (system: "basis/lme", params: (gamma: 1.8)), (system: "predictor/newmark"),
        (system: "stress/linear_elastic"),
        (system: "damage/eigensoftening", params: (tensile_strength: 2.0,
            fracture_energy: 0.05, band_width: 0.1)),
        (system: "corrector/newmark"), (system: "advection/newmark")"#;
    let (columns, _) = assert_ranks_match_serial(softening, 450);
    let value = |name: &str| columns.iter().find(|c| c.0 == name).unwrap().1;
    assert!(value("damaged_particles") > 10.0, "{columns:?}");
    assert!(value("dissipated_energy") > 0.0, "{columns:?}");
}

#[test]
fn spheres_with_lme_and_eigensoftening_in_3d_on_one_to_four_ranks_are_the_single_process() {
    // Two spheres meet along x and crack where they meet, while both drift across the slabs.
    let text = include_str!("fixtures/two_spheres_lme_3d.ron");
    let (columns, _) = assert_scene_ranks_match_serial::<Three>(text, 320);
    let value = |name: &str| columns.iter().find(|c| c.0 == name).unwrap().1;
    assert!(value("damaged_particles") > 0.0, "{columns:?}");
}

#[test]
fn disks_in_frictional_contact_on_one_to_four_ranks_are_the_single_process() {
    // Each disk its own contact group: they meet on the slab boundary, bounce and part. The
    // contact's work is summed over the nodes each rank owns.
    let contact = r#"(system: "basis/linear"), (system: "predictor/newmark"),
        (system: "stress/linear_elastic"), (system: "partition/bodies"),
        (system: "contact/frictional", params: (friction: 0.3)),
        (system: "corrector/newmark"), (system: "advection/newmark")"#;
    let (columns, _) = assert_ranks_match_serial(contact, 500);
    let work = columns.iter().find(|c| c.0 == "contact_work").unwrap().1;
    assert!(work < 0.0, "{columns:?}");
}

#[test]
fn dfg_partitioned_cracks_with_contact_on_one_to_four_ranks_are_the_single_process() {
    // Kalthoff–Winkler's pipeline on the disks: Rankine damage where they rebound, the
    // damage-field gradients splitting the nodes of the cracks, and contact between the sides.
    let dfg = r#"(system: "basis/linear"), (system: "predictor/newmark"),
        (system: "stress/neo_hookean"),
        (system: "damage/rankine", params: (tensile_strength: 20.0, fracture_energy: 0.05)),
        (system: "partition/dfg"),
        (system: "contact/frictional", params: (friction: 0.0, separability: 0.25)),
        (system: "corrector/newmark"), (system: "advection/newmark")"#;
    let (columns, nodes) = assert_ranks_match_serial(dfg, 500);
    assert_worlds_rebuilt(&nodes);
    let value = |name: &str| columns.iter().find(|c| c.0 == name).unwrap().1;
    assert!(value("failed_particles") > 0.0, "{columns:?}");
    assert!(value("contact_work") < 0.0, "{columns:?}");
}

#[test]
fn eigenerosion_on_one_to_four_ranks_is_the_single_process() {
    // Points fail where the disks meet; each rank counts and releases the energy of the points
    // it owns.
    let erosion = r#"(system: "neighbour/kdtree", params: (c_epsilon: 2.0)),
        (system: "basis/linear"), (system: "predictor/newmark"),
        (system: "stress/linear_elastic"),
        (system: "damage/eigenerosion", params: (fracture_energy: 0.02)),
        (system: "corrector/newmark"), (system: "advection/newmark")"#;
    let (columns, _) = assert_ranks_match_serial(erosion, 450);
    let value = |name: &str| columns.iter().find(|c| c.0 == name).unwrap().1;
    assert!(value("failed_particles") > 10.0, "{columns:?}");
    assert!(value("dissipated_energy") > 0.0, "{columns:?}");
}

#[test]
fn surface_detection_on_one_to_four_ranks_flags_what_the_single_process_flags() {
    // The left disk's particles are denser, so its kernel sums are the scene's largest, and the
    // disks lie further apart than a halo: a rank holding only the right disk would find a
    // smaller largest sum and flag fewer surface particles unless the ranks agree on the
    // scene's. The flags are particle state, compared bit for bit.
    let text = r#"(
    title: "two disks, one group",
    time: (step: Fixed(1.0e-3), end: Steps(100)),
    grid: (min: (0.0, 0.0), max: (3.0, 1.0), spacing: 0.05),
    materials: {
        "elastic": (density: 1000.0, youngs_modulus: 1000.0, poisson_ratio: 0.3),
    },
    bodies: [
        (name: "left", shape: Disk(center: (0.4, 0.5), radius: 0.2), material: "elastic",
         particles_per_cell: 3, velocity: Uniform((1.0, 0.0))),
        (name: "right", shape: Disk(center: (2.6, 0.5), radius: 0.2), material: "elastic",
         particles_per_cell: 2, velocity: Uniform((-1.0, 0.0))),
    ],
    pipeline: [
        (system: "basis/linear"), (system: "predictor/newmark"),
        (system: "stress/neo_hookean"),
        (system: "partition/dfg", params: (surface: 0.8)),
        (system: "contact/frictional", params: (friction: 0.0)),
        (system: "corrector/newmark"), (system: "advection/newmark"),
    ],
)"#;
    let (reference, _) = serial::<Two>(text, 100);
    for ranks in 2..=4 {
        let results = on_ranks::<Two>(text, ranks, 100);
        assert_states_match(&reference, results.iter().map(|r| &r.0), ranks);
    }
}

#[test]
fn penalty_contact_on_one_to_four_ranks_is_the_single_process() {
    // The disks meet through the penalty potential, with friction; each rank sums the energy
    // and the friction's work of the particles it owns, and bins partners as one process.
    let penalty = r#"(system: "basis/linear"), (system: "partition/bodies"),
        (system: "predictor/newmark"), (system: "stress/linear_elastic"),
        (system: "contact/penalty", params: (friction: 0.5)),
        (system: "corrector/newmark"), (system: "advection/newmark")"#;
    let (columns, _) = assert_ranks_match_serial(penalty, 500);
    let value = |name: &str| columns.iter().find(|c| c.0 == name).unwrap().1;
    assert!(value("friction_work") < 0.0, "{columns:?}");
}

/// The scene with `on_leave_grid: Remove`, the upper disk thrown out through the grid's right
/// side: the slabs stack along x, so it leaves from the last rank's slab while its particles
/// cross the others'.
fn leaving(pipeline: &str, steps: u64) -> String {
    scene(pipeline, steps)
        .replace(
            "    units: SI,",
            "    units: SI,\n    safety: (on_leave_grid: Remove),",
        )
        .replace(
            "velocity: Uniform((-0.4, -0.1))",
            "velocity: Uniform((2.0, -0.1))",
        )
}

/// The particles removed so far, as each rank of `ranks` holds the count after `steps`, with
/// each rank's owned particles.
fn removed_on_ranks(text: &str, ranks: usize, steps: u64) -> Vec<(States, EscapedParticles)> {
    each_rank(text, ranks, move |sim, comm| {
        for _ in 0..steps {
            distributed::step(sim, comm).unwrap();
        }
        let escaped = sim.world.resource::<EscapedParticles>().clone();
        (state_of_particles::<Two>(&mut sim.world).unwrap(), escaped)
    })
}

#[test]
fn particles_removed_on_leaving_the_grid_leave_every_rank_count_alike() {
    let steps = 300;
    let text = leaving(USL, steps);
    let mut serial = build_simulation(&parse(&text), &fractum_systems::stock_registry()).unwrap();
    for _ in 0..steps {
        serial.simulation.step().unwrap();
    }
    let world = &mut serial.simulation.world;
    let expected = world.resource::<EscapedParticles>().clone();
    let serial_ids: Vec<u32> = state_of_particles::<Two>(world)
        .unwrap()
        .into_keys()
        .collect();
    assert!(
        expected.count > 20 && serial_ids.len() > 100,
        "{expected:?}, {} left",
        serial_ids.len()
    );
    let mut one_rank = None;
    for ranks in 1..=4 {
        let results = removed_on_ranks(&text, ranks, steps);
        // Every rank holds the run's count and first removed particle: one process's.
        for (_, escaped) in &results {
            assert_eq!(escaped.count, expected.count, "{ranks} ranks");
            assert_eq!(escaped.first, expected.first, "{ranks} ranks");
            assert!(escaped.removed.is_empty(), "a rank despawned rows");
        }
        let mut merged = States::new();
        for (owned, _) in results {
            merged.extend(owned);
        }
        // The same particles are left as in one process, each owned by one rank.
        assert_eq!(merged.keys().copied().collect::<Vec<_>>(), serial_ids);
        // One process moves its last rows into the removed ones' places, so its node sums
        // then add in another order; the ranks keep their rows in id order, so every rank
        // count gives the same bits.
        match &one_rank {
            None => one_rank = Some(merged),
            Some(reference) => assert_states_match(reference, [&merged], ranks),
        }
    }
}

#[test]
fn every_particle_leaving_the_grid_stops_every_rank_as_one_process_stops() {
    // Both disks thrown out through the right side.
    let text = leaving(USL, 400).replace(
        "velocity: Uniform((0.4, 0.1))",
        "velocity: Uniform((4.0, 0.1))",
    );
    let mut serial = build_simulation(&parse(&text), &fractum_systems::stock_registry()).unwrap();
    let expected = loop {
        if let Err(blowup) = serial.simulation.step() {
            break blowup.to_string();
        }
    };
    assert!(
        expected.contains("every particle has left the grid"),
        "{expected}"
    );
    for ranks in [2, 3] {
        let failures = each_rank(&text, ranks, |sim, comm| {
            loop {
                if let Err(failure) = distributed::step(sim, comm) {
                    break failure.message;
                }
            }
        });
        for message in failures {
            assert_eq!(message, expected, "{ranks} ranks");
        }
    }
}
