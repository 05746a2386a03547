//! Bodies from particle files (`Points("file.csv")`, `Points("file.vtu")`): the particles,
//! volumes and what each row gives (velocity, damage, material) reach the world unchanged. The
//! VTU fixtures were written by meshio (`tests/fixtures/points/make_points.py`) and by Fractum
//! (frame 0 of `fractum run scenes/two_disks_points.ron --steps 1`).

use bevy_ecs::query::With;
use fractum_engine::components::{
    Damage, InitialVolume, Mass, MaterialId, Particle, Position, Strength, Velocity,
};
use fractum_engine::prelude::*;
use fractum_engine::simulation::{End, TimeStep};
use fractum_scene::points::read_points;
use fractum_scene::{Body, Built, SceneError, SceneFile, Shape, Spec, build_simulation};
use fractum_suite::{build_elastic, repo_root, seeded_and_stepped, temp_dir};
use glam::DVec2;
use std::sync::Arc;

/// Position, velocity and volume of every particle, in entity order.
fn state(world: &mut bevy_ecs::world::World) -> Vec<(DVec2, DVec2, f64)> {
    let mut query =
        world.query_filtered::<(&Position<Two>, &Velocity<Two>, &InitialVolume), With<Particle>>();
    query
        .iter(world)
        .map(|(x, v, vol)| (x.0, v.0, vol.0))
        .collect()
}

#[test]
fn a_particle_file_runs_as_the_mesh_it_was_written_from() {
    let (mesh_seeded, mesh) = seeded_and_stepped("two_disks_mesh.ron", 20, state);
    let (points_seeded, points) = seeded_and_stepped("two_disks_points.ron", 20, state);
    assert_eq!(points_seeded.len(), 1014);
    assert!(
        mesh_seeded == points_seeded,
        "the two scenes seed different particles"
    );
    assert!(mesh == points, "the two runs part after 20 steps");
}

/// A 2D scene over the unit square whose one body is `shape`, of material "soft" by default.
fn world_of(shape: Shape) -> bevy_ecs::world::World {
    let grid = Grid::<Two> {
        min: DVec2::ZERO,
        spacing: 0.1,
        cells: [10, 10],
        graded: None,
        window: None,
    };
    let built = build_elastic(
        Spec::new(grid)
            .time(TimeStep::Fixed(1e-5), End::Steps(1))
            .material(Material::new("soft", 1000.0, 1.0e6, 0.3))
            .material(Material::new("hard", 3000.0, 1.0e8, 0.2))
            .body(Body::new(shape, "soft")),
    );
    built.simulation.world
}

/// The point set of CSV `text`, written to a folder of its own named `name`.
fn points(name: &str, text: &str) -> Shape {
    let dir = temp_dir(name);
    let path = dir.join("p.csv");
    std::fs::write(&path, text).unwrap();
    let set = read_points(&path, "p.csv").unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    Shape::Points(Arc::new(set))
}

#[test]
fn each_row_gives_its_particle_s_volume_velocity_damage_and_material() {
    let shape = points(
        "attributes",
        "x,y,volume,vx,vy,damage,material\n\
         0.25,0.25,2e-3,1,0,0,soft\n\
         0.75,0.25,1e-3,0,-2,0.5,hard\n\
         0.55,0.75,4e-3,0,0,1,soft\n",
    );
    let mut world = world_of(shape);
    let mut query = world.query_filtered::<(
        &Position<Two>,
        &Velocity<Two>,
        &Mass,
        &Damage,
        &MaterialId,
    ), With<Particle>>();
    let mut rows: Vec<_> = query
        .iter(&world)
        .map(|(x, v, m, d, id)| (x.0, v.0, m.0, d.0, id.0))
        .collect();
    rows.sort_by(|a, b| a.0.x.total_cmp(&b.0.x));
    assert_eq!(
        rows,
        vec![
            (DVec2::new(0.25, 0.25), DVec2::new(1.0, 0.0), 2.0, 0.0, 0),
            (DVec2::new(0.55, 0.75), DVec2::ZERO, 4.0, 1.0, 0),
            (DVec2::new(0.75, 0.25), DVec2::new(0.0, -2.0), 3.0, 0.5, 1),
        ]
    );
}

#[test]
fn a_point_set_is_cropped_by_an_intersection() {
    let cropped = Shape::Intersection(vec![
        points(
            "cropped",
            "x,y,volume\n0.25,0.25,1e-3\n0.75,0.25,1e-3\n0.75,0.75,1e-3\n",
        ),
        Shape::Rectangle {
            min: DVec2::new(0.5, 0.0),
            max: DVec2::new(1.0, 1.0),
        },
    ]);
    let mut world = world_of(cropped);
    let mut query = world.query_filtered::<&Position<Two>, With<Particle>>();
    let mut kept: Vec<DVec2> = query.iter(&world).map(|x| x.0).collect();
    kept.sort_by(|a, b| a.y.total_cmp(&b.y));
    assert_eq!(kept, vec![DVec2::new(0.75, 0.25), DVec2::new(0.75, 0.75)]);
}

