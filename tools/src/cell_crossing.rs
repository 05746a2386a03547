//! Whether energy a run created may be the multilinear tents' cell-crossing error: the
//! pipeline's basis is `basis/linear`, whose weight gradients jump at every cell face a
//! particle crosses, and particles have moved more than a cell. The energy watch's warning
//! then names it (SCENES.md, "Impact and waves").

use fractum_engine::prelude::*;
use fractum_scene::PipelineSummary;

/// The particles' positions when the run started stepping, by particle id, and the smallest
/// cell width: kept only for a pipeline on `basis/linear`.
pub struct StartPositions {
    by_id: Vec<Option<[f64; 3]>>,
    smallest_cell: f64,
}

impl StartPositions {
    /// The particles' positions now, when `pipeline`'s basis is `basis/linear`.
    pub fn of_linear_basis(world: &World, pipeline: &PipelineSummary) -> Option<Self> {
        let linear = pipeline.by_stage.iter().any(|(stage, names)| {
            *stage == Stage::Basis && names.iter().any(|n| n == "basis/linear")
        });
        if !linear {
            return None;
        }
        let (positions, smallest_cell) = positions_and_cell(world);
        let mut by_id = Vec::new();
        for (id, x) in positions {
            let id = id as usize;
            if by_id.len() <= id {
                by_id.resize(id + 1, None);
            }
            by_id[id] = Some(x);
        }
        Some(Self {
            by_id,
            smallest_cell,
        })
    }

    /// The largest distance a particle has moved since the start, in cells of the smallest
    /// width.
    pub fn cells_moved(&self, world: &World) -> f64 {
        let (positions, _) = positions_and_cell(world);
        let farthest = positions
            .iter()
            .filter_map(|(id, x)| {
                let start = self.by_id.get(*id as usize).copied().flatten()?;
                Some(
                    (0..3)
                        .map(|a| (x[a] - start[a]).powi(2))
                        .sum::<f64>()
                        .sqrt(),
                )
            })
            .fold(0.0, f64::max);
        farthest / self.smallest_cell
    }
}

/// Every particle's id and position (zero beyond the dimension), and the grid's smallest cell
/// width.
fn positions_and_cell(world: &World) -> (Vec<(u32, [f64; 3])>, f64) {
    match *world.resource::<Dimension>() {
        Dimension::Two => positions_and_cell_in::<Two>(world),
        Dimension::Three => positions_and_cell_in::<Three>(world),
    }
}

fn positions_and_cell_in<D: Dim>(world: &World) -> (Vec<(u32, [f64; 3])>, f64) {
    let grid = world.resource::<Grid<D>>();
    let smallest = (0..D::N)
        .flat_map(|a| (0..grid.cells[a]).map(move |i| grid.cell_width(a, i)))
        .fold(f64::INFINITY, f64::min);
    // No particle component registered yet: no particle to follow.
    let Some(mut query) = world.try_query_filtered::<(&ParticleId, &Position<D>), With<Particle>>()
    else {
        return (Vec::new(), smallest);
    };
    let positions = query
        .iter(world)
        .map(|(id, x)| {
            let mut out = [0.0; 3];
            for (a, value) in out.iter_mut().enumerate().take(D::N) {
                *value = x.0[a];
            }
            (id.0, out)
        })
        .collect();
    (positions, smallest)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fractum_engine::testing::{spawn_particle, tiny_world};

    fn summary(basis: &str) -> PipelineSummary {
        PipelineSummary {
            by_stage: vec![(Stage::Basis, vec![basis.to_string()])],
        }
    }

    /// Kept for the tents only; the distance is the farthest particle's, in cells.
    #[test]
    fn the_farthest_move_is_measured_in_cells_under_the_tents_only() {
        let mut world = tiny_world::<Two>(8, 0.5, 1e-3);
        world.insert_resource(Dimension::Two);
        let still = spawn_particle(&mut world, DVec2::new(1.0, 1.0), DVec2::ZERO, 1.0, 0.1);
        let moving = spawn_particle(&mut world, DVec2::new(2.0, 1.0), DVec2::ZERO, 1.0, 0.1);
        assert!(StartPositions::of_linear_basis(&world, &summary("basis/bspline")).is_none());
        let start = StartPositions::of_linear_basis(&world, &summary("basis/linear")).unwrap();
        world.get_mut::<Position<Two>>(moving).unwrap().0 = DVec2::new(2.3, 1.4);
        world.get_mut::<Position<Two>>(still).unwrap().0 = DVec2::new(1.1, 1.0);
        assert!((start.cells_moved(&world) - 1.0).abs() < 1e-12);
    }
}
