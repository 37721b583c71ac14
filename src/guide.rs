//! Learned sampling of an environment light that reaches the scene through openings (a room
//! lit by the sky through its windows): the map's own importance sampling sends most light
//! samples at walls there, so the guide learns, per region of space, which blocks of the map
//! are seen, and light samples in that region choose blocks accordingly.
//!
//! # Conventions
//! - The map's importance distribution is cut into blocks ([`EnvLight::blocks`]); `r_b` is
//!   block `b`'s probability under it. In region `c` a light sample chooses block `b` with
//!   probability `P_c(b) = β·r_b + (1 − β)·q_c(b)` ([`β`](BETA) keeps every direction the map
//!   lights possible), then a direction inside the block by the map's own distribution. Its
//!   solid-angle density is `p_env(ω)·P_c(b)/r_b`, exact, so multiple importance sampling
//!   with the BSDF stays unbiased.
//! - `q_c(b) ∝ Σ lum(L)·|cos θ|/p` over the region's training light samples that reached the
//!   map through block `b` unblocked: an unbiased estimate of `∫_b L·V·|cos θ| dω`.
//! - Regions are the leaves of a k-d tree over the training samples' positions: median splits
//!   on the longest axis down to at most [`LEAF`] samples. A region where fewer than
//!   [`MIN_SEEN`] samples reached the map keeps the map's own density, drawn block-wise
//!   ([`EnvLight::start`]: a block by `r_b`, then a direction inside it).
//! - Determinism: the training paths are fixed (pixels, sample numbers, seed) and their
//!   records are combined in a fixed order, so a guide does not depend on threads, cells,
//!   passes or sample ranges.

use crate::light::env::{BlockSample, EnvLight, EnvSample};
use crate::math::{Aabb, Rgb};
use crate::sampling::Distribution1D;
use glam::{Vec2, Vec3};

/// The share of the map's own block probabilities in a region's choice.
pub const BETA: f32 = 0.3;
/// Most training samples in a region.
pub const LEAF: usize = 1024;
/// Fewest training samples that reached the map for a region to be guided.
pub const MIN_SEEN: usize = 8;

/// One training light sample of the environment: where it was taken, the block of the map it
/// went to, and `lum(L)·|cos θ|/p` if it reached the map (0 if it was blocked or faced away).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    /// The shading point, world space.
    pub p: Vec3,
    /// The block of the map the sample's direction lies in.
    pub block: u32,
    /// Its estimate of the light arriving through the block, per unit of `1/pdf`.
    pub value: f32,
}

/// Where the training paths' environment light samples go: the light and the records of one
/// run of paths.
pub struct Recorder<'a> {
    /// Index of the environment light among the scene's lights.
    pub light: usize,
    /// The environment light.
    pub env: &'a EnvLight,
    /// The records so far.
    pub records: std::cell::RefCell<Vec<Record>>,
}

impl Recorder<'_> {
    /// Records a light sample of the environment taken at `p` in direction `d` with value
    /// `value` (see [`Record`]).
    pub fn record(&self, p: Vec3, d: Vec3, value: f32) {
        let block = self.env.block_of(d) as u32;
        self.records.borrow_mut().push(Record { p, block, value });
    }
}

/// A guided light sample taken in steps: [`EnvGuide::start`] (the region), then
/// [`GuidedSample::choose_block`], whose [`BlockSample`] takes the map's steps. When each of
/// eight lanes takes a step before any takes the next, their reads overlap instead of
/// waiting one after another.
#[derive(Clone, Copy, Debug)]
pub struct GuidedSample {
    /// The region of the shading point.
    region: usize,
    /// The sample's numbers.
    u: Vec2,
}

impl GuidedSample {
    /// The second step: the block, by the region's choice (`β·r_b + (1 − β)·q_c(b)`, or the
    /// map's own `r_b` in an unguided region); its cell table is asked for. `None` where the
    /// map is sampled uniformly.
    #[inline]
    pub fn choose_block(self, guide: &EnvGuide, env: &EnvLight) -> Option<BlockSample> {
        let Some(choice) = &guide.regions[self.region] else {
            return env.start(self.u);
        };
        let (b, pmf, uy) = choice.sample(self.u.y);
        let scale = pmf / guide.own[b];
        Some(env.start_in_block(b, Some(scale), Vec2::new(self.u.x, uy)))
    }
}

