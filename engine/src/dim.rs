//! Dimension-specific math, in one place.
//!
//! Fractum runs in 2D plane strain today. Everything that knows the number of space dimensions
//! (vector and tensor types, the symmetric stress/strain representation with its out-of-plane
//! component, principal values, grid cell arithmetic helpers) lives here so that moving to 3D is
//! a contained change: swap these aliases and the few functions below.

use serde::{Deserialize, Serialize};

/// Number of space dimensions of the simulation.
pub const DIM: usize = 2;

/// A position, velocity, force or gradient vector.
pub type Vector = glam::DVec2;

/// A full (non-symmetric) second-order tensor, e.g. a velocity or deformation gradient.
pub type Matrix = glam::DMat2;

/// A symmetric second-order tensor in plane strain: the in-plane components plus `zz`.
///
/// Stress and strain both use it. In plane strain the out-of-plane strain is zero but the
/// out-of-plane stress is not, and it enters the energy and the mean stress, so it is kept.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SymTensor {
    /// xx component.
    pub xx: f64,
    /// yy component.
    pub yy: f64,
    /// zz (out-of-plane) component.
    pub zz: f64,
    /// xy (= yx) component.
    pub xy: f64,
}

impl SymTensor {
    /// The zero tensor.
    pub const ZERO: Self = Self {
        xx: 0.0,
        yy: 0.0,
        zz: 0.0,
        xy: 0.0,
    };

    /// Symmetric part of an in-plane matrix, `(A + Aᵀ)/2`, with `zz = 0`.
    pub fn sym_of(a: Matrix) -> Self {
        Self {
            xx: a.x_axis.x,
            yy: a.y_axis.y,
            zz: 0.0,
            xy: 0.5 * (a.y_axis.x + a.x_axis.y),
        }
    }

    /// Trace `xx + yy + zz`.
    pub fn trace(&self) -> f64 {
        self.xx + self.yy + self.zz
    }

    /// Full contraction `A : B` (the off-diagonal term counts twice).
    pub fn double_dot(&self, other: &Self) -> f64 {
        self.xx * other.xx + self.yy * other.yy + self.zz * other.zz + 2.0 * self.xy * other.xy
    }

    /// The in-plane part as a 2×2 matrix.
    pub fn in_plane(&self) -> Matrix {
        Matrix::from_cols(Vector::new(self.xx, self.xy), Vector::new(self.xy, self.yy))
    }

    /// `self + s * other`.
    pub fn add_scaled(&self, other: &Self, s: f64) -> Self {
        Self {
            xx: self.xx + s * other.xx,
            yy: self.yy + s * other.yy,
            zz: self.zz + s * other.zz,
            xy: self.xy + s * other.xy,
        }
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.xx.is_finite() && self.yy.is_finite() && self.zz.is_finite() && self.xy.is_finite()
    }

    /// Components in the row-major 3×3 order VTK expects: xx xy xz yx yy yz zx zy zz.
    pub fn as_3x3(&self) -> [f64; 9] {
        [
            self.xx, self.xy, 0.0, self.xy, self.yy, 0.0, 0.0, 0.0, self.zz,
        ]
    }

    /// In-plane principal values, largest first (closed form for the symmetric 2×2 block).
    ///
    /// The ordering is explicit on purpose: "first principal" means the most tensile value.
    pub fn in_plane_principal(&self) -> [f64; 2] {
        let mean = 0.5 * (self.xx + self.yy);
        let radius = (0.25 * (self.xx - self.yy).powi(2) + self.xy * self.xy).sqrt();
        [mean + radius, mean - radius]
    }
}

/// Outer product `a ⊗ b` as a matrix whose (i, j) entry is `a_i b_j`.
pub fn outer(a: Vector, b: Vector) -> Matrix {
    Matrix::from_cols(a * b.x, a * b.y)
}

/// `σ · g` for a symmetric in-plane tensor and a vector (the zz part does not act in-plane).
pub fn sym_dot(s: &SymTensor, g: Vector) -> Vector {
    Vector::new(s.xx * g.x + s.xy * g.y, s.xy * g.x + s.yy * g.y)
}

/// Volume (area × unit thickness in 2D) of a cube/square of side `h`.
pub fn cell_volume(h: f64) -> f64 {
    h.powi(DIM as i32)
}

/// Pads a vector to three components for writers that always want 3D (VTK).
pub fn to_3d(v: Vector) -> [f64; 3] {
    [v.x, v.y, 0.0]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn principal_values_are_ordered_largest_first() {
        let s = SymTensor {
            xx: -3.0,
            yy: 1.0,
            zz: 0.0,
            xy: 0.0,
        };
        assert_eq!(s.in_plane_principal(), [1.0, -3.0]);
        let sheared = SymTensor {
            xx: 0.0,
            yy: 0.0,
            zz: 0.0,
            xy: 2.0,
        };
        assert_eq!(sheared.in_plane_principal(), [2.0, -2.0]);
    }

    #[test]
    fn outer_product_places_components() {
        let m = outer(Vector::new(1.0, 2.0), Vector::new(3.0, 5.0));
        // (i, j) = a_i b_j; glam stores columns, so column j holds a * b_j.
        assert_eq!(m.x_axis, Vector::new(3.0, 6.0));
        assert_eq!(m.y_axis, Vector::new(5.0, 10.0));
        assert_eq!(m.col(0).y, 6.0);
    }

    #[test]
    fn symmetric_part_and_contraction() {
        let a = Matrix::from_cols(Vector::new(1.0, 2.0), Vector::new(4.0, 3.0));
        let s = SymTensor::sym_of(a);
        assert_eq!(s.xy, 3.0);
        assert_eq!(s.double_dot(&s), 1.0 + 9.0 + 2.0 * 9.0);
        assert_eq!(sym_dot(&s, Vector::new(1.0, 0.0)), Vector::new(1.0, 3.0));
    }
}
