//! Seeding bodies with particles: cell by cell, at sub-cell centres or Gauss points; or a disk
//! in concentric rings.

use super::format::Placement;
use super::shape::Shape;
use fractum_engine::dim::{Dim, Lattice, VectorOps, cell_volume, lattice_range};
use fractum_engine::resources::Grid;

/// A body's seeds: each particle's position and volume.
pub(crate) type Seeds<D> = Vec<(<D as Dim>::Vector, f64)>;

/// Reference coordinates in [−1, 1] and weights (summing to 2) of the points along one direction.
pub fn cell_points(placement: Placement, per_direction: u32) -> Option<Vec<(f64, f64)>> {
    let n = per_direction as usize;
    match placement {
        Placement::Uniform => Some(
            (0..n)
                .map(|k| (-1.0 + (2.0 * k as f64 + 1.0) / n as f64, 2.0 / n as f64))
                .collect(),
        ),
        Placement::Gauss => match n {
            1 => Some(vec![(0.0, 2.0)]),
            2 => {
                let a = 1.0 / 3f64.sqrt();
                Some(vec![(-a, 1.0), (a, 1.0)])
            }
            3 => {
                let a = 0.6f64.sqrt();
                Some(vec![(-a, 5.0 / 9.0), (0.0, 8.0 / 9.0), (a, 5.0 / 9.0)])
            }
            _ => None,
        },
        Placement::Rings => None,
    }
}

/// A disk of `radius` about `center` as concentric rings `spacing` apart (adjusted so that a
/// whole number of rings fills the radius): ring `i` at radius `(i + ½) ℓ` holds
/// `max(1, round(2π r_i / ℓ))` particles that share its annulus's area equally, odd rings
/// turned by half a particle. In 2D, volumes for `thickness`.
pub fn rings_in_disk(
    center: [f64; 2],
    radius: f64,
    spacing: f64,
    thickness: f64,
) -> Vec<([f64; 2], f64)> {
    let rings = (radius / spacing).round().max(1.0) as usize;
    let step = radius / rings as f64;
    let mut out = Vec::new();
    for i in 0..rings {
        let r = (i as f64 + 0.5) * step;
        let count = ((std::f64::consts::TAU * r / step).round() as usize).max(1);
        let area = std::f64::consts::TAU * r * step;
        let turn = if i % 2 == 1 { 0.5 } else { 0.0 };
        for j in 0..count {
            let angle = std::f64::consts::TAU * (j as f64 + turn) / count as f64;
            let x = [center[0] + r * angle.cos(), center[1] + r * angle.sin()];
            out.push((x, area / count as f64 * thickness));
        }
    }
    out
}

/// Positions and volumes of the particles of `shape`, cell by cell in the order of cell
/// indices (first axis fastest), `per_direction` points along each axis of every cell.
/// In 2D the volumes are for the out-of-plane `thickness`.
///
/// A shape that places its own particles gives them instead (see [`Shape::own_particles`]):
/// a mesh seeded by `Elements` its elements' quadrature points of the rule of order
/// `per_direction`, a point set its file's particles, an image its voxels, each seeded like a
/// cell.
///
/// Returns an empty list when `placement` does not support `per_direction` points (checked by
/// the scene validation before seeding).
pub fn particles_in_shape<D: Dim>(
    shape: &Shape,
    grid: &Grid<D>,
    per_direction: u32,
    placement: Placement,
    thickness: f64,
) -> Vec<(D::Vector, f64)> {
    if shape.seeds_itself() {
        // A point file's volumes are the particles' own; a mesh's are areas in 2D.
        let scale = if shape.point_set().is_some() {
            1.0
        } else {
            thickness
        };
        // An image's voxels are seeded as the grid's cells are.
        let voxel_rule = cell_points(placement, per_direction).unwrap_or_default();
        return shape
            .own_particles(per_direction, &voxel_rule)
            .into_iter()
            .map(|(x, v)| (D::Vector::from_fn(|a| x[a]), v * scale))
            .collect();
    }
    if placement == Placement::Rings {
        let Shape::Disk { center, radius } = shape else {
            return Vec::new();
        };
        let (at, cells) = (grid.axis_cell(0, center.x), grid.cells[0]);
        let width = grid.cell_width(0, at.unwrap_or(0).min(cells.saturating_sub(1)));
        let spacing = width / f64::from(per_direction);
        return rings_in_disk([center.x, center.y], *radius, spacing, thickness)
            .into_iter()
            .map(|(x, v)| (D::Vector::from_fn(|a| x[a]), v))
            .collect();
    }
    let Some(points) = cell_points(placement, per_direction) else {
        return Vec::new();
    };
    let (lo, hi) = shape.bounds();
    let (lo, hi) = (D::Vector::from_fn(|a| lo[a]), D::Vector::from_fn(|a| hi[a]));
    if grid.is_graded() {
        return graded_particles(shape, grid, &points, lo, hi, thickness);
    }
    let h = grid.spacing;
    let first = ((lo - grid.min) / h).floor().max(D::Vector::ZERO);
    let last = ((hi - grid.min) / h).ceil();
    let first = D::Cell::from_fn(|a| first[a] as usize);
    let last = D::Cell::from_fn(|a| (last[a].max(0.0) as usize).min(grid.cells[a]));
    // Each point of the tensor-product rule stands for (h/2)^d times its weights.
    let sub_cell = cell_volume::<D>(h) / (1usize << D::N) as f64;
    let in_cell: Vec<D::Cell> =
        lattice_range(D::Cell::default(), D::Cell::from_fn(|_| points.len())).collect();
    let mut out = Vec::new();
    for cell in lattice_range(first, last) {
        let corner = D::Vector::from_fn(|a| cell[a] as f64);
        let centre = grid.min + (corner + D::Vector::splat(0.5)) * h;
        for k in &in_cell {
            let x = centre + D::Vector::from_fn(|a| points[k[a]].0) * (0.5 * h);
            if shape.contains(x.to_3d().into()) {
                let volume = (0..D::N).fold(sub_cell, |v, a| v * points[k[a]].1);
                out.push((x, volume * thickness));
            }
        }
    }
    out
}

