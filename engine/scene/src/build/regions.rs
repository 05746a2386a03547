//! The world builder's boundary regions: each region's nodes (a box, or within half a cell of
//! a boundary group's facets) and the velocity it holds them at.

use crate::SceneError;
use crate::mesh::Facet;
use crate::spec::{Boundary, Condition, Spec};
use fractum_engine::boundary::{BoundaryConditions, BoundaryRegion, PiecewiseLinear};
use fractum_engine::dim::{Dim, Lattice, VectorOps, lattice_range};
use fractum_engine::resources::Grid;

/// The scene's boundary regions, each with its nodes and prescribed velocities.
pub(super) fn boundary_conditions<D: Dim>(
    spec: &Spec<D>,
) -> Result<BoundaryConditions, SceneError> {
    let regions = spec
        .boundaries
        .iter()
        .enumerate()
        .map(|(r, region)| boundary_region(spec, r, region))
        .collect::<Result<_, _>>()?;
    Ok(BoundaryConditions {
        regions,
        measured_nodes: None,
    })
}

/// Region `r`'s nodes and the velocity components it holds.
fn boundary_region<D: Dim>(
    spec: &Spec<D>,
    r: usize,
    region: &Boundary<D>,
) -> Result<BoundaryRegion, SceneError> {
    let nodes = region_nodes(&spec.grid, region);
    // A rank's world may hold none of a region's nodes; the scene must have some.
    if nodes.is_empty()
        && (spec.grid.window.is_none() || region_nodes(&spec.grid.whole(), region).is_empty())
    {
        let what = match region.facets {
            Some(_) => "no grid node lies within half a cell of this boundary group",
            None => "no grid node lies in this box",
        };
        return Err(spec.source.error(&format!("boundaries[{r}].nodes"), what));
    }
    let rest = || Some(PiecewiseLinear::constant(0.0));
    let velocity = match &region.condition {
        Condition::Fixed => std::array::from_fn(|a| if a < D::N { rest() } else { None }),
        Condition::Roller { normal } => {
            std::array::from_fn(|a| if a == *normal { rest() } else { None })
        }
        // Checked by `Spec::check`: each given list is a valid function.
        Condition::Velocity(components) => std::array::from_fn(|a| {
            components[a]
                .clone()
                .and_then(|points| PiecewiseLinear::new(points).ok())
        }),
    };
    Ok(BoundaryRegion {
        name: region.name.clone(),
        nodes,
        velocity,
    })
}

/// The indices of the held nodes of `grid` in `region`: within its box, or within half a cell
/// of its facets.
fn region_nodes<D: Dim>(grid: &Grid<D>, region: &Boundary<D>) -> Vec<u32> {
    let tol = 1e-9 * grid.spacing;
    match &region.facets {
        Some(facets) => nodes_near_facets(grid, &facets.facets),
        None => (0..grid.node_count())
            .filter(|&i| {
                let x = grid.node_position(i);
                (0..D::N).all(|a| x[a] >= region.min[a] - tol && x[a] <= region.max[a] + tol)
            })
            .map(|i| i as u32)
            .collect(),
    }
}

/// The grid nodes within half a cell (the smallest width of the cells around the node) of any
/// of `facets`, in index order: each facet looks only at the nodes of its own bounding box.
fn nodes_near_facets<D: Dim>(grid: &Grid<D>, facets: &[Facet]) -> Vec<u32> {
    let mut nodes = Vec::new();
    for facet in facets {
        let (lo, hi) = facet.bounds();
        // The nodes of the cells holding the facet's box, and one cell more each way: half a
        // cell of reach.
        let reach = |a: usize, x: f64, up: bool| {
            let x = x.clamp(grid.min[a], grid.coordinate(a, grid.cells[a]));
            let cell = grid
                .axis_cell(a, x)
                .unwrap_or(if up { grid.cells[a] - 1 } else { 0 });
            if up {
                (cell + 2).min(grid.cells[a])
            } else {
                cell.saturating_sub(1)
            }
        };
        let first = D::Cell::from_fn(|a| reach(a, lo[a], false));
        let end = D::Cell::from_fn(|a| reach(a, hi[a], true) + 1);
        for node in lattice_range(first, end) {
            let x = grid.lattice_position(node);
            let half = 0.5 * grid.smallest_width_near(x);
            if facet.distance(x.to_3d().into()) <= half
                && let Some(index) = grid.held_node_index(node)
            {
                nodes.push(index as u32);
            }
        }
    }
    nodes.sort_unstable();
    nodes.dedup();
    nodes
}

pub(super) fn describe_condition<D: Dim>(condition: &Condition) -> String {
    match condition {
        Condition::Fixed => "fixed".into(),
        Condition::Roller { normal } => format!("roller, {} held", D::AXES[*normal]),
        Condition::Velocity(components) => {
            let given: Vec<&str> = (0..D::N)
                .filter(|a| components[*a].is_some())
                .map(|a| D::AXES[a])
                .collect();
            format!("prescribed velocity ({})", given.join(", "))
        }
    }
}
