//! The validator's grid: uniform or graded along each axis, its refinement intervals, and a
//! cell count a process can hold.

use super::{MAX_CELLS, Validator};
use crate::SceneError;
use crate::format::*;
use fractum_engine::dim::{Dim, VectorOps};
use fractum_engine::resources::Grid;

impl<D: Dim> Validator<D> {
    pub(super) fn grid(&self, g: &GridSpec) -> Result<Grid<D>, SceneError> {
        if !(g.spacing.is_finite() && g.spacing > 0.0) {
            return Err(self.error("grid.spacing", "expected a positive spacing"));
        }
        let min = self.vector("grid.min", &g.min)?;
        let max = self.vector("grid.max", &g.max)?;
        if !min.is_finite() {
            return Err(self.error("grid.min", "expected finite coordinates"));
        }
        if !(max.is_finite() && (0..D::N).all(|a| max[a] > min[a])) {
            return Err(self.error("grid.max", "expected a corner above `min` along every axis"));
        }
        let mut cells = D::Cell::default();
        for a in 0..D::N {
            let length = max[a] - min[a];
            let count = length / g.spacing;
            if (count - count.round()).abs() > 1e-6 * count.max(1.0) {
                return Err(self.error(
                    "grid.max",
                    format!(
                        "the box must hold a whole number of cells: {length} / {} = {count} along {}",
                        g.spacing,
                        D::AXES[a]
                    ),
                ));
            }
            if count.round() > MAX_CELLS {
                return Err(self.error("grid.spacing", too_many_cells(count.round())));
            }
            cells[a] = count.round() as usize;
        }
        // The cap is on the whole grid: 10^5 cells along each of two axes is 10^10 cells.
        let total: f64 = (0..D::N).map(|a| cells[a] as f64).product();
        if total > MAX_CELLS {
            return Err(self.error("grid.spacing", too_many_cells(total)));
        }
        if g.refine.is_empty() {
            return Ok(Grid {
                min,
                spacing: g.spacing,
                cells,
                graded: None,
                window: None,
            });
        }
        if let Some(k) = g.refine.iter().position(|r| r.axis.index() >= D::N) {
            return Err(self.error(
                &format!("grid.refine[{k}].axis"),
                "a 2D grid has only the axes X and Y",
            ));
        }
        let coordinates: Vec<Vec<f64>> = (0..D::N)
            .map(|a| self.graded_axis(g, a, min[a], max[a]))
            .collect::<Result<_, _>>()?;
        let total = coordinates
            .iter()
            .try_fold(1usize, |n, c| n.checked_mul(c.len() - 1));
        if total.is_none_or(|n| n as f64 > MAX_CELLS) {
            let cells: f64 = coordinates.iter().map(|c| (c.len() - 1) as f64).product();
            return Err(self.error("grid.refine", too_many_cells(cells)));
        }
        Grid::graded(coordinates)
            .ok_or_else(|| self.error("grid.refine", "the node coordinates must increase"))
    }

    /// Node coordinates along axis `a` of a grid with refinement intervals: uniform at the
    /// grid's spacing between intervals and at each interval's own spacing inside it.
    /// One `grid.refine` interval: a positive spacing and bounds inside the grid, in order.
    fn check_refine_interval(
        &self,
        k: usize,
        r: &RefineSpec,
        lo: f64,
        hi: f64,
    ) -> Result<(), SceneError> {
        let field = |f: &str| format!("grid.refine[{k}].{f}");
        if !(r.spacing.is_finite() && r.spacing > 0.0) {
            return Err(self.error(&field("spacing"), "expected a positive spacing"));
        }
        if !(r.min.is_finite() && r.min >= lo && r.min < hi) {
            return Err(self.error(
                &field("min"),
                format!("expected a coordinate inside the grid, from {lo} to {hi}"),
            ));
        }
        if !(r.max.is_finite() && r.max > r.min && r.max <= hi) {
            return Err(self.error(
                &field("max"),
                format!("expected a coordinate above `min` and at most {hi}"),
            ));
        }
        Ok(())
    }

    fn graded_axis(
        &self,
        g: &GridSpec,
        a: usize,
        lo: f64,
        hi: f64,
    ) -> Result<Vec<f64>, SceneError> {
        let mut intervals: Vec<(usize, &RefineSpec)> = g
            .refine
            .iter()
            .enumerate()
            .filter(|(_, r)| r.axis.index() == a)
            .collect();
        for &(k, r) in &intervals {
            self.check_refine_interval(k, r, lo, hi)?;
        }
        intervals.sort_by(|x, y| x.1.min.total_cmp(&y.1.min));
        let mut nodes = vec![lo];
        let mut cursor = lo;
        // Appends the nodes of a segment ending at `end`, `step` apart; the segment must hold a
        // whole number of them. The last node is `end` itself, so nothing drifts.
        let segment = |nodes: &mut Vec<f64>, start: f64, end: f64, step: f64, field: &str| {
            let count = (end - start) / step;
            if (count - count.round()).abs() > 1e-6 * count.max(1.0) {
                return Err(self.error(
                    field,
                    format!(
                        "the segment from {start} to {end} along {} must hold a whole number of \
                         cells of {step}: it holds {count}",
                        D::AXES[a]
                    ),
                ));
            }
            let count = count.round() as usize;
            if count as f64 > MAX_CELLS {
                return Err(self.error(field, too_many_cells(count as f64)));
            }
            for i in 1..count {
                nodes.push(start + i as f64 * step);
            }
            if count > 0 {
                nodes.push(end);
            }
            Ok(())
        };
        for &(k, r) in &intervals {
            if r.min < cursor {
                return Err(self.error(
                    &format!("grid.refine[{k}].min"),
                    format!("overlaps another interval along {}", D::AXES[a]),
                ));
            }
            segment(
                &mut nodes,
                cursor,
                r.min,
                g.spacing,
                &format!("grid.refine[{k}].min"),
            )?;
            segment(
                &mut nodes,
                r.min,
                r.max,
                r.spacing,
                &format!("grid.refine[{k}].max"),
            )?;
            cursor = r.max;
        }
        segment(&mut nodes, cursor, hi, g.spacing, "grid.max")?;
        Ok(nodes)
    }
}

fn too_many_cells(cells: f64) -> String {
    format!(
        "the grid would have {cells:.3e} cells, more than the 10^8 a scene may have; use a larger spacing or a smaller box"
    )
}
