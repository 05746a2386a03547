//! Radius searches over point sets with a kd-tree (kiddo), in either dimension (not a system).
//!
//! kiddo's trees take the dimension as a const parameter, which generic code cannot spell as
//! `D::N`, so [`Spatial`] picks the tree type for each dimension once; code generic over
//! `D: Spatial` stays monomorphic.

use fractum_engine::prelude::*;
use kiddo::{ImmutableKdTree, SquaredEuclidean};

/// A dimension with a kd-tree for radius searches.
pub trait Spatial: Dim {
    /// The tree over points of this dimension.
    type Tree: Send + Sync;

    /// A tree over `points` (item `k` is `points[k]`).
    fn tree(points: &[Self::Vector]) -> Self::Tree;

    /// Appends to `out` the items within `radius` of `x` (boundary included), unsorted.
    fn within(tree: &Self::Tree, x: Self::Vector, radius: f64, out: &mut Vec<u32>);
}

/// Fills `candidates` with the rows within `radius` of each particle, from a fresh kd-tree,
/// each sorted once here so that the every-step filtering keeps them sorted.
pub fn build_candidates<D: Spatial>(
    positions: &[Position<D>],
    radius: f64,
    candidates: &mut Neighbourhoods,
) {
    let points: Vec<D::Vector> = positions.iter().map(|p| p.0).collect();
    let tree = D::tree(&points);
    candidates.fill_rows(points.len(), radius, |p, out| {
        let start = out.len();
        D::within(&tree, points[p], radius, out);
        out[start..].sort_unstable();
    });
}

macro_rules! kiddo_spatial {
    ($dim:ty, $n:expr) => {
        impl Spatial for $dim {
            type Tree = ImmutableKdTree<f64, $n>;

            fn tree(points: &[Self::Vector]) -> Self::Tree {
                let points: Vec<[f64; $n]> = points.iter().map(|p| p.to_array()).collect();
                ImmutableKdTree::new_from_slice(&points)
            }

            fn within(tree: &Self::Tree, x: Self::Vector, radius: f64, out: &mut Vec<u32>) {
                out.extend(
                    tree.within_unsorted::<SquaredEuclidean>(&x.to_array(), radius * radius)
                        .into_iter()
                        .map(|n| n.item as u32),
                );
            }
        }
    };
}

kiddo_spatial!(Two, 2);
kiddo_spatial!(Three, 3);

#[cfg(test)]
mod tests {
    use super::*;

    fn sorted_within<D: Spatial>(points: &[D::Vector], x: D::Vector, r: f64) -> Vec<u32> {
        let tree = D::tree(points);
        let mut found = Vec::new();
        D::within(&tree, x, r, &mut found);
        found.sort_unstable();
        found
    }

    #[test]
    fn finds_the_points_within_the_radius_in_both_dimensions() {
        let points = [DVec2::ZERO, DVec2::new(0.5, 0.0), DVec2::new(1.0, 1.0)];
        assert_eq!(sorted_within::<Two>(&points, DVec2::ZERO, 0.5), vec![0, 1]);
        let points = [DVec3::ZERO, DVec3::new(0.0, 0.0, 0.6), DVec3::splat(0.3)];
        assert_eq!(
            sorted_within::<Three>(&points, DVec3::ZERO, 0.55),
            vec![0, 2]
        );
    }
}