#[test]
fn vtu_files_from_meshio_and_from_fractum_give_the_csv_s_particles() {
    let read = |path: &str| {
        let path = repo_root().join(path);
        read_points(&path, "file").unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    };
    let csv = read("scenes/geometry/two_disks_particles.csv");
    for vtu in ["two_disks_meshio.vtu", "two_disks_frame.vtu"] {
        let set = read(&format!("tests/fixtures/points/{vtu}"));
        assert_eq!(set.dimension(), 2, "{vtu}");
        assert!(set.particles() == csv.particles(), "{vtu}: other particles");
        for (x, _) in csv.particles() {
            let (ours, theirs) = (set.attributes(x).unwrap(), csv.attributes(x).unwrap());
            assert_eq!(ours.velocity, theirs.velocity, "{vtu} at {x}");
        }
    }
    // Fractum's frame carries each particle's material index and damage too.
    let frame = read("tests/fixtures/points/two_disks_frame.vtu");
    let first = frame.attributes(csv.particles()[0].0).unwrap();
    assert_eq!((first.material, first.damage), (Some("0"), Some(0.0)));
    let mut world = world_of(Shape::Points(Arc::new(frame)));
    let mut query = world.query_filtered::<&MaterialId, With<Particle>>();
    assert!(query.iter(&world).all(|m| m.0 == 0));
    assert_eq!(query.iter(&world).count(), 1014);
}

/// A 2D scene over the unit square whose one body is the particle file `csv` (written beside
/// it), with the damage law `damage` (a pipeline entry, or empty for none).
fn scene_with_points(name: &str, csv: &str, damage: &str) -> Result<Built, SceneError> {
    let dir = temp_dir(name);
    std::fs::write(dir.join("p.csv"), csv).unwrap();
    let text = format!(
        r#"(
    time: (step: Fixed(1.0e-5), end: Steps(1)),
    grid: (min: (0.0, 0.0), max: (1.0, 1.0), spacing: 0.1),
    materials: {{"rock": (density: 1000.0, youngs_modulus: 1.0e6, poisson_ratio: 0.2)}},
    bodies: [(shape: Points("p.csv"), material: "rock")],
    pipeline: [
        (system: "basis/linear"),
        (system: "predictor/usl"),
        (system: "stress/neo_hookean"),
        {damage}
        (system: "advection/usl"),
    ],
)"#
    );
    let scene = dir.join("scene.ron");
    let file = SceneFile::parse(&scene.to_string_lossy(), text).unwrap();
    let built = build_simulation(&file, &fractum_systems::stock_registry());
    std::fs::remove_dir_all(&dir).unwrap();
    built
}

const SCALED: &str = "x,y,volume,strength_scale\n\
                      0.25,0.25,1e-3,1\n\
                      0.75,0.25,1e-3,0.5\n\
                      0.55,0.75,1e-3,2.5\n";

/// Each particle's strength, in order of x, for `law` over the particle file `csv`.
fn strengths(csv: &str, law: &str) -> Vec<f64> {
    let mut built = scene_with_points("scaled", csv, law).unwrap_or_else(|e| panic!("{e}"));
    let world = &mut built.simulation.world;
    let mut query = world.query::<(&Position<Two>, &Strength)>();
    let mut all: Vec<(f64, f64)> = query.iter(world).map(|(x, s)| (x.0.x, s.0)).collect();
    all.sort_by(|a, b| a.0.total_cmp(&b.0));
    all.into_iter().map(|(_, s)| s).collect()
}

#[test]
fn a_strength_scale_column_multiplies_the_strength_the_damage_law_gives() {
    let unit = SCALED.replace(",0.5\n", ",1\n").replace(",2.5\n", ",1\n");
    // In order of x: the scales 1, 2.5 (x = 0.55) and 0.5 (x = 0.75).
    let scales = [1.0, 2.5, 0.5];
    let plain = r#"(system: "damage/time_to_failure", params: (tensile_strength: 100.0, crack_speed: 200.0)),"#;
    assert_eq!(strengths(SCALED, plain), scales.map(|s| 100.0 * s));
    // A Weibull draw per particle, then the particle's scale.
    let weibull = r#"(system: "damage/time_to_failure", params: (tensile_strength: 100.0, crack_speed: 200.0, weibull: (modulus: 6.0, reference_volume: 1e-3, seed: 7, thickness: 1.0))),"#;
    let drawn = strengths(&unit, weibull);
    assert!(drawn.iter().any(|&s| s != 100.0), "{drawn:?}");
    let expected: Vec<f64> = drawn.iter().zip(scales).map(|(s, k)| s * k).collect();
    assert_eq!(strengths(SCALED, weibull), expected);
}