/// A k-d tree node: an axis and a split position, children at `child` (below) and
/// `child + 1`; a leaf (axis 3) holds its region's index in `child`.
#[derive(Clone, Copy, Debug)]
struct Node {
    axis: u8,
    split: f32,
    child: u32,
}

/// A learned environment light sampler (see the module's conventions).
#[derive(Clone, Debug)]
pub struct EnvGuide {
    /// Index of the guided light among the scene's lights.
    light: usize,
    nodes: Vec<Node>,
    /// Per region, its block choice `P_c`; `None` keeps the map's own density.
    regions: Vec<Option<Distribution1D>>,
    /// The map's own block probabilities `r_b` (an unguided region samples by them, as the
    /// map itself does).
    own: Vec<f32>,
}

impl EnvGuide {
    /// A guide for light `light` (the environment `env`) from training records: the regions
    /// from their positions, the block choices from their values. `None` where the map is
    /// sampled uniformly or no region sees it.
    pub fn build(light: usize, env: &EnvLight, records: &[Record]) -> Option<EnvGuide> {
        let blocks = env.blocks()?;
        let mut points: Vec<Vec3> = records.iter().map(|r| r.p).collect();
        let mut nodes = vec![Node {
            axis: 3,
            split: 0.0,
            child: 0,
        }];
        let mut leaves = 0;
        split(&mut points, &mut nodes, &mut leaves, 0, 0);
        let mut guide = EnvGuide {
            light,
            nodes,
            regions: vec![None; leaves],
            own: (0..blocks.len()).map(|b| blocks.prob(b)).collect(),
        };
        guide.fit(records);
        guide.regions.iter().any(Option::is_some).then_some(guide)
    }

    /// The same regions with block choices learned from `records` (all of them: earlier
    /// training records stay valid estimates).
    pub fn refit(&self, records: &[Record]) -> EnvGuide {
        let mut guide = self.clone();
        guide.fit(records);
        guide
    }

    /// Sets every region's block choice from `records`.
    fn fit(&mut self, records: &[Record]) {
        let nb = self.own.len();
        let mut sums = vec![0f64; self.regions.len() * nb];
        let mut seen = vec![0usize; self.regions.len()];
        for r in records {
            if r.value > 0.0 && r.value.is_finite() && (r.block as usize) < nb {
                let c = self.region(r.p);
                sums[c * nb + r.block as usize] += r.value as f64;
                seen[c] += 1;
            }
        }
        for (c, region) in self.regions.iter_mut().enumerate() {
            let q = &sums[c * nb..(c + 1) * nb];
            let total: f64 = q.iter().sum();
            *region = (seen[c] >= MIN_SEEN && total > 0.0).then(|| {
                let weights: Vec<f32> = (0..nb)
                    .map(|b| {
                        let own = self.own[b] as f64;
                        let beta = BETA as f64;
                        (beta * own + (1.0 - beta) * q[b] / total) as f32
                    })
                    .collect();
                Distribution1D::new(&weights)
            });
        }
    }

    /// Index of the guided light among the scene's lights.
    pub fn light(&self) -> usize {
        self.light
    }

    /// Regions, and how many of them are guided.
    pub fn regions(&self) -> (usize, usize) {
        let guided = self.regions.iter().filter(|r| r.is_some()).count();
        (self.regions.len(), guided)
    }

    /// The region holding `p`.
    #[inline]
    fn region(&self, p: Vec3) -> usize {
        let mut n = 0;
        loop {
            let node = self.nodes[n];
            if node.axis == 3 {
                return node.child as usize;
            }
            // (An array read, not a match on the axis: no jump to mispredict.)
            let below = [p.x, p.y, p.z, p.z][usize::from(node.axis & 3)] < node.split;
            n = node.child as usize + usize::from(!below);
        }
    }

    /// A light sample of `env` for the shading point `p` from uniform numbers `u`; its `pdf`
    /// is the guided density. The steps of [`GuidedSample`] taken at once.
    #[inline]
    pub fn sample(&self, env: &EnvLight, p: Vec3, u: Vec2) -> Option<EnvSample> {
        let mut staged = self.start(p, u).choose_block(self, env)?;
        staged.choose_cell(env);
        staged.finish(env)
    }

