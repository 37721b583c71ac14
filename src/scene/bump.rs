//! pbrt-v4's bump mapping (`displacement` on a material): a float texture `d(u, v)` displaces
//! the surface along its shading normal, and the shading normal becomes that of the displaced
//! surface, as pbrt-v4's `BumpMap`:
//!
//! ```text
//! ∂p/∂u' = ∂p/∂u + ∂d/∂u · n + d · ∂n/∂u      ∂p/∂v' = ∂p/∂v + ∂d/∂v · n + d · ∂n/∂v
//! n' = normalize(∂p/∂u' × ∂p/∂v'), turned to the geometric normal's side
//! ```
//!
//! with pbrt-v4's shading frame on triangles: without vertex normals, the true `∂p/∂u`,
//! `∂p/∂v` and the geometric normal (∂n = 0); with them, the interpolated normal `n`,
//! `∂p/∂u` made perpendicular to it and `∂p/∂v` replaced by `n × ∂p/∂u` (pbrt-v4's `ss`
//! and `ts`), and `∂n/∂u`, `∂n/∂v` from the vertex normals. pbrt-v4 differentiates `d` by a
//! finite step of an eighth of a pixel footprint or less; the analytic gradient of the
//! bilinear lookup (`Texture::gradient`, which the caller passes in) is that step's limit.
//!
//! This renderer's texture v runs down the image (pbrt's `1 − v`): `∂/∂v` changes sign, and
//! the formulas below are pbrt's with that substitution. A planar mesh whose given vertex
//! normals all agree is shaded as one without normals (its `∂p/∂v` is the true one).

use glam::{Vec2, Vec3};

/// A displacement texture's value and its gradient `(∂d/∂u, ∂d/∂v)` at one point (this
/// renderer's v, down the image).
pub type Displacement = (f32, Vec2);

/// The shading normal of the triangle with corners `p` and texture coordinates `t` at
/// barycentric coordinates `b` (weights of corners 0, 1, 2), bump-mapped by `displacement`:
/// with vertex `normals` (pbrt-v4's interpolated frame) or without (`None`: the unit
/// geometric normal `ng` and the true `∂p/∂v`); on `ng`'s side. `None` where the texture
/// coordinates are degenerate or the result is not a direction.
pub fn bumped_normal(
    p: [Vec3; 3],
    t: &[Vec2; 3],
    normals: Option<[Vec3; 3]>,
    ng: Vec3,
    b: [f32; 3],
    (displacement, gradient): Displacement,
) -> Option<Vec3> {
    let (dpdu, dpdv_down) = derivatives(p, t)?;
    // pbrt's ∂/∂v is along −v here.
    let (ddu, ddv) = (gradient.x, -gradient.y);
    let (dpdu, dpdv) = match normals {
        None => (dpdu + ddu * ng, -dpdv_down + ddv * ng),
        Some(normals) => {
            let n = (normals[0] * b[0] + normals[1] * b[1] + normals[2] * b[2]).try_normalize()?;
            let (dndu, dndv_down) = derivatives(normals, t).unwrap_or((Vec3::ZERO, Vec3::ZERO));
            let ss = dpdu - n * n.dot(dpdu);
            let ts = n.cross(dpdu);
            (
                ss + ddu * n + displacement * dndu,
                ts + ddv * n - displacement * dndv_down,
            )
        }
    };
    let bent = dpdu.cross(dpdv).try_normalize()?;
    Some(if bent.dot(ng) < 0.0 { -bent } else { bent })
}

/// `(∂f/∂u, ∂f/∂v)` of the linear interpolation of the vertex values `f` over texture
/// coordinates `t` (v down the image); `None` where the coordinates are degenerate.
fn derivatives(f: [Vec3; 3], t: &[Vec2; 3]) -> Option<(Vec3, Vec3)> {
    let (df1, df2) = (f[1] - f[0], f[2] - f[0]);
    let (d1, d2) = (t[1] - t[0], t[2] - t[0]);
    let det = d1.x * d2.y - d1.y * d2.x;
    if det.abs() < 1e-12 || !det.is_finite() {
        return None;
    }
    Some((
        (df1 * d2.y - df2 * d1.y) / det,
        (df2 * d1.x - df1 * d2.x) / det,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit square's lower-right triangle in the XZ plane, facing +Y, u along +X and (this
    /// renderer's) v along +Z, so pbrt's v runs along −Z.
    const P: [Vec3; 3] = [Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0), Vec3::X];
    const T: [Vec2; 3] = [Vec2::ZERO, Vec2::ONE, Vec2::X];

    #[test]
    fn a_slope_in_u_tilts_the_normal_against_it_with_or_without_vertex_normals() {
        let b = [0.5, 0.25, 0.25];
        // d rises at 0.2 per unit of u.
        let d = (0.05, Vec2::new(0.2, 0.0));
        let want = Vec3::new(-0.2, 1.0, 0.0).normalize();
        let got = bumped_normal(P, &T, None, Vec3::Y, b, d).unwrap();
        assert!((got - want).length() < 1e-5, "{got} {want}");
        // Vertex normals that differ (slightly): pbrt's interpolated frame, the same slope.
        // Where they face −Y, the surface is displaced along −Y: seen from +Y (the side the
        // result is turned to) the slope runs the other way, as in pbrt-v4.
        let tilt = Vec3::new(0.0, 1.0, 1e-3).normalize();
        for sign in [1.0, -1.0] {
            let normals = [Vec3::Y * sign, Vec3::Y * sign, tilt * sign];
            let got = bumped_normal(P, &T, Some(normals), Vec3::Y, b, d).unwrap();
            let want = Vec3::new(-0.2 * sign, 1.0, 0.0).normalize();
            assert!((got - want).length() < 1e-2, "{sign}: {got} {want}");
        }
    }

    #[test]
    fn a_constant_displacement_leaves_a_flat_normal() {
        let b = [0.2, 0.3, 0.5];
        let got = bumped_normal(P, &T, None, Vec3::Y, b, (0.3, Vec2::ZERO));
        assert_eq!(got, Some(Vec3::Y));
        let degenerate = [Vec2::ZERO; 3];
        let d = (0.3, Vec2::ONE);
        assert_eq!(bumped_normal(P, &degenerate, None, Vec3::Y, b, d), None);
    }
}
