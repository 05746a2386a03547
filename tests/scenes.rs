//! Every shipped scene in `scenes/` loads, runs a few steps with finite state, and writes a CSV
//! with the required columns and VTU frames that load: every other scene writes them
//! uncompressed and a second VTK reader (vtkio, which does not take compressed inline arrays)
//! loads them; the others keep the default zlib and Fractum's reader loads them. VTK's own
//! reader takes both encodings in `tests/vtk_reader.rs`.

use bevy_ecs::prelude::{Entity, With};
use fractum_engine::budget::MemoryUse;
use fractum_engine::components::Particle;
use fractum_engine::registry::templates::SPAWN_BATCH;
use fractum_engine::simulation::End;
use fractum_io::output::{FrameCompression, base_columns, read_particle_frame};
use fractum_io::run::run;
use fractum_scene::{Built, SceneFile, estimate_memory};
use fractum_suite::{load, ron_files, temp_dir};

fn frame_point_count(path: &std::path::Path) -> usize {
    let vtk = vtkio::Vtk::import(path).unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
    let vtkio::model::DataSet::UnstructuredGrid { pieces, .. } = vtk.data else {
        panic!("{}: not an unstructured grid", path.display());
    };
    let piece = pieces[0]
        .load_piece_data(Some(path))
        .unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
    let names: Vec<String> = piece
        .data
        .point
        .iter()
        .map(|a| a.name().to_string())
        .collect();
    for expected in ["id", "velocity", "stress", "damage", "mass", "volume"] {
        assert!(
            names.iter().any(|n| n == expected),
            "{}: no `{expected}` array",
            path.display()
        );
    }
    piece.num_points()
}

/// Entities are spawned with the components the installers give them
/// (`registry/templates.rs`), so no table that every particle or node left holds more than one
/// spawn batch of memory.
fn assert_no_emptied_table_is_kept(world: &bevy_ecs::world::World, name: &str) {
    let kept: Vec<usize> = world
        .storages()
        .tables
        .iter()
        .filter(|t| t.is_empty() && t.entity_capacity() > SPAWN_BATCH)
        .map(|t| t.entity_capacity())
        .collect();
    assert!(
        kept.is_empty(),
        "{name}: empty tables keep room for {kept:?} entities"
    );
}

/// The memory estimate from counts (`fractum check --estimate`, nothing spawned) counts the
/// particles the build spawned, is the estimate the build passed, and gives each particle at
/// least the bytes of every component the built particles carry.
fn assert_estimate_counts_what_was_built(path: &std::path::Path, built: &mut Built, name: &str) {
    let file = SceneFile::read(path).unwrap();
    let estimate = estimate_memory(&file, &fractum_systems::stock_registry(), None)
        .unwrap_or_else(|e| panic!("{e}"));
    let counts: Vec<usize> = estimate.bodies.iter().map(|(_, n)| *n).collect();
    assert_eq!(counts, built.body_particles, "{name}");
    let used = built.simulation.world.resource::<MemoryUse>();
    assert_eq!(estimate.estimate.total(), used.needed, "{name}");
    let world = &mut built.simulation.world;
    let first = world
        .query_filtered::<Entity, With<Particle>>()
        .iter(world)
        .next()
        .unwrap();
    let components = world.components();
    let carried: usize = world
        .entity(first)
        .archetype()
        .components()
        .iter()
        .map(|&id| components.get_info(id).unwrap().layout().size())
        .sum();
    let particles = counts.iter().sum::<usize>() as f64;
    let per_particle = estimate.estimate.parts[1].1 / particles;
    assert!(
        per_particle >= carried as f64,
        "{name}: {per_particle} bytes estimated per particle, {carried} carried"
    );
}

#[test]
fn every_shipped_scene_runs_a_few_steps() {
    let scenes = ron_files("scenes");
    assert!(!scenes.is_empty());
    for (k, path) in scenes.into_iter().enumerate() {
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        let mut built = load(&path).unwrap_or_else(|e| panic!("{e}"));
        let particles = built.simulation.particle_count();
        assert_no_emptied_table_is_kept(&built.simulation.world, &name);
        assert_estimate_counts_what_was_built(&path, &mut built, &name);
        built.simulation.set_end(End::Steps(5));
        let mut plan = built.output.clone();
        plan.vtu_every = 5;
        let plain = k % 2 == 0;
        if plain {
            plan.compression = FrameCompression::None;
        }
        let out = temp_dir(&name);
        let summary = run(&mut built.simulation, &plan, &out, |_| {})
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(summary.steps, 5);
        let csv = std::fs::read_to_string(out.join("series.csv")).unwrap();
        let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
        let base = base_columns(plan.dimension);
        assert_eq!(&header[..base.len()], &base);
        let last: Vec<f64> = csv
            .lines()
            .last()
            .unwrap()
            .split(',')
            .map(|v| v.parse().unwrap())
            .collect();
        assert_eq!(last.len(), header.len());
        assert!(last.iter().all(|v| v.is_finite()), "{name}: {last:?}");
        let frame = out.join("frames/particles_00000005.vtu");
        if plain {
            assert_eq!(frame_point_count(&frame), particles, "{name}");
        } else {
            let read = read_particle_frame(&frame).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(read.position.len(), particles, "{name}");
            let full = ["id", "velocity", "stress", "damage", "mass", "volume"];
            read.require(&full)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
        }
        let pvd = std::fs::read_to_string(out.join("particles.pvd")).unwrap();
        assert!(
            pvd.contains("frames/particles_00000000.vtu")
                && pvd.contains("frames/particles_00000005.vtu")
        );
        std::fs::remove_dir_all(&out).unwrap();
    }
}
