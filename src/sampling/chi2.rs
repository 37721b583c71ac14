//! Chi-square goodness-of-fit harness for direction samplers.
//!
//! The sphere is cut into `theta_bins × phi_bins` cells of equal solid angle (uniform in
//! `cos θ` and `φ`, with `θ` measured from +Z). Observed counts from the sampler are compared
//! with counts expected from integrating its pdf over each cell (a midpoint rule on a fine
//! sub-grid). Cells expecting fewer than 5 samples are pooled. The statistic is tested against
//! the chi-square distribution with `cells − 1` degrees of freedom.

use super::Rng;
use glam::{Vec2, Vec3};
use std::f64::consts::PI;

/// Parameters of one chi-square test.
#[derive(Clone, Debug)]
pub struct Chi2Config {
    /// Number of samples drawn.
    pub samples: usize,
    /// Cells along `cos θ` (from −1 to 1).
    pub theta_bins: usize,
    /// Cells along `φ` (from 0 to 2π).
    pub phi_bins: usize,
    /// Sub-grid resolution per cell and axis for integrating the pdf.
    pub resolution: usize,
    /// Significance level of this single test (already corrected for multiple tests by the caller).
    pub significance: f64,
    /// Seed of the sample stream.
    pub seed: u64,
}

impl Chi2Config {
    /// A million samples on a fine grid (80 × 160 cells, 16² points per cell for the pdf's
    /// integral), for peaked densities (microfacet lobes), at `significance`.
    pub fn fine(significance: f64, seed: u64) -> Self {
        Chi2Config {
            samples: 1_000_000,
            theta_bins: 80,
            phi_bins: 160,
            resolution: 16,
            significance,
            seed,
        }
    }
}

impl Default for Chi2Config {
    fn default() -> Self {
        Chi2Config {
            samples: 1_000_000,
            theta_bins: 10,
            phi_bins: 20,
            resolution: 8,
            significance: 0.01,
            seed: 1,
        }
    }
}

/// Outcome of a passing test.
#[derive(Clone, Debug)]
pub struct Chi2Result {
    /// The statistic.
    pub chi2: f64,
    /// Degrees of freedom.
    pub dof: usize,
    /// Probability of a statistic at least this large if the sampler follows its pdf.
    pub p_value: f64,
    /// Integral of the pdf over the sphere (1 for a sampler that never fails).
    pub pdf_integral: f64,
}

fn cell_of(w: Vec3, tb: usize, pb: usize) -> Option<usize> {
    if !w.is_finite() {
        return None;
    }
    let z = w.z.clamp(-1.0, 1.0) as f64;
    let t = (((z + 1.0) * 0.5 * tb as f64) as usize).min(tb - 1);
    let mut phi = (w.y as f64).atan2(w.x as f64);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let p = ((phi / (2.0 * PI) * pb as f64) as usize).min(pb - 1);
    Some(t * pb + p)
}

/// [`chi2_test_sphere`] with the sphere turned so that the xz-plane (a plane of incidence)
/// lies on the equator, where the cells are finest: lobes sharper than the polar cells
/// (reflection and refraction around the normal) are resolved wherever they point in that
/// plane.
pub fn chi2_test_sphere_equatorial(
    cfg: &Chi2Config,
    mut sample: impl FnMut(Vec2) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f32,
) -> Result<Chi2Result, String> {
    let to = |v: Vec3| Vec3::new(v.x, v.z, -v.y);
    let back = |w: Vec3| Vec3::new(w.x, -w.z, w.y);
    chi2_test_sphere(cfg, |u| sample(u).map(to), |w| pdf(back(w)))
}

