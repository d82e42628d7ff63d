//! A mesh object's placement: `scale`, `rotate`, `translate` or a 4x4 `matrix`, checked
//! and composed in f64, applied once at load to the mesh's vertices (and to its normals
//! by the inverse transpose).
//!
//! Reads the mesh keys `scale`, `rotate`, `translate` and `matrix` (`scene::desc`).

use super::desc::{RotationDesc, ScaleDesc, V3};
use glam::{DAffine3, DMat3, DVec3, Vec3};

/// An affine map of points, in f64: `p ↦ matrix · p + translation`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    affine: DAffine3,
    /// The inverse transpose of the linear part: what normals are mapped by.
    normal_matrix: DMat3,
}

impl Transform {
    pub const IDENTITY: Transform = Transform {
        affine: DAffine3::IDENTITY,
        normal_matrix: DMat3::IDENTITY,
    };

    /// The transform a mesh's keys describe: `matrix` alone, or `scale`, then each of
    /// `rotate` in the order written, then `translate`. `Err` is the key that is wrong
    /// and why.
    pub fn from_keys(
        scale: Option<ScaleDesc>,
        rotate: &[RotationDesc],
        translate: Option<V3>,
        matrix: Option<&[Vec<f64>]>,
    ) -> Result<Transform, (&'static str, String)> {
        let key = if matrix.is_some() { "matrix" } else { "scale" };
        let affine = match matrix {
            Some(rows) => {
                if scale.is_some() || !rotate.is_empty() || translate.is_some() {
                    return Err((
                        "matrix",
                        "matrix replaces scale, rotate and translate: give either the matrix or those keys"
                            .into(),
                    ));
                }
                from_matrix(rows).map_err(|m| ("matrix", m))?
            }
            None => {
                let mut a = match scale {
                    None => DAffine3::IDENTITY,
                    Some(s) => {
                        let s = match s {
                            ScaleDesc::Uniform(s) => DVec3::splat(s),
                            ScaleDesc::PerAxis(V3(s)) => DVec3::from(s),
                        };
                        if !s.is_finite() || s.cmpeq(DVec3::ZERO).any() {
                            return Err((
                                "scale",
                                format!(
                                    "scale must be finite and non-zero on every axis, got {:?}",
                                    s.to_array()
                                ),
                            ));
                        }
                        DAffine3::from_scale(s)
                    }
                };
                for (k, r) in rotate.iter().enumerate() {
                    let axis = DVec3::from(r.axis.0);
                    let length = axis.length();
                    if !(axis.is_finite() && length.is_finite() && length > 0.0) {
                        return Err((
                            "rotate",
                            format!(
                                "rotate {}: axis must be a finite, non-zero vector, got {:?}",
                                k + 1,
                                r.axis.0
                            ),
                        ));
                    }
                    if !r.degrees.is_finite() {
                        return Err((
                            "rotate",
                            format!(
                                "rotate {}: degrees must be finite, got {}",
                                k + 1,
                                r.degrees
                            ),
                        ));
                    }
                    let turn = DAffine3::from_axis_angle(axis / length, r.degrees.to_radians());
                    a = turn * a;
                }
                if let Some(V3(t)) = translate {
                    let t = DVec3::from(t);
                    if !t.is_finite() {
                        return Err((
                            "translate",
                            format!("translate must be finite, got {:?}", t.to_array()),
                        ));
                    }
                    a = DAffine3::from_translation(t) * a;
                }
                a
            }
        };
        let linear = affine.matrix3;
        let det = linear.determinant();
        if !(det.is_finite() && det != 0.0) {
            return Err((
                key,
                format!("the transform is singular (determinant {det:e}): it flattens the mesh"),
            ));
        }
        Ok(Transform {
            affine,
            normal_matrix: linear.inverse().transpose(),
        })
    }

    /// The map of points.
    pub fn affine(&self) -> DAffine3 {
        self.affine
    }

    pub fn is_identity(&self) -> bool {
        *self == Self::IDENTITY
    }

    /// The point `p` moved, in f64.
    pub fn point(&self, p: Vec3) -> DVec3 {
        self.affine.transform_point3(p.as_dvec3())
    }

    /// The normal `n` mapped by the inverse transpose and normalised, in f64 (zero if it
    /// has no direction).
    pub fn normal(&self, n: Vec3) -> DVec3 {
        (self.normal_matrix * n.as_dvec3()).normalize_or_zero()
    }
}

