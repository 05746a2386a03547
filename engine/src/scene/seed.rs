//! Seeding bodies with particles: cell by cell, at sub-cell centres or Gauss points.

use super::format::{Placement, Shape};
use crate::dim::{Vector, cell_volume};
use crate::resources::Grid;

/// True when `x` lies inside `shape` (boundary included for rectangles and disks; even-odd rule
/// for polygons).
pub fn point_in_shape(shape: &Shape, x: Vector) -> bool {
    match shape {
        Shape::Rectangle { min, max } => {
            x.x >= min.0 && x.x <= max.0 && x.y >= min.1 && x.y <= max.1
        }
        Shape::Disk { center, radius } => {
            (x - Vector::new(center.0, center.1)).length_squared() <= radius * radius
        }
        Shape::Polygon { vertices } => {
            let mut inside = false;
            let n = vertices.len();
            for k in 0..n {
                let a = Vector::new(vertices[k].0, vertices[k].1);
                let b = Vector::new(vertices[(k + 1) % n].0, vertices[(k + 1) % n].1);
                if (a.y > x.y) != (b.y > x.y) {
                    let crossing = a.x + (x.y - a.y) * (b.x - a.x) / (b.y - a.y);
                    if x.x < crossing {
                        inside = !inside;
                    }
                }
            }
            inside
        }
    }
}

/// Axis-aligned bounding box of a shape.
pub fn shape_bounds(shape: &Shape) -> (Vector, Vector) {
    match shape {
        Shape::Rectangle { min, max } => (Vector::new(min.0, min.1), Vector::new(max.0, max.1)),
        Shape::Disk { center, radius } => {
            let c = Vector::new(center.0, center.1);
            (c - Vector::splat(*radius), c + Vector::splat(*radius))
        }
        Shape::Polygon { vertices } => vertices.iter().fold(
            (
                Vector::splat(f64::INFINITY),
                Vector::splat(f64::NEG_INFINITY),
            ),
            |(lo, hi), v| {
                let v = Vector::new(v.0, v.1);
                (lo.min(v), hi.max(v))
            },
        ),
    }
}

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
    }
}

/// Positions and volumes of the particles of `shape`, cell by cell in row-major cell order.
///
/// Returns an empty list when `placement` does not support `per_direction` points (checked by
/// the scene validation before seeding).
pub fn particles_in_shape(
    shape: &Shape,
    grid: &Grid,
    per_direction: u32,
    placement: Placement,
) -> Vec<(Vector, f64)> {
    let Some(points) = cell_points(placement, per_direction) else {
        return Vec::new();
    };
    let (lo, hi) = shape_bounds(shape);
    let h = grid.spacing;
    let first = ((lo - grid.min) / h).floor().max(Vector::ZERO);
    let last = ((hi - grid.min) / h).ceil();
    let (i0, j0) = (first.x as usize, first.y as usize);
    let i1 = (last.x.max(0.0) as usize).min(grid.cells[0]);
    let j1 = (last.y.max(0.0) as usize).min(grid.cells[1]);
    let quarter_cell = cell_volume(h) / 4.0;
    let mut out = Vec::new();
    for j in j0..j1 {
        for i in i0..i1 {
            let centre = grid.min + (Vector::new(i as f64, j as f64) + 0.5) * h;
            for &(sy, wy) in &points {
                for &(sx, wx) in &points {
                    let x = centre + Vector::new(sx, sy) * (0.5 * h);
                    if point_in_shape(shape, x) {
                        out.push((x, quarter_cell * wx * wy));
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_grid() -> Grid {
        Grid {
            min: Vector::ZERO,
            spacing: 0.25,
            cells: [4, 4],
        }
    }

    #[test]
    fn rectangle_filling_whole_cells_has_exact_volume() {
        let shape = Shape::Rectangle {
            min: (0.0, 0.0),
            max: (0.5, 1.0),
        };
        for placement in [Placement::Uniform, Placement::Gauss] {
            for n in 1..=3 {
                let particles = particles_in_shape(&shape, &unit_grid(), n, placement);
                assert_eq!(particles.len(), (8 * n * n) as usize);
                let volume: f64 = particles.iter().map(|p| p.1).sum();
                assert!((volume - 0.5).abs() < 1e-14, "{placement:?} {n}: {volume}");
            }
        }
    }

    #[test]
    fn polygon_and_disk_membership() {
        let triangle = Shape::Polygon {
            vertices: vec![(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)],
        };
        assert!(point_in_shape(&triangle, Vector::new(0.2, 0.2)));
        assert!(!point_in_shape(&triangle, Vector::new(0.6, 0.6)));
        let disk = Shape::Disk {
            center: (0.5, 0.5),
            radius: 0.25,
        };
        assert!(point_in_shape(&disk, Vector::new(0.5, 0.74)));
        assert!(!point_in_shape(&disk, Vector::new(0.3, 0.3)));
        assert_eq!(shape_bounds(&disk).1, Vector::new(0.75, 0.75));
    }
}
