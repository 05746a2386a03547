//! Eigenvalues and eigenvectors of a symmetric 3×3 matrix by the cyclic Jacobi method.
//!
//! Each Jacobi rotation zeroes one off-diagonal entry; sweeps over the three entries converge
//! quadratically, and the method is accurate to round-off whatever the spacing of the
//! eigenvalues: repeated and triple eigenvalues (an isotropic stress, uniaxial tension) need no
//! special case, unlike the closed-form (trigonometric) solution of the characteristic cubic,
//! which loses half the digits of a repeated pair. Values come out largest first, so "first
//! principal" is always the most tensile one.

/// Eigenvalues of the symmetric matrix `a` (only its upper triangle is read), largest first, and
/// the matching orthonormal eigenvectors.
pub fn symmetric_eigen(a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut m = [
        [a[0][0], a[0][1], a[0][2]],
        [a[0][1], a[1][1], a[1][2]],
        [a[0][2], a[1][2], a[2][2]],
    ];
    // Columns of `v` are the eigenvectors.
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let scale = m.iter().flatten().map(|x| x * x).sum::<f64>().sqrt();
    if scale > 0.0 && scale.is_finite() {
        let negligible = 1e-3 * f64::EPSILON * scale;
        for _sweep in 0..32 {
            let off = m[0][1].abs() + m[0][2].abs() + m[1][2].abs();
            if off <= negligible {
                break;
            }
            for (p, q) in [(0, 1), (0, 2), (1, 2)] {
                if m[p][q].abs() > negligible {
                    rotate(&mut m, &mut v, p, q);
                }
            }
        }
    }
    let mut order = [0, 1, 2];
    order.sort_by(|&i, &j| m[j][j].total_cmp(&m[i][i]));
    let values = order.map(|k| m[k][k]);
    let vectors = order.map(|k| [v[0][k], v[1][k], v[2][k]]);
    (values, vectors)
}

/// One Jacobi rotation in the (p, q) plane that zeroes `m[p][q]`, accumulated into `v`.
fn rotate(m: &mut [[f64; 3]; 3], v: &mut [[f64; 3]; 3], p: usize, q: usize) {
    let apq = m[p][q];
    let theta = (m[q][q] - m[p][p]) / (2.0 * apq);
    // The smaller root of t² + 2θt − 1 = 0 keeps the rotation below 45°, for stability.
    let t = if theta.abs() > 1e150 {
        0.5 / theta
    } else {
        theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
    };
    let c = 1.0 / (t * t + 1.0).sqrt();
    let s = t * c;
    m[p][p] -= t * apq;
    m[q][q] += t * apq;
    m[p][q] = 0.0;
    m[q][p] = 0.0;
    let r = 3 - p - q;
    let (arp, arq) = (m[r][p], m[r][q]);
    m[r][p] = c * arp - s * arq;
    m[p][r] = m[r][p];
    m[r][q] = s * arp + c * arq;
    m[q][r] = m[r][q];
    for row in v.iter_mut() {
        let (vp, vq) = (row[p], row[q]);
        row[p] = c * vp - s * vq;
        row[q] = s * vp + c * vq;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat3, DQuat, DVec3};
    use proptest::prelude::*;

    fn to_array(m: DMat3) -> [[f64; 3]; 3] {
        std::array::from_fn(|i| std::array::from_fn(|j| m.col(j)[i]))
    }

    /// `Q diag(d) Qᵀ` for the rotation `q`.
    fn rotated(d: [f64; 3], q: DQuat) -> [[f64; 3]; 3] {
        let r = DMat3::from_quat(q);
        to_array(r * DMat3::from_diagonal(DVec3::from_array(d)) * r.transpose())
    }

    fn check(a: [[f64; 3]; 3], tolerance: f64) -> [f64; 3] {
        let (values, vectors) = symmetric_eigen(a);
        let m = DMat3::from_cols_array_2d(&a);
        for (k, value) in values.iter().enumerate() {
            let x = DVec3::from_array(vectors[k]);
            assert!((x.length() - 1.0).abs() < 1e-14);
            let residual = (m * x - x * *value).length();
            assert!(
                residual < tolerance,
                "A x − λ x = {residual:e} for λ = {value}"
            );
            for other in &vectors[k + 1..] {
                assert!(x.dot(DVec3::from_array(*other)).abs() < 1e-14);
            }
        }
        assert!(values[0] >= values[1] && values[1] >= values[2]);
        values
    }

    /// Round-off for a matrix of Frobenius norm `norm`: a few ulps of the largest entry (the
    /// input `Q D Qᵀ` itself carries that much error).
    fn round_off(norm: f64) -> f64 {
        10.0 * f64::EPSILON * norm
    }

    fn close(values: [f64; 3], expected: [f64; 3]) -> bool {
        let norm = expected.iter().map(|v| v * v).sum::<f64>().sqrt();
        values
            .iter()
            .zip(expected)
            .all(|(v, e)| (v - e).abs() <= round_off(norm))
    }

    #[test]
    fn repeated_and_triple_eigenvalues_are_exact_to_round_off() {
        let q = DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0);
        // The closed-form cubic would lose about half the digits of each repeated pair here.
        for (diagonal, sorted) in [
            ([2.0, -1.0, 2.0], [2.0, 2.0, -1.0]),
            ([-3.0, 5.0, -3.0], [5.0, -3.0, -3.0]),
            ([4.0; 3], [4.0; 3]),
            // Uniaxial tension along a skew direction: one non-zero value.
            ([0.0, 7.5, 0.0], [7.5, 0.0, 0.0]),
        ] {
            let values = check(rotated(diagonal, q), 1e-14);
            assert!(close(values, sorted), "{values:?} vs {sorted:?}");
        }
        assert_eq!(symmetric_eigen([[0.0; 3]; 3]).0, [0.0; 3]);
    }

    #[test]
    fn diagonal_input_is_sorted_largest_first() {
        let (values, vectors) =
            symmetric_eigen([[-1.0, 0.0, 0.0], [0.0, 3.0, 0.0], [0.0, 0.0, 0.5]]);
        assert_eq!(values, [3.0, 0.5, -1.0]);
        assert_eq!(vectors[0], [0.0, 1.0, 0.0]);
    }

    proptest! {
        #[test]
        fn any_symmetric_matrix(a in -10.0f64..10.0, b in -10.0f64..10.0, c in -10.0f64..10.0,
                                d in -10.0f64..10.0, e in -10.0f64..10.0, f in -10.0f64..10.0) {
            let m = [[a, d, f], [d, b, e], [f, e, c]];
            let values = check(m, 1e-12);
            prop_assert!((values.iter().sum::<f64>() - (a + b + c)).abs() < 1e-12);
        }

        #[test]
        fn nearly_repeated_eigenvalues(gap in 0.0f64..1e-9, x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0) {
            let q = DQuat::from_euler(glam::EulerRot::XYZ, x, y, z);
            let values = check(rotated([1.0, 1.0 + gap, -2.0], q), 1e-14);
            prop_assert!(close(values, [1.0 + gap, 1.0, -2.0]), "{:?}", values);
        }
    }
}