/// An affine 4x4 matrix, rows of four numbers acting on column vectors `[x, y, z, 1]`
/// (the translation is the last column), its last row `[0, 0, 0, 1]`.
fn from_matrix(rows: &[Vec<f64>]) -> Result<DAffine3, String> {
    if rows.len() != 4 || rows.iter().any(|r| r.len() != 4) {
        let shape: Vec<usize> = rows.iter().map(Vec::len).collect();
        return Err(format!(
            "matrix must be four rows of four numbers, got rows of {shape:?}"
        ));
    }
    if let Some(x) = rows.iter().flatten().find(|x| !x.is_finite()) {
        return Err(format!("matrix must be finite, got {x}"));
    }
    if rows[3] != [0.0, 0.0, 0.0, 1.0] {
        return Err(format!(
            "matrix must be affine, its last row [0, 0, 0, 1], got {:?}",
            rows[3]
        ));
    }
    let column = |j: usize| DVec3::new(rows[0][j], rows[1][j], rows[2][j]);
    Ok(DAffine3 {
        matrix3: DMat3::from_cols(column(0), column(1), column(2)),
        translation: column(3),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rotation(axis: [f64; 3], degrees: f64) -> RotationDesc {
        RotationDesc {
            axis: V3(axis),
            degrees,
        }
    }

    #[test]
    fn scale_then_rotations_in_order_then_translate() {
        let t = Transform::from_keys(
            Some(ScaleDesc::PerAxis(V3([2.0, 3.0, 4.0]))),
            &[
                rotation([0.0, 0.0, 1.0], 90.0),
                rotation([1.0, 0.0, 0.0], 90.0),
            ],
            Some(V3([10.0, 20.0, 30.0])),
            None,
        )
        .unwrap();
        // (1, 1, 1) scaled: (2, 3, 4); about z by 90°: (−3, 2, 4); about x by 90°:
        // (−3, −4, 2); moved: (7, 16, 32).
        let p = t.point(Vec3::ONE);
        assert!(
            (p - DVec3::new(7.0, 16.0, 32.0)).abs().max_element() < 1e-12,
            "{p}"
        );
    }

    #[test]
    fn matrix_is_rows_acting_on_columns() {
        let rows = [
            vec![0.0, -1.0, 0.0, 5.0],
            vec![1.0, 0.0, 0.0, 6.0],
            vec![0.0, 0.0, 2.0, 7.0],
            vec![0.0, 0.0, 0.0, 1.0],
        ];
        let t = Transform::from_keys(None, &[], None, Some(&rows)).unwrap();
        assert_eq!(
            t.point(Vec3::new(1.0, 2.0, 3.0)),
            DVec3::new(3.0, 7.0, 13.0)
        );
        // Normals by the inverse transpose: the z scale of 2 leaves a z normal alone and
        // tilts a slanted one towards the plane's new normal.
        assert_eq!(t.normal(Vec3::Z), DVec3::Z);
        let n = t.normal(Vec3::new(1.0, 0.0, 1.0));
        let expected = DVec3::new(0.0, 1.0, 0.5).normalize();
        assert!((n - expected).length() < 1e-15, "{n}");
    }

    #[test]
    fn bad_keys_are_refused_with_the_key() {
        let err = |s, r: &[RotationDesc], t, m: Option<&[Vec<f64>]>| {
            Transform::from_keys(s, r, t, m).unwrap_err().1
        };
        assert!(err(Some(ScaleDesc::Uniform(0.0)), &[], None, None).starts_with("scale"));
        let zero_axis = [rotation([0.0, 0.0, 0.0], 10.0)];
        assert!(err(None, &zero_axis, None, None).starts_with("rotate 1: axis"));
        let nan = [rotation([0.0, 1.0, 0.0], f64::NAN)];
        assert!(err(None, &nan, None, None).starts_with("rotate 1: degrees"));
        let identity = [
            vec![1.0, 0.0, 0.0, 0.0],
            vec![0.0, 1.0, 0.0, 0.0],
            vec![0.0, 0.0, 1.0, 0.0],
            vec![0.0, 0.0, 0.0, 1.0],
        ];
        let both = err(Some(ScaleDesc::Uniform(2.0)), &[], None, Some(&identity));
        assert!(both.starts_with("matrix replaces"));
        let mut projective = identity.clone();
        projective[3][2] = 1.0;
        assert!(err(None, &[], None, Some(&projective)).contains("affine"));
        let mut flat = identity.clone();
        flat[2][2] = 0.0;
        assert!(err(None, &[], None, Some(&flat)).contains("singular"));
        assert!(err(None, &[], None, Some(&identity[..3])).starts_with("matrix must be four"));
        assert!(Transform::from_keys(None, &[], None, Some(&identity))
            .unwrap()
            .is_identity());
    }
}
