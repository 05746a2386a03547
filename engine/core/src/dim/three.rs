//! Three dimensions: `DVec3`, `DMat3` and [`SymTensor3`].

use super::eigen::symmetric_eigen;
use super::{Dim, Dimension, SymOps, glam_matrix_ops, glam_vector_ops};
use glam::{DMat3, DVec3};

/// Three space dimensions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Three;

glam_vector_ops!(DVec3, 3, |f| DVec3::new(f(0), f(1), f(2)));
glam_matrix_ops!(DMat3, DVec3, 3, |a, b| DMat3::from_cols(
    a * b.x,
    a * b.y,
    a * b.z
));

impl Dim for Three {
    const N: usize = 3;
    const DIMENSION: Dimension = Dimension::Three;
    const NAME: &'static str = "3D";
    const AXES: &'static [&'static str] = &["x", "y", "z"];
    type Vector = DVec3;
    type Matrix = DMat3;
    type Sym = SymTensor3;
    type Cell = [usize; 3];

    #[inline]
    fn left_cauchy_green(f: DMat3) -> SymTensor3 {
        let b = f * f.transpose();
        SymTensor3 {
            xx: b.x_axis.x,
            yy: b.y_axis.y,
            zz: b.z_axis.z,
            xy: b.y_axis.x,
            yz: b.z_axis.y,
            xz: b.z_axis.x,
        }
    }

    #[inline]
    fn cauchy_green_trace(f: DMat3) -> f64 {
        f.x_axis.length_squared() + f.y_axis.length_squared() + f.z_axis.length_squared()
    }
}

/// A symmetric second-order tensor in three dimensions: six independent components.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SymTensor3 {
    /// xx component.
    pub xx: f64,
    /// yy component.
    pub yy: f64,
    /// zz component.
    pub zz: f64,
    /// xy (= yx) component.
    pub xy: f64,
    /// yz (= zy) component.
    pub yz: f64,
    /// xz (= zx) component.
    pub xz: f64,
}

impl SymTensor3 {
    /// The full 3×3 array, row by row.
    #[inline]
    pub fn to_array(&self) -> [[f64; 3]; 3] {
        [
            [self.xx, self.xy, self.xz],
            [self.xy, self.yy, self.yz],
            [self.xz, self.yz, self.zz],
        ]
    }

    /// Principal values (largest first) and the matching unit principal directions.
    #[inline]
    pub fn principal(&self) -> ([f64; 3], [DVec3; 3]) {
        let (values, vectors) = symmetric_eigen(self.to_array());
        (values, vectors.map(DVec3::from_array))
    }
}

impl SymOps<DVec3, DMat3> for SymTensor3 {
    const ZERO: Self = Self {
        xx: 0.0,
        yy: 0.0,
        zz: 0.0,
        xy: 0.0,
        yz: 0.0,
        xz: 0.0,
    };
    const IDENTITY: Self = Self {
        xx: 1.0,
        yy: 1.0,
        zz: 1.0,
        xy: 0.0,
        yz: 0.0,
        xz: 0.0,
    };

    #[inline]
    fn isotropic(k: f64) -> Self {
        Self::IDENTITY.scaled(k)
    }

    #[inline]
    fn sym_of(a: DMat3) -> Self {
        Self {
            xx: a.x_axis.x,
            yy: a.y_axis.y,
            zz: a.z_axis.z,
            xy: 0.5 * (a.y_axis.x + a.x_axis.y),
            yz: 0.5 * (a.z_axis.y + a.y_axis.z),
            xz: 0.5 * (a.z_axis.x + a.x_axis.z),
        }
    }

    #[inline]
    fn from_fn(mut f: impl FnMut(usize, usize) -> f64) -> Self {
        Self {
            xx: f(0, 0),
            yy: f(1, 1),
            zz: f(2, 2),
            xy: f(0, 1),
            yz: f(1, 2),
            xz: f(0, 2),
        }
    }

    #[inline]
    fn get(&self, i: usize, j: usize) -> f64 {
        match (i.min(j), i.max(j)) {
            (0, 0) => self.xx,
            (1, 1) => self.yy,
            (2, 2) => self.zz,
            (0, 1) => self.xy,
            (1, 2) => self.yz,
            (0, 2) => self.xz,
            _ => 0.0,
        }
    }

    #[inline]
    fn trace(&self) -> f64 {
        self.xx + self.yy + self.zz
    }

