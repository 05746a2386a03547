//! Two dimensions, plane strain: `DVec2`, `DMat2` and [`SymTensor2`] with its `zz` component.

use super::{Dim, Dimension, SymOps, glam_matrix_ops, glam_vector_ops};
use glam::{DMat2, DVec2};

/// Two space dimensions in plane strain: the out-of-plane strain is zero, the out-of-plane
/// stress `σ_zz` is kept.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Two;

glam_vector_ops!(DVec2, 2, |f| DVec2::new(f(0), f(1)));
glam_matrix_ops!(DMat2, DVec2, 2, |a, b| DMat2::from_cols(a * b.x, a * b.y));

impl Dim for Two {
    const N: usize = 2;
    const DIMENSION: Dimension = Dimension::Two;
    const NAME: &'static str = "2D plane strain";
    const AXES: &'static [&'static str] = &["x", "y"];
    type Vector = DVec2;
    type Matrix = DMat2;
    type Sym = SymTensor2;
    type Cell = [usize; 2];

    #[inline]
    fn left_cauchy_green(f: DMat2) -> SymTensor2 {
        let b = f * f.transpose();
        SymTensor2 {
            xx: b.x_axis.x,
            yy: b.y_axis.y,
            zz: 1.0,
            xy: b.y_axis.x,
        }
    }

    #[inline]
    fn cauchy_green_trace(f: DMat2) -> f64 {
        f.x_axis.length_squared() + f.y_axis.length_squared() + 1.0
    }
}

/// A symmetric second-order tensor in plane strain: the in-plane components plus `zz`.
///
/// Stress and strain both use it. In plane strain the out-of-plane strain is zero but the
/// out-of-plane stress is not, and it enters the energy and the mean stress, so it is kept.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SymTensor2 {
    /// xx component.
    pub xx: f64,
    /// yy component.
    pub yy: f64,
    /// zz (out-of-plane) component.
    pub zz: f64,
    /// xy (= yx) component.
    pub xy: f64,
}

impl SymTensor2 {
    /// In-plane principal values, largest first (closed form for the symmetric 2×2 block).
    ///
    /// The ordering is explicit on purpose: "first principal" means the most tensile value.
    #[inline]
    pub fn in_plane_principal(&self) -> [f64; 2] {
        let mean = 0.5 * (self.xx + self.yy);
        let radius = (0.25 * (self.xx - self.yy).powi(2) + self.xy * self.xy).sqrt();
        [mean + radius, mean - radius]
    }
}

impl SymOps<DVec2, DMat2> for SymTensor2 {
    const ZERO: Self = Self {
        xx: 0.0,
        yy: 0.0,
        zz: 0.0,
        xy: 0.0,
    };
    const IDENTITY: Self = Self {
        xx: 1.0,
        yy: 1.0,
        zz: 1.0,
        xy: 0.0,
    };

    #[inline]
    fn isotropic(k: f64) -> Self {
        Self {
            xx: k,
            yy: k,
            zz: k,
            xy: 0.0,
        }
    }

    #[inline]
    fn sym_of(a: DMat2) -> Self {
        Self {
            xx: a.x_axis.x,
            yy: a.y_axis.y,
            zz: 0.0,
            xy: 0.5 * (a.y_axis.x + a.x_axis.y),
        }
    }

    #[inline]
    fn from_fn(mut f: impl FnMut(usize, usize) -> f64) -> Self {
        Self {
            xx: f(0, 0),
            yy: f(1, 1),
            zz: f(2, 2),
            xy: f(0, 1),
        }
    }

    #[inline]
    fn get(&self, i: usize, j: usize) -> f64 {
        match (i.min(j), i.max(j)) {
            (0, 0) => self.xx,
            (1, 1) => self.yy,
            (2, 2) => self.zz,
            (0, 1) => self.xy,
            _ => 0.0,
        }
    }

    #[inline]
    fn trace(&self) -> f64 {
        self.xx + self.yy + self.zz
    }

    #[inline]
    fn double_dot(&self, other: &Self) -> f64 {
        self.xx * other.xx + self.yy * other.yy + self.zz * other.zz + 2.0 * self.xy * other.xy
    }

    #[inline]
    fn add_scaled(&self, other: &Self, s: f64) -> Self {
        Self {
            xx: self.xx + s * other.xx,
            yy: self.yy + s * other.yy,
            zz: self.zz + s * other.zz,
            xy: self.xy + s * other.xy,
        }
    }

