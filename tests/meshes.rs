//! Bodies from finite-element meshes (`Mesh(file: .., physical: .., seeding: ..)`): the Gmsh
//! fixtures in `tests/fixtures/meshes/` were written by Gmsh from the `.geo` files beside them;
//! `nl-partsol/` holds NL-PartSol's own GiD mesh of its two-disk example and the particle set
//! that code seeds from it.

use bevy_ecs::query::With;
use fractum_engine::boundary::BoundaryConditions;
use fractum_engine::components::{InitialVolume, Particle, Position, Velocity};
use fractum_engine::prelude::*;
use fractum_engine::simulation::{End, TimeStep};
use fractum_scene::mesh::{Mesh, MeshSeeding, boundary_facets, read_mesh, read_raw_mesh};
use fractum_scene::{
    Body, Boundary, Built, Condition, InitialVelocity, Placement, Shape, Spec, particles_in_shape,
};
use fractum_suite::{build_elastic, repo_root, seeded_and_stepped};
use glam::{DVec2, DVec3};
use std::f64::consts::PI;
use std::sync::Arc;

fn read(name: &str, physical: Option<&str>, seeding: MeshSeeding) -> Mesh {
    let path = repo_root().join("tests/fixtures/meshes").join(name);
    read_mesh(&path, name, physical, seeding).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn mesh(name: &str, physical: Option<&str>, seeding: MeshSeeding) -> Shape {
    Shape::Mesh(Arc::new(read(name, physical, seeding)))
}

/// A 2D grid over the unit square with `cells` cells along each axis.
fn grid2(cells: usize) -> Grid<Two> {
    Grid::<Two> {
        min: DVec2::ZERO,
        spacing: 1.0 / cells as f64,
        cells: [cells; 2],
        graded: None,
        window: None,
    }
}

/// The particles of `shape`, 2 Gauss points per direction per cell (or the mesh's rule of
/// order 2 for `Elements` seeding), unit thickness.
fn seeded2(shape: &Shape, cells: usize) -> Vec<(DVec2, f64)> {
    particles_in_shape(shape, &grid2(cells), 2, Placement::Gauss, 1.0)
}

fn seeded3(shape: &Shape, cells: usize) -> Vec<(DVec3, f64)> {
    let grid = Grid::<Three> {
        min: DVec3::ZERO,
        spacing: 1.0 / cells as f64,
        cells: [cells; 3],
        graded: None,
        window: None,
    };
    particles_in_shape(shape, &grid, 2, Placement::Gauss, 1.0)
}

fn total<V>(particles: &[(V, f64)]) -> f64 {
    particles.iter().map(|p| p.1).sum()
}

#[test]
fn a_meshed_disk_has_the_disk_s_area_by_either_seeding() {
    let analytic = PI * 0.3 * 0.3;
    let facetted = read("disk.msh", None, MeshSeeding::Grid).measure();
    // 64 edges on the rim: the polygon holds 0.16% less than the circle.
    assert!((facetted / analytic - 1.0).abs() < 0.01, "{facetted}");
    // 160 cells across the unit square, 48 across the radius.
    let grid = total(&seeded2(&mesh("disk.msh", None, MeshSeeding::Grid), 160));
    assert!(
        (grid / facetted - 1.0).abs() < 1e-3,
        "grid seeding {:e} from the facets",
        grid / facetted - 1.0
    );
    assert!((grid / analytic - 1.0).abs() < 0.01);
    let elements = seeded2(&mesh("disk.msh", None, MeshSeeding::Elements), 160);
    assert_eq!(
        elements.len(),
        3 * read("disk.msh", None, MeshSeeding::Grid).element_count()
    );
    assert!((total(&elements) / facetted - 1.0).abs() < 1e-12);
}

#[test]
fn physical_groups_select_regions_and_an_unknown_name_lists_those_there_are() {
    let core = read("disk.msh", Some("core"), MeshSeeding::Grid).measure();
    let ring = read("disk.msh", Some("ring"), MeshSeeding::Grid).measure();
    let whole = read("disk.msh", None, MeshSeeding::Grid).measure();
    assert!((core / (PI * 0.15 * 0.15) - 1.0).abs() < 0.01, "{core}");
    assert!((ring / (PI * (0.09 - 0.0225)) - 1.0).abs() < 0.01, "{ring}");
    assert!((core + ring - whole).abs() < 1e-14);
    let path = repo_root().join("tests/fixtures/meshes/disk.msh");
    let missing = read_mesh(&path, "disk.msh", Some("granite"), MeshSeeding::Grid).unwrap_err();
    assert!(
        missing.to_string().contains("\"core\", \"ring\""),
        "{missing}"
    );
    let boundary = read_mesh(&path, "disk.msh", Some("rim"), MeshSeeding::Grid).unwrap_err();
    assert!(boundary.to_string().contains("dimension 1"), "{boundary}");
}

#[test]
fn ascii_and_binary_gmsh_files_give_bitwise_identical_particles() {
    for (ascii, binary) in [
        ("disk.msh", "disk_binary.msh"),
        ("plate_hole.msh", "plate_hole_binary.msh"),
    ] {
        for seeding in [MeshSeeding::Grid, MeshSeeding::Elements] {
            let a = seeded2(&mesh(ascii, None, seeding), 100);
            let b = seeded2(&mesh(binary, None, seeding), 100);
            assert!(!a.is_empty());
            assert_eq!(a.len(), b.len(), "{ascii} against {binary}, {seeding:?}");
            if let Some(k) = (0..a.len()).find(|&k| a[k] != b[k]) {
                panic!(
                    "{ascii} against {binary}, {seeding:?}: particle {k}: {:?} against {:?}",
                    a[k], b[k]
                );
            }
        }
    }
}

#[test]
fn a_plate_with_a_hole_by_difference_seeds_the_meshed_plate_s_particles() {
    let difference = Shape::Difference(
        Box::new(Shape::Rectangle {
            min: DVec2::ZERO,
            max: DVec2::new(0.4, 0.2),
        }),
        Box::new(Shape::Disk {
            center: DVec2::new(0.2, 0.1),
            radius: 0.05,
        }),
    );
    let meshed = mesh("plate_hole.msh", Some("plate"), MeshSeeding::Grid);
    // 2.5 mm cells, 20 across the hole.
    let by_difference = seeded2(&difference, 400);
    let by_mesh = seeded2(&meshed, 400);
    assert_eq!(by_difference.len(), by_mesh.len());
    assert_eq!(by_difference, by_mesh);
    let analytic = 0.4 * 0.2 - PI * 0.05 * 0.05;
    assert!((total(&by_mesh) / analytic - 1.0).abs() < 0.01);
    let Shape::Mesh(m) = &meshed else {
        unreachable!()
    };
    // The hole's polygon of 256 edges: 1e-4 of the hole's area, 1e-5 of the plate's.
    assert!(
        (m.measure() / analytic - 1.0).abs() < 2e-5,
        "{}",
        m.measure()
    );
}

#[test]
fn a_meshed_sphere_and_a_hexahedral_block_have_their_volumes() {
    let analytic = 4.0 / 3.0 * PI * 0.3f64.powi(3);
    let sphere = read("sphere.msh", Some("sphere"), MeshSeeding::Grid);
    let facetted = sphere.measure();
    assert!((facetted / analytic - 1.0).abs() < 0.01, "{facetted}");
    // 1/64 cells, 19 across the radius.
    let grid = total(&seeded3(&Shape::Mesh(Arc::new(sphere)), 64));
    assert!(
        (grid / facetted - 1.0).abs() < 1e-3,
        "grid seeding {:e} from the facets",
        grid / facetted - 1.0
    );
    let elements = seeded3(&mesh("sphere.msh", None, MeshSeeding::Elements), 64);
    assert!((total(&elements) / facetted - 1.0).abs() < 1e-12);

    // The block's hexahedra give the built-in box's particles, and their exact volume.
    let block = mesh("block.msh", Some("block"), MeshSeeding::Grid);
    let built_in = Shape::Box {
        min: DVec3::ZERO,
        max: DVec3::new(0.2, 0.2, 0.1),
    };
    assert_eq!(seeded3(&block, 40), seeded3(&built_in, 40));
    let hexes = seeded3(&mesh("block.msh", None, MeshSeeding::Elements), 40);
    assert_eq!(hexes.len(), 8 * 8 * 8 * 4);
    assert!((total(&hexes) - 0.004).abs() < 1e-15);
}

/// The reference particle set of NL-PartSol's two-disk mesh: positions and volumes.
fn nl_partsol_particles() -> Vec<(DVec2, f64)> {
    let path = repo_root().join("tests/fixtures/meshes/nl-partsol/particles.csv");
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .skip(1)
        .map(|line| {
            let v: Vec<f64> = line.split(',').map(|w| w.parse().unwrap()).collect();
            (DVec2::new(v[0], v[1]), v[2])
        })
        .collect()
}

/// The two-disk scene seeded from NL-PartSol's mesh, one particle per element, each disk a
/// body cut from the mesh by a half-plane (the disks touch no line x + y = 0.5).
fn two_disks(threads: usize) -> Built {
    let disks = mesh("nl-partsol/MPM_Mesh.msh", None, MeshSeeding::Elements);
    let half = |lower: bool| {
        let corner = if lower { DVec2::ZERO } else { DVec2::ONE };
        Shape::Polygon {
            vertices: vec![corner, DVec2::new(1.0, 0.0), DVec2::new(0.0, 1.0)],
        }
    };
    let body = |lower: bool, v: f64| {
        let mut b = Body::new(
            Shape::Intersection(vec![disks.clone(), half(lower)]),
            "elastic",
        )
        .velocity(InitialVelocity::Uniform(DVec2::splat(v)));
        b.particles_per_cell = 1;
        b
    };
    let grid = Grid::<Two> {
        min: DVec2::ZERO,
        spacing: 0.05,
        cells: [20; 2],
        graded: None,
        window: None,
    };
    let spec = Spec::new(grid)
        .time(TimeStep::Fixed(1e-4), End::Steps(20))
        .material(Material::new("elastic", 1000.0, 1.0e6, 0.3))
        .body(body(true, 0.1))
        .body(body(false, -0.1))
        .system("basis/linear")
        .system("predictor/usl")
        .system("stress/linear_elastic")
        .system("advection/usl");
    let mut built = spec
        .build(&fractum_systems::stock_registry())
        .unwrap_or_else(|e| panic!("{e}"));
    built.simulation.set_threads(threads).unwrap();
    built
}

fn positions(world: &mut bevy_ecs::world::World) -> Vec<(DVec2, f64)> {
    let mut query = world.query_filtered::<(&Position<Two>, &InitialVolume), With<Particle>>();
    query.iter(world).map(|(x, v)| (x.0, v.0)).collect()
}

#[test]
fn nl_partsol_s_two_disk_mesh_gives_its_particle_set_exactly() {
    let reference = nl_partsol_particles();
    assert_eq!(reference.len(), 616);
    let disks = mesh("nl-partsol/MPM_Mesh.msh", None, MeshSeeding::Elements);
    let seeded = particles_in_shape(&disks, &grid2(20), 1, Placement::Uniform, 1.0);
    assert_eq!(seeded.len(), reference.len());
    for (k, (ours, theirs)) in seeded.iter().zip(&reference).enumerate() {
        assert_eq!(ours, theirs, "particle {k}");
    }
    // The scene's two bodies hold the same particles, lower disk first.
    let mut built = two_disks(1);
    let mut in_scene = positions(&mut built.simulation.world);
    let mut sorted = reference.clone();
    let key = |p: &(DVec2, f64)| (p.0.x.to_bits(), p.0.y.to_bits());
    in_scene.sort_by_key(key);
    sorted.sort_by_key(key);
    assert_eq!(in_scene, sorted);
}

#[test]
fn one_and_two_threads_move_meshed_bodies_identically() {
    let mut runs = [1, 2].map(|threads| {
        let mut built = two_disks(threads);
        for _ in 0..20 {
            built.simulation.step().unwrap();
        }
        positions(&mut built.simulation.world)
    });
    let two = runs[1].split_off(0);
    assert_eq!(runs[0], two);
}

/// Positions and velocities of every particle of a 3D world, in entity order.
fn state3(world: &mut bevy_ecs::world::World) -> Vec<(DVec3, DVec3)> {
    let mut query = world.query_filtered::<(&Position<Three>, &Velocity<Three>), With<Particle>>();
    query.iter(world).map(|(x, v)| (x.0, v.0)).collect()
}

#[test]
fn the_meshed_plate_with_its_end_groups_runs_as_its_built_in_twin() {
    let look = |world: &mut bevy_ecs::world::World| {
        let regions: Vec<Vec<u32>> = world
            .resource::<BoundaryConditions>()
            .regions
            .iter()
            .map(|r| r.nodes.clone())
            .collect();
        (regions, positions(world))
    };
    let (difference_seeded, difference) = seeded_and_stepped("plate_with_hole.ron", 50, look);
    let (mesh_seeded, mesh) = seeded_and_stepped("plate_with_hole_mesh.ron", 50, look);
    assert_eq!(
        difference_seeded.0, mesh_seeded.0,
        "the end regions hold other nodes"
    );
    assert!(
        difference_seeded == mesh_seeded,
        "the two plates seed different particles"
    );
    assert!(difference == mesh, "the two runs part after 50 steps");
}

#[test]
fn the_meshed_drop_weight_beam_runs_as_its_built_in_twin() {
    let (prism_seeded, prism) = seeded_and_stepped("drop_weight_3d.ron", 8, state3);
    let (mesh_seeded, mesh) = seeded_and_stepped("drop_weight_3d_mesh.ron", 8, state3);
    assert_eq!(prism_seeded.len(), 41_200);
    assert!(
        prism_seeded == mesh_seeded,
        "the two beams seed different particles"
    );
    assert!(prism == mesh, "the two runs part after 8 steps");
}

/// The nodes of each boundary region of `spec`, built with the plate as its body.
fn region_nodes<D: Dim>(spec: Spec<D>) -> Vec<Vec<u32>> {
    let built = build_elastic(spec);
    let regions = &built
        .simulation
        .world
        .resource::<BoundaryConditions>()
        .regions;
    regions.iter().map(|r| r.nodes.clone()).collect()
}

/// The boundary group `physical` of fixture `name`, as a fixed region.
fn group<D: Dim>(name: &str, physical: &str) -> Boundary<D> {
    let path = repo_root().join("tests/fixtures/meshes").join(name);
    let raw = read_raw_mesh(&path).unwrap();
    let facets = boundary_facets(&raw, name, physical).unwrap_or_else(|e| panic!("{e}"));
    let (lo, hi) = facets.bounds();
    Boundary {
        facets: Some(Arc::new(facets)),
        ..Boundary::new(
            physical,
            D::Vector::from_fn(|a| lo[a]),
            D::Vector::from_fn(|a| hi[a]),
            Condition::Fixed,
        )
    }
}

#[test]
fn boundary_groups_hold_the_grid_nodes_along_them() {
    // 2D: the plate's left edge is the nodes a box on x = 0 holds; the hole's rim the nodes
    // within half a cell of the circle.
    let h = 0.01;
    let grid = Grid::<Two> {
        min: DVec2::new(-0.05, -0.05),
        spacing: h,
        cells: [50, 30],
        graded: None,
        window: None,
    };
    let plate = || {
        Spec::new(grid.clone())
            .time(TimeStep::Fixed(1e-7), End::Steps(1))
            .material(Material::new("steel", 7800.0, 2.0e11, 0.3))
            .body(Body::new(
                mesh("plate_hole.msh", Some("plate"), MeshSeeding::Grid),
                "steel",
            ))
    };
    let nodes = region_nodes(
        plate()
            .boundary(group("plate_hole.msh", "left"))
            .boundary(group("plate_hole.msh", "hole"))
            .boundary(Boundary::new(
                "box",
                DVec2::new(0.0, 0.0),
                DVec2::new(0.0, 0.2),
                Condition::Fixed,
            )),
    );
    assert_eq!(nodes[0], nodes[2], "the left edge against a box on x = 0");
    assert_eq!(nodes[0].len(), 21);
    let hole = &nodes[1];
    assert!(hole.len() >= 20, "{} nodes on the hole's rim", hole.len());
    for &n in hole {
        let x = grid.node_position(n as usize);
        let off = ((x - DVec2::new(0.2, 0.1)).length() - 0.05).abs();
        assert!(
            off <= 0.5 * h + 2e-6,
            "node {n} at {x:?} is {off} from the rim"
        );
    }
    // 3D: the block's bottom face is the nodes a box on z = 0 holds.
    let grid = Grid::<Three> {
        min: DVec3::splat(-0.05),
        spacing: 0.025,
        cells: [12, 12, 8],
        graded: None,
        window: None,
    };
    let block = Spec::new(grid)
        .time(TimeStep::Fixed(1e-7), End::Steps(1))
        .material(Material::new("steel", 7800.0, 2.0e11, 0.3))
        .body(Body::new(
            mesh("block.msh", Some("block"), MeshSeeding::Grid),
            "steel",
        ))
        .boundary(group("block.msh", "bottom"))
        .boundary(Boundary::new(
            "box",
            DVec3::ZERO,
            DVec3::new(0.2, 0.2, 0.0),
            Condition::Fixed,
        ));
    let nodes = region_nodes(block);
    assert_eq!(nodes[0], nodes[1]);
    assert_eq!(nodes[0].len(), 81);
}

#[test]
fn a_boundary_group_that_is_not_there_lists_those_that_are() {
    let path = repo_root().join("tests/fixtures/meshes/plate_hole.msh");
    let raw = read_raw_mesh(&path).unwrap();
    let e = boundary_facets(&raw, "plate_hole.msh", "top").unwrap_err();
    assert!(e.message.contains("\"left\", \"right\", \"hole\""), "{e}");
    let e = boundary_facets(&raw, "plate_hole.msh", "plate").unwrap_err();
    assert!(e.message.contains("a region of the body"), "{e}");
}
