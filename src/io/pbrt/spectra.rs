//! Spectra reduced to linear sRGB, as an RGB renderer must: pbrt-v4's `blackbody`, sampled
//! `spectrum` values and named spectra.
//!
//! A spectrum `s(λ)` becomes `rgb = M · ∫ s(λ) (x̄, ȳ, z̄)(λ) dλ`, divided channel by channel by
//! the same integral of the constant spectrum 1, so that a constant spectrum keeps its value
//! in every channel (an equal-energy white balanced to the sRGB white). `(x̄, ȳ, z̄)` are the
//! CIE 1931 2° colour matching functions in the multi-lobe Gaussian fit of Wyman, Sloan and
//! Shirley (JCGT 2013), `M` the XYZ-to-linear-sRGB matrix; the integrals are sums at 1 nm
//! over 360–830 nm. An emitter's blackbody is scaled to unit luminance `Y` (pbrt-v4 divides
//! an emitter's spectrum by its photometric value) and converted without white balance, as
//! pbrt-v4's default film does: 6500 K comes out close to the sRGB white.

use crate::math::Rgb;

/// One lobe of the fit: a Gaussian with different widths below and above its centre.
fn lobe(l: f64, mu: f64, below: f64, above: f64) -> f64 {
    let s = if l < mu { below } else { above };
    (-0.5 * ((l - mu) / s).powi(2)).exp()
}

/// CIE 1931 colour matching functions at wavelength `l` (nm), analytic fit.
fn cmf(l: f64) -> [f64; 3] {
    [
        1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7)
            - 0.065 * lobe(l, 501.1, 20.4, 26.2),
        0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1),
        1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8),
    ]
}

/// Linear sRGB of CIE XYZ.
fn xyz_to_rgb(c: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = c;
    [
        3.240_454_2 * x - 1.537_138_5 * y - 0.498_531_4 * z,
        -0.969_266_0 * x + 1.876_010_8 * y + 0.041_556_0 * z,
        0.055_643_4 * x - 0.204_025_9 * y + 1.057_225_2 * z,
    ]
}

/// `∫ s(λ) cmf(λ) dλ` at 1 nm steps over 360–830 nm.
fn integrate(s: impl Fn(f64) -> f64) -> [f64; 3] {
    let mut acc = [0.0; 3];
    for l in 360..=830 {
        let l = l as f64;
        let (v, c) = (s(l), cmf(l));
        for i in 0..3 {
            acc[i] += v * c[i];
        }
    }
    acc
}

/// The white-balanced RGB of spectrum `s` (see the module documentation).
fn balanced_rgb(s: impl Fn(f64) -> f64) -> Rgb {
    let rgb = xyz_to_rgb(integrate(s));
    let white = xyz_to_rgb(integrate(|_| 1.0));
    Rgb::new(
        (rgb[0] / white[0]) as f32,
        (rgb[1] / white[1]) as f32,
        (rgb[2] / white[2]) as f32,
    )
}

/// Planck's law: a blackbody's spectral radiance at `l_nm` nanometres and `kelvin`.
fn planck(l_nm: f64, kelvin: f64) -> f64 {
    let l = l_nm * 1e-9;
    let (c, h, kb) = (299_792_458.0f64, 6.626_070_15e-34f64, 1.380_649e-23f64);
    2.0 * h * c * c / (l.powi(5) * ((h * c / (l * kb * kelvin)).exp() - 1.0))
}

/// The RGB of a blackbody at `kelvin`, of unit luminance; `None` unless `kelvin > 0`.
pub fn blackbody_rgb(kelvin: f64) -> Option<Rgb> {
    if !(kelvin > 0.0 && kelvin.is_finite()) {
        return None;
    }
    let xyz = integrate(|l| planck(l, kelvin));
    if !(xyz[1] > 0.0 && xyz[1].is_finite()) {
        return None;
    }
    let rgb = xyz_to_rgb([xyz[0] / xyz[1], 1.0, xyz[2] / xyz[1]]);
    Some(Rgb::new(rgb[0] as f32, rgb[1] as f32, rgb[2] as f32))
}

/// The RGB of pbrt-v4's `BlackbodySpectrum` at `kelvin` (Planck's law divided by its value
/// at its peak wavelength, not by its luminance) as pbrt-v4's default film records a
/// radiance: `M · ∫ B (x̄, ȳ, z̄) dλ`, λ in nanometres (its XYZ sensor does not normalise;
/// emitters are divided by their photometric value instead, which media's temperature
/// emission is not); `None` unless `kelvin > 0`.
pub fn blackbody_peak_rgb(kelvin: f64) -> Option<Rgb> {
    let unit = blackbody_rgb(kelvin)?;
    let peak = planck(2.897_772_1e6 / kelvin, kelvin);
    let y = integrate(|l| planck(l, kelvin) / peak)[1];
    Some(unit * y as f32)
}

/// The RGB of a spectrum given as `(λ nm, value)` pairs in increasing λ (linear between
/// them, constant beyond the ends).
pub fn sampled_rgb(pairs: &[f64]) -> Result<Rgb, String> {
    if pairs.len() < 2 || !pairs.len().is_multiple_of(2) {
        return Err(format!(
            "a sampled spectrum needs (wavelength, value) pairs, not {} numbers",
            pairs.len()
        ));
    }
    let pts: Vec<(f64, f64)> = pairs.chunks(2).map(|c| (c[0], c[1])).collect();
    if pts.windows(2).any(|w| w[1].0 <= w[0].0) {
        return Err("the wavelengths of a sampled spectrum must increase".into());
    }
    Ok(balanced_rgb(|l| interpolate(&pts, l)))
}