    #[inline]
    fn scaled(&self, s: f64) -> Self {
        Self {
            xx: s * self.xx,
            yy: s * self.yy,
            zz: s * self.zz,
            xy: s * self.xy,
        }
    }

    #[inline]
    fn hooke(&self, lambda: f64, mu: f64) -> Self {
        let volumetric = lambda * self.trace();
        Self {
            xx: volumetric + 2.0 * mu * self.xx,
            yy: volumetric + 2.0 * mu * self.yy,
            zz: volumetric + 2.0 * mu * self.zz,
            xy: 2.0 * mu * self.xy,
        }
    }

    #[inline]
    fn deviator(&self) -> Self {
        let mean = self.trace() / 3.0;
        Self {
            xx: self.xx - mean,
            yy: self.yy - mean,
            zz: self.zz - mean,
            xy: self.xy,
        }
    }

    #[inline]
    fn dot(&self, g: DVec2) -> DVec2 {
        DVec2::new(self.xx * g.x + self.xy * g.y, self.xy * g.x + self.yy * g.y)
    }

    #[inline]
    fn to_matrix(&self) -> DMat2 {
        DMat2::from_cols(DVec2::new(self.xx, self.xy), DVec2::new(self.xy, self.yy))
    }

    #[inline]
    fn principal_values(&self) -> [f64; 3] {
        let [a, b] = self.in_plane_principal();
        let mut all = [a, b, self.zz];
        all.sort_by(|p, q| q.total_cmp(p));
        all
    }

    #[inline]
    fn largest_principal(&self) -> f64 {
        self.in_plane_principal()[0]
    }

    #[inline]
    fn is_finite(&self) -> bool {
        self.xx.is_finite() && self.yy.is_finite() && self.zz.is_finite() && self.xy.is_finite()
    }

    #[inline]
    fn as_3x3(&self) -> [f64; 9] {
        [
            self.xx, self.xy, 0.0, self.xy, self.yy, 0.0, 0.0, 0.0, self.zz,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dim::MatrixOps;

    #[test]
    fn principal_values_are_ordered_largest_first() {
        let s = SymTensor2 {
            xx: -3.0,
            yy: 1.0,
            zz: 0.0,
            xy: 0.0,
        };
        assert_eq!(s.in_plane_principal(), [1.0, -3.0]);
        assert_eq!(s.principal_values(), [1.0, 0.0, -3.0]);
        let sheared = SymTensor2 {
            xx: 0.0,
            yy: 0.0,
            zz: 5.0,
            xy: 2.0,
        };
        assert_eq!(sheared.in_plane_principal(), [2.0, -2.0]);
        // σ_zz does not open a plane-strain crack.
        assert_eq!(sheared.largest_principal(), 2.0);
        assert_eq!(sheared.principal_values(), [5.0, 2.0, -2.0]);
    }

    #[test]
    fn outer_product_places_components() {
        let m = DMat2::outer(DVec2::new(1.0, 2.0), DVec2::new(3.0, 5.0));
        // (i, j) = a_i b_j; glam stores columns, so column j holds a * b_j.
        assert_eq!(m.x_axis, DVec2::new(3.0, 6.0));
        assert_eq!(m.y_axis, DVec2::new(5.0, 10.0));
        assert_eq!(m.get(1, 0), 6.0);
    }

    #[test]
    fn symmetric_part_and_contraction() {
        let a = DMat2::from_cols(DVec2::new(1.0, 2.0), DVec2::new(4.0, 3.0));
        let s = SymTensor2::sym_of(a);
        assert_eq!(s.xy, 3.0);
        assert_eq!(s.double_dot(&s), 1.0 + 9.0 + 2.0 * 9.0);
        assert_eq!(s.dot(DVec2::new(1.0, 0.0)), DVec2::new(1.0, 3.0));
        assert_eq!(
            s.to_matrix(),
            DMat2::from_cols(DVec2::new(1.0, 3.0), DVec2::new(3.0, 3.0))
        );
    }

    #[test]
    fn plane_strain_deformation_keeps_unit_out_of_plane_stretch() {
        let f = DMat2::from_cols(DVec2::new(1.1, 0.2), DVec2::new(-0.1, 0.9));
        let b = Two::left_cauchy_green(f);
        assert_eq!(b.zz, 1.0);
        assert!((b.trace() - Two::cauchy_green_trace(f)).abs() < 1e-15);
    }
}