    #[inline]
    fn double_dot(&self, o: &Self) -> f64 {
        self.xx * o.xx
            + self.yy * o.yy
            + self.zz * o.zz
            + 2.0 * (self.xy * o.xy + self.yz * o.yz + self.xz * o.xz)
    }

    #[inline]
    fn add_scaled(&self, o: &Self, s: f64) -> Self {
        Self {
            xx: self.xx + s * o.xx,
            yy: self.yy + s * o.yy,
            zz: self.zz + s * o.zz,
            xy: self.xy + s * o.xy,
            yz: self.yz + s * o.yz,
            xz: self.xz + s * o.xz,
        }
    }

    #[inline]
    fn scaled(&self, s: f64) -> Self {
        Self {
            xx: s * self.xx,
            yy: s * self.yy,
            zz: s * self.zz,
            xy: s * self.xy,
            yz: s * self.yz,
            xz: s * self.xz,
        }
    }

    #[inline]
    fn hooke(&self, lambda: f64, mu: f64) -> Self {
        let volumetric = lambda * self.trace();
        let two_mu = 2.0 * mu;
        Self {
            xx: volumetric + two_mu * self.xx,
            yy: volumetric + two_mu * self.yy,
            zz: volumetric + two_mu * self.zz,
            xy: two_mu * self.xy,
            yz: two_mu * self.yz,
            xz: two_mu * self.xz,
        }
    }

    #[inline]
    fn deviator(&self) -> Self {
        let mean = self.trace() / 3.0;
        Self {
            xx: self.xx - mean,
            yy: self.yy - mean,
            zz: self.zz - mean,
            ..*self
        }
    }

    #[inline]
    fn dot(&self, g: DVec3) -> DVec3 {
        DVec3::new(
            self.xx * g.x + self.xy * g.y + self.xz * g.z,
            self.xy * g.x + self.yy * g.y + self.yz * g.z,
            self.xz * g.x + self.yz * g.y + self.zz * g.z,
        )
    }

    #[inline]
    fn to_matrix(&self) -> DMat3 {
        DMat3::from_cols(
            DVec3::new(self.xx, self.xy, self.xz),
            DVec3::new(self.xy, self.yy, self.yz),
            DVec3::new(self.xz, self.yz, self.zz),
        )
    }

    #[inline]
    fn principal_values(&self) -> [f64; 3] {
        symmetric_eigen(self.to_array()).0
    }

    #[inline]
    fn largest_principal(&self) -> f64 {
        self.principal_values()[0]
    }

    #[inline]
    fn is_finite(&self) -> bool {
        [self.xx, self.yy, self.zz, self.xy, self.yz, self.xz]
            .iter()
            .all(|v| v.is_finite())
    }

    #[inline]
    fn as_3x3(&self) -> [f64; 9] {
        [
            self.xx, self.xy, self.xz, self.xy, self.yy, self.yz, self.xz, self.yz, self.zz,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dim::MatrixOps;

    #[test]
    fn symmetric_part_contraction_and_action() {
        let a = DMat3::from_cols(
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(4.0, 5.0, 6.0),
            DVec3::new(7.0, 8.0, 9.0),
        );
        let s = SymTensor3::sym_of(a);
        assert_eq!((s.xy, s.yz, s.xz), (3.0, 7.0, 5.0));
        assert_eq!(s.to_matrix(), (a + a.transpose()) * 0.5);
        let g = DVec3::new(0.5, -1.0, 2.0);
        assert_eq!(s.dot(g), s.to_matrix() * g);
        let full = s.to_matrix();
        let contraction: f64 = (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j)))
            .map(|(i, j)| full.get(i, j) * full.get(i, j))
            .sum();
        assert!((s.double_dot(&s) - contraction).abs() < 1e-12);
        assert_eq!(s.as_3x3()[5], s.yz);
    }

    #[test]
    fn left_cauchy_green_matches_f_f_transpose() {
        let f = DMat3::from_cols(
            DVec3::new(1.1, 0.1, 0.0),
            DVec3::new(-0.2, 0.9, 0.3),
            DVec3::new(0.05, 0.0, 1.2),
        );
        let b = Three::left_cauchy_green(f);
        assert!((b.to_matrix() - f * f.transpose()).max_abs() < 1e-15);
        assert!((b.trace() - Three::cauchy_green_trace(f)).abs() < 1e-14);
    }
}