/// Runs the test. `sample` maps a uniform point of the unit square to a unit direction (or
/// `None` when the sampler fails, e.g. on absorption); `pdf` is its density in solid angle.
/// Returns `Err` with a description when the histogram does not fit or the pdf is invalid.
pub fn chi2_test_sphere(
    cfg: &Chi2Config,
    mut sample: impl FnMut(Vec2) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f32,
) -> Result<Chi2Result, String> {
    let (tb, pb) = (cfg.theta_bins, cfg.phi_bins);
    let cells = tb * pb;
    let mut observed = vec![0f64; cells];
    let mut rng = Rng::new(cfg.seed, 0xC415);
    for _ in 0..cfg.samples {
        if let Some(w) = sample(rng.next_2d()) {
            let len = w.length();
            if (len - 1.0).abs() > 1e-3 {
                return Err(format!("sample {w} is not a unit vector"));
            }
            if let Some(c) = cell_of(w, tb, pb) {
                observed[c] += 1.0;
            }
        }
    }
    // Expected counts: midpoint rule in (cos θ, φ); the Jacobian of that map is 1.
    let res = cfg.resolution;
    let dz = 2.0 / (tb * res) as f64;
    let dphi = 2.0 * PI / (pb * res) as f64;
    let mut expected = vec![0f64; cells];
    let mut integral = 0.0;
    for t in 0..tb * res {
        let z = -1.0 + (t as f64 + 0.5) * dz;
        let r = (1.0 - z * z).max(0.0).sqrt();
        for p in 0..pb * res {
            let phi = (p as f64 + 0.5) * dphi;
            let w = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
            let v = pdf(w) as f64;
            if !v.is_finite() || v < 0.0 {
                return Err(format!(
                    "pdf({w}) = {v} is not a finite non-negative number"
                ));
            }
            let m = v * dz * dphi;
            expected[(t / res) * pb + p / res] += m;
            integral += m;
        }
    }
    if integral > 1.0 + 1e-2 {
        return Err(format!("pdf integrates to {integral:.4} > 1"));
    }
    for e in &mut expected {
        *e *= cfg.samples as f64;
    }
    // Pool small cells, then sum (O − E)² / E.
    let mut order: Vec<usize> = (0..cells).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pool_o, mut pool_e, mut chi2, mut dof_cells) = (0.0, 0.0, 0.0, 0usize);
    for &c in &order {
        if expected[c] < 5.0 || pool_e > 0.0 && pool_e < 5.0 {
            pool_o += observed[c];
            pool_e += expected[c];
            continue;
        }
        chi2 += (observed[c] - expected[c]).powi(2) / expected[c];
        dof_cells += 1;
    }
    if pool_e > 0.0 {
        chi2 += (pool_o - pool_e).powi(2) / pool_e;
        dof_cells += 1;
    } else if pool_o > 0.0 {
        return Err(format!("{pool_o} samples landed where the pdf is zero"));
    }
    let dof = dof_cells.saturating_sub(1).max(1);
    let p_value = chi2_survival(chi2, dof as f64);
    let result = Chi2Result {
        chi2,
        dof,
        p_value,
        pdf_integral: integral,
    };
    if p_value < cfg.significance {
        // Name the worst cells (centre direction, observed, expected) to help find the cause.
        let mut worst: Vec<(f64, usize)> = (0..cells)
            .filter(|&c| expected[c] >= 5.0)
            .map(|c| ((observed[c] - expected[c]).powi(2) / expected[c], c))
            .collect();
        worst.sort_by(|a, b| b.0.total_cmp(&a.0));
        let desc: Vec<String> = worst
            .iter()
            .take(4)
            .map(|&(_, c)| {
                let z = -1.0 + ((c / pb) as f64 + 0.5) * 2.0 / tb as f64;
                let phi = ((c % pb) as f64 + 0.5) * 2.0 * PI / pb as f64;
                format!(
                    "cell z={z:.3} φ={phi:.3}: observed {} expected {:.1}",
                    observed[c], expected[c]
                )
            })
            .collect();
        return Err(format!(
            "chi-square rejects the sampler: {result:?}; worst cells: {}",
            desc.join("; ")
        ));
    }
    Ok(result)
}

/// `P(X ≥ x)` for a chi-square variable with `k` degrees of freedom.
pub fn chi2_survival(x: f64, k: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    regularized_gamma_q(k / 2.0, x / 2.0)
}

fn ln_gamma(x: f64) -> f64 {
    // Lanczos approximation (g = 7, n = 9).
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Upper regularised incomplete gamma function `Q(a, x)`.
fn regularized_gamma_q(a: f64, x: f64) -> f64 {
    if x < a + 1.0 {
        // Series for P, then Q = 1 − P.
        let mut sum = 1.0 / a;
        let mut term = sum;
        let mut n = a;
        for _ in 0..1000 {
            n += 1.0;
            term *= x / n;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - ln_gamma(a)).exp()
    } else {
        // Continued fraction (modified Lentz).
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (-x + a * x.ln() - ln_gamma(a)).exp() * h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn survival_function_matches_tables() {
        // Critical values from standard chi-square tables.
        assert!((chi2_survival(3.841, 1.0) - 0.05).abs() < 1e-3);
        assert!((chi2_survival(18.307, 10.0) - 0.05).abs() < 1e-3);
        assert!((chi2_survival(124.342, 100.0) - 0.05).abs() < 1e-3);
        assert!((chi2_survival(2.0, 2.0) - (-1.0f64).exp()).abs() < 1e-9);
    }
}