/// Piecewise-linear interpolation of sorted points, constant beyond the ends.
fn interpolate(pts: &[(f64, f64)], l: f64) -> f64 {
    let i = pts.partition_point(|p| p.0 < l);
    if i == 0 {
        return pts[0].1;
    }
    if i == pts.len() {
        return pts[pts.len() - 1].1;
    }
    let ((l0, v0), (l1, v1)) = (pts[i - 1], pts[i]);
    v0 + (v1 - v0) * (l - l0) / (l1 - l0)
}

/// The RGB of one of pbrt-v4's named spectra, `None` for names this renderer lacks.
pub fn named_rgb(name: &str) -> Option<Rgb> {
    NAMED
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, c)| Rgb::new(c[0], c[1], c[2]))
}

/// The index of refraction at 550 nm of one of pbrt-v4's named glasses.
pub fn named_ior(name: &str) -> Option<f32> {
    GLASSES.iter().find(|(n, _)| *n == name).map(|(_, v)| *v)
}

/// pbrt-v4's named glasses and their index at 550 nm, interpolated in pbrt-v4's tables of
/// their dispersion.
const GLASSES: &[(&str, f32)] = &[
    ("glass-BK7", 1.5185),
    ("glass-BAF10", 1.6731),
    ("glass-FK51A", 1.4878),
    ("glass-LASF9", 1.8558),
    ("glass-F5", 1.6771),
    ("glass-F10", 1.7336),
    ("glass-F11", 1.7911),
];

/// pbrt-v4's named spectra as RGB, reduced from pbrt-v4's tabulated spectra (sampled every
/// few nanometres, linear between samples) by the method of this module: metals' `eta` and `k`
/// as [`sampled_rgb`] does, illuminants as emitters of unit luminance (as [`blackbody_rgb`]).
/// Values within 10⁻⁶ of 0 are 0.
const NAMED: &[(&str, [f32; 3])] = &[
    ("metal-Ag-eta", [0.128755, 0.123146, 0.152181]),
    ("metal-Ag-k", [3.998709, 3.298955, 2.360609]),
    ("metal-Al-eta", [1.369213, 0.932635, 0.572798]),
    ("metal-Al-k", [7.643803, 6.62049, 5.318793]),
    ("metal-Au-eta", [0.121315, 0.392612, 1.586818]),
    ("metal-Au-k", [3.296351, 2.522392, 1.762161]),
    ("metal-Cu-eta", [0.16967, 0.970876, 1.212831]),
    ("metal-Cu-k", [3.236334, 2.59374, 2.355428]),
    ("metal-CuZn-eta", [0.43253, 0.514022, 1.145977]),
    ("metal-CuZn-k", [3.584465, 2.694642, 1.74976]),
    ("metal-MgO-eta", [1.734377, 1.74079, 1.754028]),
    ("metal-MgO-k", [0.0, 0.0, 0.0]),
    ("metal-TiO2-eta", [2.86958, 2.953991, 3.195051]),
    ("metal-TiO2-k", [0.000067, 0.0, 0.0007]),
    ("stdillum-A", [1.827038, 0.831531, 0.232311]),
    ("stdillum-D50", [1.084266, 1.000239, 0.749332]),
    ("stdillum-D65", [0.999488, 1.000178, 0.999747]),
    ("illum-acesD60", [1.045561, 0.99501, 0.915187]),
    ("stdillum-F1", [0.960804, 1.017124, 0.945818]),
    ("stdillum-F2", [1.346366, 0.940991, 0.564084]),
    ("stdillum-F3", [1.582357, 0.889209, 0.381791]),
    ("stdillum-F4", [1.811767, 0.832494, 0.267778]),
    ("stdillum-F5", [0.922073, 1.034044, 0.892296]),
    ("stdillum-F6", [1.322546, 0.955793, 0.487609]),
    ("stdillum-F7", [1.003849, 0.998929, 0.999273]),
    ("stdillum-F8", [1.176757, 0.975569, 0.721241]),
    ("stdillum-F9", [1.377286, 0.931171, 0.570281]),
    ("stdillum-F10", [1.175347, 0.976054, 0.720586]),
    ("stdillum-F11", [1.409558, 0.925282, 0.533534]),
    ("stdillum-F12", [1.766235, 0.845587, 0.272209]),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_spectra_keep_their_value_and_blackbodies_are_white_near_6500k() {
        let c = sampled_rgb(&[400.0, 0.7, 700.0, 0.7]).unwrap();
        assert!((c - Rgb::splat(0.7)).abs().max_element() < 1e-5, "{c}");
        let warm = blackbody_rgb(2700.0).unwrap();
        assert!(
            warm.x > warm.y && warm.y > warm.z,
            "2700 K is reddish: {warm}"
        );
        let d = blackbody_rgb(6504.0).unwrap();
        assert!((d.y - 1.0).abs() < 0.05, "unit luminance: {d}");
        assert!(
            (d - Rgb::ONE).abs().max_element() < 0.1,
            "6504 K is near white: {d}"
        );
        assert!(sampled_rgb(&[500.0, 1.0, 400.0, 1.0]).is_err());
        assert!(blackbody_rgb(-5.0).is_none());
    }
}
