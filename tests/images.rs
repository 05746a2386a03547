//! Bodies from images (`Image(file: .., voxel_size: .., phases: [..])`): pictures and stacks
//! in every format read to the same voxels, and those voxels seed the particles of the built-in
//! shapes they were drawn from. The fixtures in `tests/fixtures/images/` were written by Pillow
//! and tifffile (`make_images.py` beside them).

use bevy_ecs::query::With;
use fractum_engine::components::{Damage, InitialVolume, MaterialId, Particle, Position};
use fractum_engine::prelude::*;
use fractum_engine::simulation::{End, TimeStep};
use fractum_scene::image::{Phase, VoxelFrame, VoxelImage, read_image};
use fractum_scene::{
    Body, Placement, SceneFile, Shape, Spec, build_simulation, particles_in_shape,
};
use fractum_suite::{build_elastic, repo_root};
use glam::{DVec2, DVec3};
use std::f64::consts::PI;
use std::sync::Arc;

/// Voxel width of the fixtures: 40 voxels across the unit square or cube.
const H: f64 = 0.025;

fn window(grey_min: f64, grey_max: f64) -> Phase {
    Phase {
        grey_min,
        grey_max,
        material: None,
    }
}

fn read(name: &str, phases: &[Phase]) -> VoxelImage {
    let path = repo_root().join("tests/fixtures/images").join(name);
    let frame = VoxelFrame {
        origin: DVec3::ZERO,
        spacing: DVec3::splat(H),
    };
    read_image(&path, name, frame, phases).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn grid2() -> Grid<Two> {
    Grid::<Two> {
        min: DVec2::ZERO,
        spacing: H,
        cells: [40; 2],
        graded: None,
        window: None,
    }
}

fn grid3() -> Grid<Three> {
    Grid::<Three> {
        min: DVec3::ZERO,
        spacing: H,
        cells: [40; 3],
        graded: None,
        window: None,
    }
}

fn total<V>(particles: &[(V, f64)]) -> f64 {
    particles.iter().map(|p| p.1).sum()
}

#[test]
fn a_disk_reads_alike_from_png_and_from_1_bit_16_bit_and_float_tiff() {
    let pictures = [
        read("disk.png", &[window(100.0, 255.0)]),
        read("disk_1bit.tif", &[window(1.0, 1.0)]),
        read("disk_16bit.tif", &[window(25_000.0, 65_535.0)]),
        read("disk_float.tif", &[window(0.5, 1.0)]),
    ];
    let disk = Shape::Disk {
        center: DVec2::splat(0.5),
        radius: 0.3,
    };
    // One particle per voxel, at the voxel's centre: the built-in disk's particles with one
    // particle per cell, since each pixel was drawn by the disk's test at its centre.
    let lattice = particles_in_shape(&disk, &grid2(), 1, Placement::Uniform, 1.0);
    for picture in pictures {
        assert_eq!(picture.dimension(), 2, "{}", picture.file);
        assert_eq!(picture.size(), [40, 40, 1]);
        let shape = Shape::Image(Arc::new(picture));
        let seeded = particles_in_shape(&shape, &grid2(), 1, Placement::Uniform, 1.0);
        assert!(seeded == lattice, "the particles differ from the disk's");
        let area = total(&seeded);
        let error = area / (PI * 0.09) - 1.0;
        assert!(error.abs() < 0.01, "area {area}: {error:+e} from πr²");
    }
}

#[test]
fn a_plate_with_a_hole_reads_as_the_difference_of_a_square_and_a_disk() {
    let picture = Shape::Image(Arc::new(read(
        "plate_with_hole.png",
        &[window(128.0, 255.0)],
    )));
    let plate = Shape::Difference(
        Box::new(Shape::Rectangle {
            min: DVec2::ZERO,
            max: DVec2::ONE,
        }),
        Box::new(Shape::Disk {
            center: DVec2::splat(0.5),
            radius: 0.2,
        }),
    );
    let seeded = particles_in_shape(&picture, &grid2(), 1, Placement::Uniform, 1.0);
    let lattice = particles_in_shape(&plate, &grid2(), 1, Placement::Uniform, 1.0);
    assert!(seeded == lattice, "the particles differ from the plate's");
    let area = total(&seeded);
    let error = area / (1.0 - PI * 0.04) - 1.0;
    assert!(error.abs() < 0.01, "area {area}: {error:+e} from 1 − πr²");
}

#[test]
fn sub_voxels_split_each_voxel_s_area_and_stay_inside_it() {
    let shape = Shape::Image(Arc::new(read("disk.png", &[window(100.0, 255.0)])));
    let one = particles_in_shape(&shape, &grid2(), 1, Placement::Uniform, 1.0);
    for (n, placement) in [(2, Placement::Uniform), (3, Placement::Gauss)] {
        let many = particles_in_shape(&shape, &grid2(), n, placement, 0.5);
        assert_eq!(many.len(), one.len() * (n * n) as usize);
        let (a, b) = (total(&many), 0.5 * total(&one));
        assert!((a - b).abs() < 1e-12 * b, "{a} against {b}");
        // Each voxel's points lie around its centre, within half a voxel.
        for (k, (x, _)) in many.iter().enumerate() {
            let centre = one[k / (n * n) as usize].0;
            assert!(
                (*x - centre).abs().max_element() < 0.5 * H,
                "{x} from {centre}"
            );
        }
    }
}

#[test]
fn rows_run_up_from_the_bottom_of_the_picture_and_slices_along_z() {
    // Grey = 100 × slice + 10 × row from the top + column, 4 columns by 3 rows.
    let phases: Vec<Phase> = (0..2)
        .flat_map(|k| (0..3).flat_map(move |r| (0..4).map(move |c| (k, r, c))))
        .map(|(k, r, c)| {
            let g = f64::from(100 * k + 10 * r + c);
            window(g, g)
        })
        .collect();
    // Phase 12 × slice + 4 × row from the top + column holds that voxel's grey alone.
    let stack = read("orientation_stack.tif", &phases);
    let picture = read("orientation.png", &phases[..12]);
    let at = |i: f64, j: f64| DVec3::new((i + 0.5) * H, (j + 0.5) * H, 0.0);
    // The top row of the file (row 0) is the highest row of voxels.
    assert_eq!(picture.phase_at(at(0.0, 2.0)), Some(0));
    assert_eq!(picture.phase_at(at(3.0, 2.0)), Some(3));
    assert_eq!(picture.phase_at(at(1.0, 0.0)), Some(4 * 2 + 1));
    assert_eq!(picture.phase_at(at(4.0, 0.0)), None);
    assert_eq!(
        picture.bounds(),
        (DVec3::ZERO, DVec3::new(4.0 * H, 3.0 * H, 0.0))
    );
    // The second page of the stack is the upper slice.
    assert_eq!(
        stack.phase_at(at(1.0, 0.0) + DVec3::Z * H),
        Some(12 + 4 * 2 + 1)
    );
    assert_eq!(stack.phase_at(at(2.0, 1.0)), Some(4 + 2));
    assert_eq!(stack.phase_at(at(2.0, 1.0) - DVec3::Z * H), None);
}

/// The voxel centres of the fixtures' sphere of radius `r`, counted by the built-in sphere.
fn voxels_in_sphere(r: f64) -> usize {
    let sphere = Shape::Sphere {
        center: DVec3::splat(0.5),
        radius: r,
    };
    particles_in_shape(&sphere, &grid3(), 1, Placement::Uniform, 1.0).len()
}

#[test]
fn a_tiff_stack_and_its_numbered_png_slices_give_the_sphere_and_its_core() {
    let phases = [window(100.0, 140.0), window(200.0, 255.0)];
    let stack = read("sphere_stack.tif", &phases);
    let slices = read("sphere_slices/sphere_##.png", &phases);
    assert_eq!(stack.dimension(), 3);
    assert_eq!(slices.size(), [40, 40, 40]);
    let core = voxels_in_sphere(0.15);
    assert_eq!(stack.voxel_counts(), [voxels_in_sphere(0.3) - core, core]);
    let seed = |image: VoxelImage| {
        let shape = Shape::Image(Arc::new(image));
        particles_in_shape(&shape, &grid3(), 1, Placement::Uniform, 1.0)
    };
    let (from_stack, from_slices) = (seed(stack), seed(slices));
    assert!(from_stack == from_slices, "stack and slices differ");
    let sphere = Shape::Sphere {
        center: DVec3::splat(0.5),
        radius: 0.3,
    };
    let lattice = particles_in_shape(&sphere, &grid3(), 1, Placement::Uniform, 1.0);
    assert!(
        from_stack == lattice,
        "the particles differ from the sphere's"
    );
    let volume = total(&from_stack);
    let error = volume / (4.0 / 3.0 * PI * 0.027) - 1.0;
    assert!(
        error.abs() < 0.01,
        "volume {volume}: {error:+e} from 4πr³/3"
    );
}

/// Position, volume and material of every particle, sorted by position.
fn particles(world: &mut bevy_ecs::world::World) -> Vec<([u64; 2], f64, u16)> {
    let mut query =
        world.query_filtered::<(&Position<Two>, &InitialVolume, &MaterialId), With<Particle>>();
    let mut all: Vec<_> = query
        .iter(world)
        .map(|(x, v, m)| ([x.0.x.to_bits(), x.0.y.to_bits()], v.0, m.0))
        .collect();
    all.sort_by_key(|p| p.0);
    all
}

/// The shipped scene `name` with each `from` replaced by `to`, built from the scenes folder.
fn variant(name: &str, edits: &[(&str, &str)]) -> fractum_scene::Built {
    let path = repo_root().join("scenes").join(name);
    let mut text = std::fs::read_to_string(&path).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{name} has no `{from}`");
        text = text.replace(from, to);
    }
    let file = SceneFile::parse(&path.to_string_lossy(), text).unwrap();
    build_simulation(&file, &fractum_systems::stock_registry()).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_two_phase_picture_seeds_the_plate_and_inclusion_of_its_built_in_twin() {
    let mut image = variant(
        "stiff_inclusion_image.ron",
        &[("particles_per_cell: 2", "particles_per_cell: 1")],
    );
    let mut built_in = variant(
        "stiff_inclusion.ron",
        &[("placement: Gauss,", "particles_per_cell: 1,")],
    );
    let seeded = particles(&mut image.simulation.world);
    assert_eq!(seeded.len(), 80 * 40);
    let steel = seeded.iter().filter(|p| p.2 == 1).count();
    assert!(
        steel > 0 && steel < seeded.len() / 10,
        "{steel} steel particles"
    );
    assert!(
        seeded == particles(&mut built_in.simulation.world),
        "the picture's particles or materials differ from the plate's and the disk's"
    );
}

#[test]
fn an_image_marks_cracks_and_crops_by_its_voxels() {
    let disk = Shape::Image(Arc::new(read("disk.png", &[window(100.0, 255.0)])));
    let square = Shape::Rectangle {
        min: DVec2::ZERO,
        max: DVec2::ONE,
    };
    // As a later operand it only removes: the square's lattice less the disk's 448 pixels.
    let holed = Shape::Difference(Box::new(square.clone()), Box::new(disk.clone()));
    let seeded = particles_in_shape(&holed, &grid2(), 1, Placement::Uniform, 1.0);
    assert_eq!(seeded.len(), 40 * 40 - 448);
    // As a crack, it fails the particles in its voxels.
    let mut body = Body::new(square, "rock");
    body.particles_per_cell = 1;
    body.cracks = vec![disk];
    let built = build_elastic(
        Spec::new(grid2())
            .time(TimeStep::Fixed(1e-6), End::Steps(1))
            .material(Material::new("rock", 2000.0, 1.0e9, 0.25))
            .body(body),
    );
    let mut world = built.simulation.world;
    let mut query = world.query_filtered::<&Damage, With<Particle>>();
    let failed = query.iter(&world).filter(|d| d.0 == 1.0).count();
    assert_eq!(failed, 448);
}

#[test]
fn origin_and_slice_spacing_place_the_voxels() {
    let path = repo_root().join("tests/fixtures/images/orientation_stack.tif");
    let frame = VoxelFrame {
        origin: DVec3::new(1.0, -2.0, 0.5),
        spacing: DVec3::new(0.1, 0.1, 0.3),
    };
    let stack = read_image(&path, "orientation_stack.tif", frame, &[window(0.0, 255.0)]).unwrap();
    let (lo, hi) = stack.bounds();
    assert_eq!(lo, DVec3::new(1.0, -2.0, 0.5));
    assert!(
        (hi - DVec3::new(1.4, -1.7, 1.1)).abs().max_element() < 1e-12,
        "{hi}"
    );
    assert_eq!(stack.voxel_volume(), 0.1 * 0.1 * 0.3);
    let shape = Shape::Image(Arc::new(stack));
    let rule = [(0.0, 2.0)];
    let particles = shape.own_particles(1, &rule);
    assert_eq!(particles.len(), 24);
    // The first voxel's centre, then the next along x.
    assert!((particles[0].0 - DVec3::new(1.05, -1.95, 0.65)).length() < 1e-12);
    assert!((particles[1].0 - DVec3::new(1.15, -1.95, 0.65)).length() < 1e-12);
    assert!((particles[23].0 - DVec3::new(1.35, -1.75, 0.95)).length() < 1e-12);
}