#[test]
fn strength_scales_that_no_damage_law_reads_are_refused() {
    let error = match scene_with_points("unread", SCALED, "") {
        Ok(_) => panic!("strength scales without a strength law were accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        error.contains("`bodies[0].shape`")
            && error
                .contains("no damage law of the pipeline gives its particles a tensile strength"),
        "{error}"
    );
    let bad = "x,y,volume,strength_scale\n0.25,0.25,1e-3,0\n";
    let error = match scene_with_points("zero", bad, "") {
        Ok(_) => panic!("a zero strength scale was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(error.contains("line 2: `strength_scale` is 0"), "{error}");
}

/// A disk of particles from a file with a strength scale growing along x, thrown at a plain
/// disk at rest, with time-to-failure damage: the scene's text, written beside its file in
/// `dir`: the scene's path and text.
fn scaled_disk_scene(dir: &std::path::Path) -> (String, String) {
    let mut csv = String::from("x,y,volume,strength_scale\n");
    let spacing = 0.025;
    for i in 0..40 {
        for j in 0..40 {
            let (x, y) = (0.0125 + spacing * i as f64, 0.0125 + spacing * j as f64);
            if (x - 0.3f64).hypot(y - 0.5) < 0.15 {
                csv.push_str(&format!("{x},{y},{},{}\n", spacing * spacing, 1.0 + x));
            }
        }
    }
    std::fs::write(dir.join("disk.csv"), csv).unwrap();
    let text = r#"(
    time: (step: Fixed(1.0e-4), end: Steps(150)),
    grid: (min: (0.0, 0.0), max: (1.0, 1.0), spacing: 0.05),
    materials: {"rock": (density: 1000.0, youngs_modulus: 1.0e6, poisson_ratio: 0.2)},
    bodies: [
        (name: "scaled", shape: Points("disk.csv"), material: "rock",
         velocity: Uniform((20.0, 0.0))),
        (name: "plain", shape: Disk(center: (0.75, 0.5), radius: 0.1), material: "rock",
         particles_per_cell: 2),
    ],
    pipeline: [
        (system: "basis/linear"),
        (system: "predictor/usl"),
        (system: "stress/neo_hookean"),
        (system: "damage/time_to_failure", params: (tensile_strength: 2.0e4, crack_speed: 200.0)),
        (system: "advection/usl"),
    ],
)"#;
    let scene = dir.join("scene.ron").to_string_lossy().into_owned();
    (scene, text.to_string())
}

#[test]
fn strength_scales_beside_a_body_without_them_leave_every_particle_in_one_table() {
    let dir = temp_dir("scaled-and-plain");
    let (path, text) = scaled_disk_scene(&dir);
    let file = SceneFile::parse(&path, text).unwrap();
    let mut built = build_simulation(&file, &fractum_systems::stock_registry()).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    // The systems read the particles' columns as one table: steps run.
    for _ in 0..5 {
        built.simulation.step().unwrap();
    }
    let world = &mut built.simulation.world;
    let mut query = world.query::<(
        &Position<Two>,
        &fractum_engine::components::BodyId,
        &Strength,
    )>();
    for (x, body, strength) in query.iter(world) {
        let expected = match body.0 {
            // The file's scale, 1 + x at the seed; the disk has moved 5 steps at 20 m/s.
            0 => 2.0e4 * (1.0 + x.0.x - 5.0 * 1.0e-4 * 20.0),
            _ => 2.0e4,
        };
        assert!(
            (strength.0 - expected).abs() < 1e-9 * expected,
            "body {}: {} against {expected}",
            body.0,
            strength.0
        );
    }
}

#[test]
fn strength_scales_over_ranks_give_every_particle_the_single_process_state() {
    use fractum_engine::communicator::{Communicator, thread_ranks};
    use fractum_io::run::distributed::{self, state_of_particles};
    let dir = temp_dir("scaled-ranks");
    let (path, text) = scaled_disk_scene(&dir);
    let file = SceneFile::parse(&path, text.clone()).unwrap();
    let registry = fractum_systems::stock_registry();
    let steps = 150;
    let mut serial = build_simulation(&file, &registry).unwrap();
    for _ in 0..steps {
        serial.simulation.step().unwrap();
    }
    let reference = state_of_particles::<Two>(&mut serial.simulation.world).unwrap();
    for ranks in 2..=3 {
        let threads: Vec<_> = thread_ranks(ranks)
            .into_iter()
            .map(|comm| {
                let file = SceneFile::parse(&path, text.clone()).unwrap();
                std::thread::spawn(move || {
                    let registry = fractum_systems::stock_registry();
                    let mut built = fractum_scene::build_rank_simulation(
                        &file,
                        &registry,
                        comm.rank(),
                        comm.size(),
                    )
                    .unwrap();
                    for _ in 0..steps {
                        distributed::step(&mut built.simulation, &comm).unwrap();
                    }
                    state_of_particles::<Two>(&mut built.simulation.world).unwrap()
                })
            })
            .collect();
        let mut merged = std::collections::BTreeMap::new();
        for thread in threads {
            merged.extend(thread.join().unwrap());
        }
        assert_eq!(merged.len(), reference.len(), "{ranks} ranks");
        let differing = reference
            .iter()
            .filter(|(id, s)| merged.get(id) != Some(s))
            .count();
        assert_eq!(
            differing, 0,
            "{ranks} ranks: particles differ from one process"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