    /// The first step of a light sample at `p` from numbers `u` (see [`GuidedSample`]): the
    /// region. (Asking for the region's block choice here measured slower: its lines crowd
    /// out the reads the later steps ask for.)
    #[inline]
    pub fn start(&self, p: Vec3, u: Vec2) -> GuidedSample {
        GuidedSample {
            region: self.region(p),
            u,
        }
    }

    /// Radiance of `env` arriving at `p` from direction `d`, and the guided density of
    /// [`EnvGuide::sample`] choosing `d` there.
    #[inline]
    pub fn radiance_pdf(&self, env: &EnvLight, p: Vec3, d: Vec3) -> (Rgb, f32) {
        let Some(choice) = &self.regions[self.region(p)] else {
            return env.radiance_pdf(d);
        };
        let (l, pdf, b) = env.radiance_pdf_block(d);
        let own = self.own[b];
        let pdf = if own > 0.0 {
            pdf * choice.pmf(b) / own
        } else {
            0.0
        };
        (l, pdf)
    }
}

/// Builds the k-d tree over `points` into node `slot`: median splits on the longest axis of
/// their bounds, a leaf (numbered by `leaves`) at [`LEAF`] points or fewer.
fn split(points: &mut [Vec3], nodes: &mut Vec<Node>, leaves: &mut usize, depth: u32, slot: usize) {
    let bounds = points.iter().fold(Aabb::EMPTY, |b, &p| b.grow(p));
    let extent = bounds.max - bounds.min;
    let axis = extent.max_position();
    let flat = extent[axis].is_nan() || extent[axis] <= 0.0;
    if points.len() <= LEAF || depth >= 40 || flat {
        nodes[slot] = Node {
            axis: 3,
            split: 0.0,
            child: *leaves as u32,
        };
        *leaves += 1;
        return;
    }
    let mid = points.len() / 2;
    points.select_nth_unstable_by(mid, |a, b| a[axis].total_cmp(&b[axis]));
    let position = points[mid][axis];
    let child = nodes.len();
    nodes[slot] = Node {
        axis: axis as u8,
        split: position,
        child: child as u32,
    };
    nodes.extend([nodes[slot]; 2]);
    let (below, above) = points.split_at_mut(mid);
    split(below, nodes, leaves, depth + 1, child);
    split(above, nodes, leaves, depth + 1, child + 1);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::image::Image;
    use crate::light::env::EnvSampling;
    use crate::sampling::chi2::{chi2_test_sphere, Chi2Config};
    use crate::sampling::Rng;

    /// A 64×32 sky: brighter overhead, a small sun.
    fn env() -> EnvLight {
        let (w, h) = (64, 32);
        let mut img = Image::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let v = 0.2 + 0.8 * (1.0 - y as f32 / h as f32) + 0.2 * (x as f32 / w as f32);
                img.pixels[y * w + x] = Vec3::new(v, v, v * 1.2);
            }
        }
        img.pixels[6 * w + 40] = Vec3::splat(200.0);
        EnvLight::new(img, EnvSampling::Importance)
    }

    /// Records around `centre`: each sees the map only through `seen` (in turn), value 1; as
    /// many again blocked.
    fn cluster(centre: Vec3, seen: &[u32], n: usize, rng: &mut Rng) -> Vec<Record> {
        (0..n)
            .map(|i| Record {
                p: centre + Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.5,
                block: seen[i % seen.len()],
                value: if i % 2 == 0 { 1.0 } else { 0.0 },
            })
            .collect()
    }

    fn guide(env: &EnvLight) -> EnvGuide {
        let mut rng = Rng::new(4, 4);
        let mut records = cluster(Vec3::ZERO, &[3, 20, 21], 3000, &mut rng);
        records.extend(cluster(Vec3::new(10.0, 0.0, 0.0), &[100], 3000, &mut rng));
        // A region that never sees the map keeps its own sampling.
        records.extend(
            cluster(Vec3::new(0.0, 10.0, 0.0), &[7], 2000, &mut rng)
                .into_iter()
                .map(|r| Record { value: 0.0, ..r }),
        );
        EnvGuide::build(0, env, &records).expect("some region sees the map")
    }

    /// At a guided point, in a region that sees another block, and in an unguided region, the
    /// guided samples follow the guided pdf (chi-square, 1% significance), which integrates
    /// to 1; the unguided region's pdf is the map's own.
    #[test]
    fn guided_samples_follow_the_guided_pdf() {
        let env = env();
        let g = guide(&env);
        let (regions, guided) = g.regions();
        assert!(
            guided >= 2 && guided < regions,
            "{guided} of {regions} regions guided"
        );
        let to = |d: Vec3| Vec3::new(d.x, -d.z, d.y);
        let back = |w: Vec3| Vec3::new(w.x, w.z, -w.y);
        for (seed, p) in [
            (1, Vec3::splat(0.25)),
            (2, Vec3::new(10.25, 0.25, 0.25)),
            (3, Vec3::new(0.25, 10.25, 0.25)),
        ] {
            let cfg = Chi2Config {
                samples: 1_000_000,
                theta_bins: 32,
                phi_bins: 64,
                resolution: 128,
                significance: 0.01 / 3.0,
                seed,
            };
            let r = chi2_test_sphere(
                &cfg,
                |u| g.sample(&env, p, u).map(|s| to(s.wi)),
                |w| g.radiance_pdf(&env, p, back(w)).1,
            )
            .unwrap_or_else(|e| panic!("at {p}: {e}"));
            assert!(
                (r.pdf_integral - 1.0).abs() < 3e-3,
                "at {p}: pdf integrates to {}",
                r.pdf_integral
            );
        }
        let mut rng = Rng::new(9, 9);
        for _ in 0..1000 {
            let d = crate::sampling::uniform_sphere(rng.next_2d());
            let own = env.pdf(d);
            let unguided = g.radiance_pdf(&env, Vec3::new(0.25, 10.25, 0.25), d).1;
            assert_eq!(own.to_bits(), unguided.to_bits());
        }
    }

    /// Where training saw the map through a few blocks, most samples go there: at least the
    /// learned share (1 − β) of them, against their far smaller share under the map's own
    /// sampling.
    #[test]
    fn samples_go_where_the_map_was_seen() {
        let env = env();
        let g = guide(&env);
        let blocks = env.blocks().unwrap();
        let own: f32 = [3, 20, 21].iter().map(|&b| blocks.prob(b)).sum();
        let mut rng = Rng::new(5, 6);
        let n = 20_000;
        let inside = (0..n)
            .filter_map(|_| g.sample(&env, Vec3::splat(0.25), rng.next_2d()))
            .filter(|s| [3, 20, 21].contains(&env.block_of(s.wi)))
            .count();
        let share = inside as f32 / n as f32;
        assert!(
            share > 1.0 - BETA - 0.02,
            "{share} of samples in the seen blocks"
        );
        assert!(own < 0.2, "the map's own share {own}");
    }

    /// The k-d tree puts every record in the region a lookup finds, with at most LEAF records
    /// in each, and the same records give the same guide.
    #[test]
    fn regions_partition_the_records() {
        let env = env();
        let mut rng = Rng::new(7, 7);
        let records: Vec<Record> = (0..20_000)
            .map(|i| Record {
                p: Vec3::new(rng.next_f32(), rng.next_f32() * 0.1, rng.next_f32()) * 4.0,
                block: (i % 128) as u32,
                value: 1.0,
            })
            .collect();
        let g = EnvGuide::build(0, &env, &records).unwrap();
        let mut count = vec![0usize; g.regions.len()];
        for r in &records {
            count[g.region(r.p)] += 1;
        }
        assert!(count.iter().all(|&c| c <= LEAF), "{:?}", count.iter().max());
        assert!(g.regions.len() >= records.len() / LEAF);
        let again = EnvGuide::build(0, &env, &records).unwrap();
        let mut rng = Rng::new(8, 8);
        for _ in 0..1000 {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0;
            let u = rng.next_2d();
            assert_eq!(
                g.sample(&env, p, u).map(|s| (s.wi, s.pdf)),
                again.sample(&env, p, u).map(|s| (s.wi, s.pdf))
            );
        }
    }
}