/// The tensor-product points of every cell of a graded grid that fall inside `shape`: each cell
/// is the rule scaled to its own widths.
fn graded_particles<D: Dim>(
    shape: &Shape,
    grid: &Grid<D>,
    points: &[(f64, f64)],
    lo: D::Vector,
    hi: D::Vector,
    thickness: f64,
) -> Vec<(D::Vector, f64)> {
    let axis_range = |a: usize| {
        let clamp = |x: f64| x.clamp(grid.min[a], grid.coordinate(a, grid.cells[a]));
        let first = grid.axis_cell(a, clamp(lo[a])).unwrap_or(0);
        let last = grid
            .axis_cell(a, clamp(hi[a]))
            .map_or(grid.cells[a], |i| i + 1);
        (first, last)
    };
    let first = D::Cell::from_fn(|a| axis_range(a).0);
    let last = D::Cell::from_fn(|a| axis_range(a).1);
    let in_cell: Vec<D::Cell> =
        lattice_range(D::Cell::default(), D::Cell::from_fn(|_| points.len())).collect();
    let mut out = Vec::new();
    for cell in lattice_range(first, last) {
        let half = D::Vector::from_fn(|a| 0.5 * grid.cell_width(a, cell[a]));
        let centre = D::Vector::from_fn(|a| grid.coordinate(a, cell[a]) + half[a]);
        for k in &in_cell {
            let x = centre + D::Vector::from_fn(|a| points[k[a]].0 * half[a]);
            if shape.contains(x.to_3d().into()) {
                let volume = (0..D::N).fold(1.0, |v, a| v * half[a] * points[k[a]].1);
                out.push((x, volume * thickness));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use fractum_engine::dim::{Three, Two};
    use glam::{DVec2, DVec3};

    /// A ring disk holds exactly the disk's area, every particle inside it, the outermost ring's
    /// domains ending on the circle, and neighbours along each ring about one spacing apart.
    #[test]
    fn a_ring_disk_fills_the_disk_with_particles_one_spacing_apart() {
        let (centre, radius, spacing) = ([0.3, -0.2], 0.05, 0.0049);
        let rings = rings_in_disk(centre, radius, spacing, 0.01);
        let volume: f64 = rings.iter().map(|p| p.1).sum();
        let disk = std::f64::consts::PI * radius * radius * 0.01;
        assert!(
            (volume / disk - 1.0).abs() < 1e-12,
            "{volume} against {disk}"
        );
        // 10 rings 5 mm apart (the spacing adjusted to fill the radius).
        let step = radius / 10.0;
        let distance = |x: [f64; 2]| (x[0] - centre[0]).hypot(x[1] - centre[1]);
        let outermost = rings.iter().map(|p| distance(p.0)).fold(0.0, f64::max);
        assert!((outermost - (radius - 0.5 * step)).abs() < 1e-12);
        for (i, ring) in rings_by_radius(&rings, centre).iter().enumerate() {
            let r = (i as f64 + 0.5) * step;
            assert!(ring.iter().all(|&a| (distance(a) - r).abs() < 1e-12));
            if ring.len() > 2 {
                let chord = 2.0 * r * (std::f64::consts::PI / ring.len() as f64).sin();
                assert!(
                    (chord / step - 1.0).abs() < 0.15,
                    "ring {i}: {chord} m apart"
                );
            }
        }
    }

    fn rings_by_radius(particles: &[([f64; 2], f64)], centre: [f64; 2]) -> Vec<Vec<[f64; 2]>> {
        let mut rings: Vec<(f64, Vec<[f64; 2]>)> = Vec::new();
        for &(x, _) in particles {
            let r = (x[0] - centre[0]).hypot(x[1] - centre[1]);
            match rings.iter_mut().find(|(ring, _)| (ring - r).abs() < 1e-9) {
                Some((_, members)) => members.push(x),
                None => rings.push((r, vec![x])),
            }
        }
        rings.sort_by(|a, b| a.0.total_cmp(&b.0));
        rings.into_iter().map(|(_, members)| members).collect()
    }

    /// `Rings` seeds a disk at the grid's cell width over `particles_per_cell`, in 2D; the
    /// scene check refuses it on other shapes.
    #[test]
    fn rings_placement_seeds_a_disk_at_the_grid_s_spacing() {
        let grid = Grid::<Two> {
            min: DVec2::ZERO,
            spacing: 0.1,
            cells: [10, 10],
            graded: None,
            window: None,
        };
        let disk = Shape::Disk {
            center: DVec2::new(0.5, 0.5),
            radius: 0.2,
        };
        let seeded = particles_in_shape(&disk, &grid, 2, Placement::Rings, 1.0);
        assert_eq!(
            seeded.len(),
            rings_in_disk([0.5, 0.5], 0.2, 0.05, 1.0).len()
        );
        let volume: f64 = seeded.iter().map(|p| p.1).sum();
        assert!((volume - std::f64::consts::PI * 0.04).abs() < 1e-12);
        let square = Shape::Rectangle {
            min: DVec2::ZERO,
            max: DVec2::ONE,
        };
        assert!(particles_in_shape(&square, &grid, 2, Placement::Rings, 1.0).is_empty());
    }

    #[test]
    fn rectangle_filling_whole_cells_has_exact_volume() {
        let grid = Grid::<Two> {
            min: DVec2::ZERO,
            spacing: 0.25,
            cells: [4, 4],
            graded: None,
            window: None,
        };
        let shape = Shape::Rectangle {
            min: DVec2::ZERO,
            max: DVec2::new(0.5, 1.0),
        };
        for placement in [Placement::Uniform, Placement::Gauss] {
            for n in 1..=3 {
                let particles = particles_in_shape(&shape, &grid, n, placement, 1.0);
                assert_eq!(particles.len(), (8 * n * n) as usize);
                let volume: f64 = particles.iter().map(|p| p.1).sum();
                assert!((volume - 0.5).abs() < 1e-14, "{placement:?} {n}: {volume}");
            }
        }
        let thin = particles_in_shape(&shape, &grid, 2, Placement::Uniform, 0.1);
        let volume: f64 = thin.iter().map(|p| p.1).sum();
        assert!((volume - 0.05).abs() < 1e-15);
    }

    #[test]
    fn graded_cells_are_filled_each_at_its_own_size() {
        // x nodes 0, 0.5, 0.625, 0.75, 1: one coarse cell, then three fine; y uniform 0.5.
        let grid = Grid::<Two>::graded(vec![vec![0.0, 0.5, 0.625, 0.75, 1.0], vec![0.0, 0.5, 1.0]])
            .unwrap();
        let shape = Shape::Rectangle {
            min: DVec2::ZERO,
            max: DVec2::new(1.0, 1.0),
        };
        let particles = particles_in_shape(&shape, &grid, 2, Placement::Gauss, 1.0);
        assert_eq!(particles.len(), 4 * 4 * 2);
        let volume: f64 = particles.iter().map(|p| p.1).sum();
        assert!((volume - 1.0).abs() < 1e-14);
        // A particle of the coarse cell stands for 0.25 × 0.25, one of a fine cell for
        // 0.0625 × 0.25.
        let coarse = particles.iter().find(|p| p.0.x < 0.5).unwrap();
        let fine = particles.iter().find(|p| p.0.x > 0.5).unwrap();
        assert!((coarse.1 - 0.0625).abs() < 1e-15 && (fine.1 - 0.015625).abs() < 1e-15);
    }

    #[test]
    fn box_filling_whole_cells_has_exact_volume_in_3d() {
        let grid = Grid::<Three> {
            min: DVec3::ZERO,
            spacing: 0.25,
            cells: [4, 4, 4],
            graded: None,
            window: None,
        };
        let shape = Shape::Box {
            min: DVec3::ZERO,
            max: DVec3::new(0.5, 1.0, 0.25),
        };
        for placement in [Placement::Uniform, Placement::Gauss] {
            for n in 1..=3 {
                let particles = particles_in_shape(&shape, &grid, n, placement, 1.0);
                assert_eq!(particles.len(), (8 * n * n * n) as usize);
                let volume: f64 = particles.iter().map(|p| p.1).sum();
                assert!(
                    (volume - 0.125).abs() < 1e-15,
                    "{placement:?} {n}: {volume}"
                );
                assert!(particles.iter().all(|p| p.0.z > 0.0 && p.0.z < 0.25));
            }
        }
        // The first particles run along x first.
        let particles = particles_in_shape(&shape, &grid, 2, Placement::Uniform, 1.0);
        assert_eq!(particles[0].0, DVec3::splat(0.0625));
        assert_eq!(particles[1].0, DVec3::new(0.1875, 0.0625, 0.0625));
    }

    fn plate_and_hole() -> (Grid<Two>, Shape, Shape) {
        // A 1 × 0.5 plate, a hole of radius 0.1 at its centre: 16 cells across the hole.
        let grid = Grid::<Two> {
            min: DVec2::ZERO,
            spacing: 0.0125,
            cells: [80, 40],
            graded: None,
            window: None,
        };
        let plate = Shape::Rectangle {
            min: DVec2::ZERO,
            max: DVec2::new(1.0, 0.5),
        };
        let hole = Shape::Disk {
            center: DVec2::new(0.5, 0.25),
            radius: 0.1,
        };
        (grid, plate, hole)
    }

    #[test]
    fn a_plate_with_a_hole_is_the_plate_without_the_holes_particles() {
        let (grid, plate, hole) = plate_and_hole();
        let holed = Shape::Difference(Box::new(plate.clone()), Box::new(hole.clone()));
        for placement in [Placement::Uniform, Placement::Gauss] {
            let particles = particles_in_shape(&holed, &grid, 2, placement, 1.0);
            let expected: Vec<(DVec2, f64)> = particles_in_shape(&plate, &grid, 2, placement, 1.0)
                .into_iter()
                .filter(|p| !hole.contains(p.0.extend(0.0)))
                .collect();
            assert_eq!(particles, expected, "{placement:?}");
            let area: f64 = particles.iter().map(|p| p.1).sum();
            let exact = 0.5 - std::f64::consts::PI * 0.01;
            assert!(
                ((area - exact) / exact).abs() < 0.01,
                "{placement:?}: area {area}, analytic {exact}"
            );
        }
    }

    #[test]
    fn a_union_of_tiles_is_the_whole_and_an_intersection_their_overlap() {
        let (grid, plate, hole) = plate_and_hole();
        let left = Shape::Rectangle {
            min: DVec2::ZERO,
            max: DVec2::new(0.5, 0.5),
        };
        let right = Shape::Rectangle {
            min: DVec2::new(0.5, 0.0),
            max: DVec2::new(1.0, 0.5),
        };
        let seeded = |shape: &Shape| particles_in_shape(shape, &grid, 2, Placement::Gauss, 1.0);
        assert_eq!(
            seeded(&Shape::Union(vec![left.clone(), right.clone()])),
            seeded(&plate)
        );
        // The hole's right half: the disk and the right tile.
        let half = seeded(&Shape::Intersection(vec![hole.clone(), right]));
        let expected: Vec<(DVec2, f64)> =
            seeded(&hole).into_iter().filter(|p| p.0.x >= 0.5).collect();
        assert_eq!(half, expected);
        // Shapes that share no point seed nothing.
        let far = Shape::Disk {
            center: DVec2::new(0.9, 0.4),
            radius: 0.05,
        };
        assert!(seeded(&Shape::Intersection(vec![left, far])).is_empty());
    }

    #[test]
    fn an_octant_of_a_sphere_has_its_volume_in_3d() {
        let grid = Grid::<Three> {
            min: DVec3::splat(-0.5),
            spacing: 0.025,
            cells: [40, 40, 40],
            graded: None,
            window: None,
        };
        let octant = Shape::Intersection(vec![
            Shape::Box {
                min: DVec3::ZERO,
                max: DVec3::splat(0.5),
            },
            Shape::Sphere {
                center: DVec3::ZERO,
                radius: 0.4,
            },
        ]);
        let particles = particles_in_shape(&octant, &grid, 2, Placement::Gauss, 1.0);
        let volume: f64 = particles.iter().map(|p| p.1).sum();
        let exact = std::f64::consts::PI * 0.4f64.powi(3) / 6.0;
        assert!(
            ((volume - exact) / exact).abs() < 0.01,
            "{volume} against {exact}"
        );
        assert!(particles.iter().all(|p| p.0.min_element() > 0.0));
    }
}
