//! Bodies from closed triangle surfaces (`Surface("file")`): the fixtures in
//! `tests/fixtures/surfaces/` were exported by trimesh (`make_surfaces.py` beside them).

use bevy_ecs::query::With;
use fractum_engine::components::{InitialVolume, Particle, Position};
use fractum_engine::prelude::*;
use fractum_engine::simulation::{End, TimeStep};
use fractum_scene::surface::read_surface;
use fractum_scene::{Body, Placement, Shape, Spec};
use fractum_suite::repo_root;
use glam::DVec3;
use std::sync::Arc;

fn surface(name: &str) -> Shape {
    let path = repo_root().join("tests/fixtures/surfaces").join(name);
    Shape::Surface(Arc::new(
        read_surface(&path, name).unwrap_or_else(|e| panic!("{name}: {e}")),
    ))
}

/// The particles of a body of `shape` in the cube from 0 to 0.1 m with `cells` cells along
/// each axis, 2 Gauss points per direction: positions and volumes in spawn order, on
/// `threads` threads.
fn particles_on(shape: Shape, cells: usize, threads: usize) -> Vec<([f64; 3], f64)> {
    let grid = Grid::<Three> {
        min: DVec3::ZERO,
        spacing: 0.1 / cells as f64,
        cells: [cells; 3],
        graded: None,
        window: None,
    };
    let mut body = Body::new(shape, "steel");
    body.placement = Placement::Gauss;
    let spec = Spec::new(grid)
        .time(TimeStep::Fixed(1e-7), End::Steps(1))
        .material(Material::new("steel", 7800.0, 2.0e11, 0.3))
        .body(body)
        .system("basis/linear")
        .system("predictor/usl")
        .system("stress/linear_elastic")
        .system("advection/usl");
    let mut built = spec
        .build(&fractum_systems::stock_registry())
        .unwrap_or_else(|e| panic!("{e}"));
    built.simulation.set_threads(threads).unwrap();
    let world = &mut built.simulation.world;
    let mut query = world.query_filtered::<(&Position<Three>, &InitialVolume), With<Particle>>();
    query
        .iter(world)
        .map(|(x, v)| (x.0.to_array(), v.0))
        .collect()
}

/// As [`particles_on`], with 5 mm cells.
fn particles(shape: Shape, threads: usize) -> Vec<([f64; 3], f64)> {
    particles_on(shape, 20, threads)
}

fn volume(particles: &[([f64; 3], f64)]) -> f64 {
    particles.iter().map(|p| p.1).sum()
}

#[test]
fn an_imported_sphere_has_the_sphere_s_volume() {
    let radius: f64 = 0.02;
    let analytic = 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3);
    for name in ["sphere.stl", "sphere.obj"] {
        let shape = surface(name);
        let Shape::Surface(s) = &shape else {
            unreachable!()
        };
        assert_eq!(s.facet_count(), 1280);
        let facetted = s.volume();
        // 1.25 mm cells, 32 across the radius. The facets hold 0.86% less than the sphere;
        // the seeded volume was +0.04% from the facets here (−0.81% at 16 cells across the
        // radius, +2.3% at 8, where the per-cell rule's staircase dominates).
        let seeded = volume(&particles_on(shape.clone(), 80, 1));
        let (to_facets, to_sphere) = (seeded / facetted - 1.0, seeded / analytic - 1.0);
        assert!(
            to_sphere.abs() < 0.01,
            "{name}: {to_sphere:e} from the sphere"
        );
        assert!(
            to_facets.abs() < 0.001,
            "{name}: {to_facets:e} from the facets"
        );
    }
}

#[test]
fn an_imported_box_seeds_the_built_in_box_s_particles() {
    let built_in = particles(
        Shape::Box {
            min: DVec3::new(0.02, 0.03, 0.04),
            max: DVec3::new(0.08, 0.07, 0.06),
        },
        1,
    );
    assert_eq!(built_in.len(), 12 * 8 * 4 * 8);
    assert_eq!(particles(surface("box.stl"), 1), built_in);
    assert_eq!(particles(surface("box_ascii.stl"), 1), built_in);
}

#[test]
fn ascii_and_binary_stl_read_the_same_facets_and_threads_do_not_matter() {
    assert_eq!(surface("box.stl"), surface("box_ascii.stl"));
    let one = particles(surface("sphere.stl"), 1);
    assert_eq!(particles(surface("sphere.stl"), 2), one);
}

/// Gmsh's STL export does not keep a closed surface's facets turning one way: the box with
/// every other facet written the wrong way round (its second and third corners swapped) is
/// re-oriented when read, and seeds the box's particles.
#[test]
fn a_surface_with_facets_turned_the_wrong_way_is_reoriented() {
    let text =
        std::fs::read_to_string(repo_root().join("tests/fixtures/surfaces/box_ascii.stl")).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    let corners: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i].trim_start().starts_with("vertex"))
        .collect();
    for (facet, first) in corners.chunks(3).enumerate() {
        if facet % 2 == 1 {
            lines.swap(first[1], first[2]);
        }
    }
    let dir = std::env::temp_dir().join(format!("fractum-mixed-stl-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("box_mixed.stl");
    std::fs::write(&path, lines.join("\n")).unwrap();
    let mixed = read_surface(&path, "box_mixed.stl").unwrap_or_else(|e| panic!("{e}"));
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(
        (mixed.volume() - 0.06 * 0.04 * 0.02).abs() < 1e-12,
        "{}",
        mixed.volume()
    );
    let seeded = particles(Shape::Surface(Arc::new(mixed)), 1);
    assert_eq!(seeded, particles(surface("box_ascii.stl"), 1));
}
