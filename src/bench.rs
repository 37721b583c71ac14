//! `pathtracer bench`: BVH build time and ray throughput on a scene's triangles.
//!
//! Two fixed ray sets over the triangles (node transforms applied, spheres and lights left out):
//! (a) coherent: 1024×1024 pinhole rays, 45° field of view, aimed at the centre of the
//! triangles' bounding box from the direction of the scene's CS184 camera, at the nearest
//! distance that keeps all eight box corners in view; (b) incoherent: 2,000,000 rays with
//! origins uniform in the box and uniformly distributed directions (fixed seed).
//!
//! Two more sets start on surfaces, as a path tracer's rays after the camera's do (most of a
//! render's rays): from the first hit of each ray of the scene's own view (its camera where
//! the file places it exactly, 512×512 rays over its field of view; else the coherent set),
//! (c) a bounce, cosine-distributed about the geometric normal on the side the camera ray
//! came from (closest-hit), and (d) a shadow ray towards a uniformly chosen point of a
//! uniformly chosen triangle, ending just short of it (any-hit with a finite `t_max`, as
//! light-sampling rays).

use crate::accel::tribvh::TriangleBvh;
use crate::camera::{cs184_direction, Camera};
use crate::geometry::Triangle;
use crate::io::desc::{SceneDesc, ShapeDesc};
use crate::math::{offset_origin, Aabb, Frame, Ray};
use crate::sampling::{cosine_hemisphere, uniform_sphere, uniform_triangle, Rng};
use glam::Vec3;
use rayon::prelude::*;
use std::fmt;
use std::time::Instant;

/// Resolution of the coherent ray set (square).
pub const COHERENT_RES: usize = 1024;
/// Number of rays in the incoherent set.
pub const INCOHERENT_RAYS: usize = 2_000_000;

/// A displaced UV sphere of about `n` triangles (`4·rows²`, with `2·rows` columns): a
/// deterministic test mesh for scaling measurements, with a camera looking down −Z.
pub fn synthetic(n: usize) -> SceneDesc {
    use crate::error::Loc;
    use crate::io::desc::{CameraDesc, MaterialDesc, MaterialKind};
    use glam::Mat4;
    use std::f32::consts::PI;
    let rows = ((n as f64 / 4.0).sqrt().round() as usize).max(2);
    let cols = 2 * rows;
    let mut positions = Vec::with_capacity((rows + 1) * cols);
    for i in 0..=rows {
        let theta = PI * i as f32 / rows as f32;
        for j in 0..cols {
            let phi = 2.0 * PI * j as f32 / cols as f32;
            let r = 1.0
                + 0.08 * (7.0 * theta).sin() * (5.0 * phi).sin()
                + 0.03 * (31.0 * theta + 17.0 * phi).sin();
            positions.push(Vec3::new(
                r * theta.sin() * phi.cos(),
                r * theta.cos(),
                r * theta.sin() * phi.sin(),
            ));
        }
    }
    let mut triangles = Vec::with_capacity(2 * rows * cols);
    for i in 0..rows {
        for j in 0..cols {
            let (a, b) = ((i * cols + j) as u32, (i * cols + (j + 1) % cols) as u32);
            let (c, d) = (a + cols as u32, b + cols as u32);
            triangles.push([a, c, b]);
            triangles.push([b, c, d]);
        }
    }
    let materials = vec![0; triangles.len()];
    SceneDesc {
        name: format!("synthetic{}", triangles.len()),
        file: "<synthetic>".into(),
        materials: vec![MaterialDesc {
            name: "grey".into(),
            kind: MaterialKind::Diffuse {
                albedo: Vec3::splat(0.5),
            },
            emission: Vec3::ZERO,
            loc: Loc::default(),
            one_sided: false,
            interface: None,
        }],
        shapes: vec![ShapeDesc::Mesh {
            normals: crate::io::desc::MeshNormals::Smooth,
            uvs: Vec::new(),
            one_sided: false,
            name: "sphere".into(),
            positions,
            triangles,
            materials,
            transform: Mat4::IDENTITY,
            loc: Loc::default(),
        }],
        camera: Some(CameraDesc {
            exact: false,
            fov_axis: crate::io::desc::FovAxis::Height,
            right_is_x: false,
            lens: None,
            orthographic: false,
            name: "camera".into(),
            xfov_deg: Some(45.0),
            yfov_deg: None,
            aspect: Some(1.0),
            znear: 0.01,
            zfar: 100.0,
            transform: Mat4::from_translation(Vec3::new(0.0, 0.0, 2.0)),
            loc: Loc::default(),
        }),
        ..Default::default()
    }
}

/// Writes `values` as a NumPy `.npy` file (version 1.0, little-endian `<f4`, C order, shape
/// `(values.len() / width, width)`).
pub fn write_npy(path: &std::path::Path, width: usize, values: &[f32]) -> crate::error::Result<()> {
    let rows = values.len() / width.max(1);
    let mut header =
        format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({rows}, {width}), }}");
    // Magic (6) + version (2) + length (2) + header + newline, padded to a multiple of 64.
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut bytes = Vec::with_capacity(10 + header.len() + values.len() * 4);
    bytes.extend_from_slice(b"\x93NUMPY\x01\x00");
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    for v in values {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    crate::io::atomic::write(path, "cannot write", |w| {
        std::io::Write::write_all(w, &bytes)
    })
}

/// Writes the benchmark's inputs for other ray tracers: `triangles.npy` (T×9: three vertices),
/// and `coherent_{origins,directions}.npy`, `incoherent_{origins,directions}.npy` (N×3).
pub fn export_npy(desc: &SceneDesc, dir: &std::path::Path) -> crate::error::Result<()> {
    std::fs::create_dir_all(dir).map_err(|source| crate::error::Error::Io {
        path: dir.display().to_string(),
        what: "cannot create directory",
        source,
    })?;
    let tris = triangles(desc);
    let flat: Vec<f32> = tris
        .iter()
        .flat_map(|t| t.v.iter().flat_map(|v| v.to_array()))
        .collect();
    write_npy(&dir.join("triangles.npy"), 9, &flat)?;
    let bounds = tris.iter().fold(Aabb::EMPTY, |a, t| a.union(&t.bounds()));
    for (name, rays) in ray_sets(desc, &tris, &TriangleBvh::build(&tris), &bounds) {
        let o: Vec<f32> = rays.iter().flat_map(|r| r.o.to_array()).collect();
        let d: Vec<f32> = rays.iter().flat_map(|r| r.d.to_array()).collect();
        let t: Vec<f32> = rays.iter().map(|r| r.t_max).collect();
        write_npy(&dir.join(format!("{name}_origins.npy")), 3, &o)?;
        write_npy(&dir.join(format!("{name}_directions.npy")), 3, &d)?;
        write_npy(&dir.join(format!("{name}_tmax.npy")), 1, &t)?;
    }
    Ok(())
}

/// The four ray sets by name (`coherent`, `incoherent`, `bounce`, `shadow`) for `tris` (of
/// `desc`, in `bvh`, within `bounds`).
fn ray_sets(
    desc: &SceneDesc,
    tris: &[Triangle],
    bvh: &TriangleBvh,
    bounds: &Aabb,
) -> [(&'static str, Vec<Ray>); 4] {
    let coherent = coherent_rays(desc, bounds);
    let view = view_rays(desc);
    let (bounce, shadow) = surface_rays(bvh, tris, view.as_deref().unwrap_or(&coherent));
    [
        ("coherent", coherent),
        ("incoherent", incoherent_rays(bounds)),
        ("bounce", bounce),
        ("shadow", shadow),
    ]
}

/// Triangles of all meshes in world space.
pub fn triangles(desc: &SceneDesc) -> Vec<Triangle> {
    let mut out = Vec::new();
    for s in &desc.shapes {
        if let ShapeDesc::Mesh {
            positions,
            triangles,
            transform,
            ..
        } = s
        {
            let w: Vec<Vec3> = positions
                .iter()
                .map(|p| transform.transform_point3(*p))
                .collect();
            out.extend(triangles.iter().map(|t| Triangle {
                v: [w[t[0] as usize], w[t[1] as usize], w[t[2] as usize]],
            }));
        }
    }
    out
}

/// The coherent ray set (row-major, top row first).
pub fn coherent_rays(desc: &SceneDesc, bounds: &Aabb) -> Vec<Ray> {
    let back = cs184_direction(desc.camera.as_ref());
    let c = bounds.center();
    // The orientation of a camera looking at the centre from that direction.
    let frame = Camera::look_at(c + back, c, 45.0, 45.0);
    let (forward, right, up) = (frame.forward, frame.right, frame.up);
    let tan = (22.5f32).to_radians().tan();
    // Nearest distance keeping every corner inside the ±22.5° frustum on both axes.
    let dist = bounds
        .corners()
        .iter()
        .map(|&p| {
            let o = p - c;
            o.dot(back) + o.dot(right).abs().max(o.dot(up).abs()) / tan
        })
        .fold(0.0f32, f32::max)
        .max(1e-3);
    let eye = c + back * dist;
    let n = COHERENT_RES;
    (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32 + 0.5, (i / n) as f32 + 0.5);
            let sx = (2.0 * x / n as f32 - 1.0) * tan;
            let sy = (1.0 - 2.0 * y / n as f32) * tan;
            Ray::new(eye, (forward + right * sx + up * sy).normalize())
        })
        .collect()
}

/// Side of the square grid of [`view_rays`].
const VIEW_RES: usize = 512;

/// Rays through a square grid over the field of view of the scene's camera, where the file
/// places it exactly (see [`crate::io::desc::CameraDesc::exact`]); `None` otherwise.
fn view_rays(desc: &SceneDesc) -> Option<Vec<Ray>> {
    let cam = desc.camera.as_ref().filter(|c| c.exact)?;
    let eye = cam.transform.transform_point3(Vec3::ZERO);
    let forward = cam
        .transform
        .transform_vector3(-Vec3::Z)
        .normalize_or_zero();
    let right = forward
        .cross(cam.transform.transform_vector3(Vec3::Y))
        .normalize_or_zero();
    let up = right.cross(forward);
    let tan = (0.5 * cam.yfov_deg.unwrap_or(45.0)).to_radians().tan();
    let aspect = cam.aspect.unwrap_or(1.0);
    let n = VIEW_RES;
    let rays: Vec<Ray> = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32 + 0.5, (i / n) as f32 + 0.5);
            let sx = (2.0 * x / n as f32 - 1.0) * tan * aspect;
            let sy = (1.0 - 2.0 * y / n as f32) * tan;
            Ray::new(eye, (forward + right * sx + up * sy).normalize())
        })
        .collect();
    rays.iter().all(|r| r.d.is_finite()).then_some(rays)
}

/// The incoherent ray set.
pub fn incoherent_rays(bounds: &Aabb) -> Vec<Ray> {
    let mut rng = Rng::new(2024, 7);
    (0..INCOHERENT_RAYS)
        .map(|_| {
            let o = bounds.min
                + bounds.extent() * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            Ray::new(o, uniform_sphere(rng.next_2d()))
        })
        .collect()
}

/// The bounce and shadow ray sets (c and d of the module documentation) from the first hits
/// of `camera` rays through `bvh` over `tris`.
pub fn surface_rays(bvh: &TriangleBvh, tris: &[Triangle], camera: &[Ray]) -> (Vec<Ray>, Vec<Ray>) {
    let mut rng = Rng::new(2024, 11);
    let mut bounces = Vec::new();
    let mut shadows = Vec::new();
    for ray in camera {
        let Some(hit) = bvh.closest(ray) else {
            continue;
        };
        let tri = &tris[hit.prim as usize];
        let ng = (tri.v[1] - tri.v[0])
            .cross(tri.v[2] - tri.v[0])
            .normalize_or_zero();
        if ng == Vec3::ZERO {
            continue;
        }
        let ng = if ng.dot(ray.d) < 0.0 { ng } else { -ng };
        let p = ray.at(hit.t);
        let d = Frame::from_normal(ng).to_world(cosine_hemisphere(rng.next_2d()));
        bounces.push(Ray::new(offset_origin(p, ng, d), d));
        let target = &tris[(rng.next_f32() * tris.len() as f32) as usize % tris.len()];
        let b = uniform_triangle(rng.next_2d());
        let q = target.v[0] * (1.0 - b.x - b.y) + target.v[1] * b.x + target.v[2] * b.y;
        let o = offset_origin(p, ng, q - p);
        let to = q - o;
        let dist = to.length();
        if dist > 0.0 {
            let mut r = Ray::new(o, to / dist);
            r.t_max = dist * (1.0 - 1e-4);
            shadows.push(r);
        }
    }
    (bounces, shadows)
}

/// Closest hit distance of `ray` through `bvh`, or `ray.t_max` (∞ for the bench's rays).
pub fn closest(bvh: &TriangleBvh, ray: &Ray) -> f32 {
    bvh.closest(ray).map_or(ray.t_max, |h| h.t)
}

/// Whether `ray` hits any triangle of `bvh`.
pub fn any_hit(bvh: &TriangleBvh, ray: &Ray) -> bool {
    bvh.any(ray)
}

/// Throughput of one query over one ray set.
#[derive(Clone, Debug)]
pub struct Throughput {
    /// Million rays per second on one thread.
    pub single: f64,
    /// Million rays per second on all threads.
    pub multi: f64,
    /// Fraction of rays that hit.
    pub hit_fraction: f64,
}

/// The benchmark's figures.
#[derive(Clone, Debug)]
pub struct BenchReport {
    /// Scene name.
    pub name: String,
    /// Triangle count.
    pub triangles: usize,
    /// BVH nodes.
    pub nodes: usize,
    /// Bytes of the built structure (nodes and triangle packs, vertices included) per triangle.
    pub bytes_per_triangle: f64,
    /// Best BVH build time of three, milliseconds.
    pub build_ms: f64,
    /// Threads of the multi-threaded runs.
    pub threads: usize,
    /// By ray set and query: coherent and incoherent closest-hit and any-hit, bounce
    /// closest-hit, shadow any-hit.
    pub results: Vec<(String, Throughput)>,
}

fn measure(
    rays: &[Ray],
    pool: &rayon::ThreadPool,
    f: &(dyn Fn(&Ray) -> bool + Sync),
) -> Throughput {
    let time = |multi: bool| {
        let mut best = f64::INFINITY;
        let mut hits = 0;
        for _ in 0..3 {
            let t = Instant::now();
            hits = if multi {
                pool.install(|| {
                    rays.par_chunks(4096)
                        .map(|c| c.iter().filter(|r| f(r)).count())
                        .sum()
                })
            } else {
                rays.iter().filter(|r| f(r)).count()
            };
            best = best.min(t.elapsed().as_secs_f64());
        }
        (rays.len() as f64 / best / 1e6, hits)
    };
    let (single, hits) = time(false);
    let (multi, _) = time(true);
    Throughput {
        single,
        multi,
        hit_fraction: hits as f64 / rays.len().max(1) as f64,
    }
}

/// Runs the benchmark on `threads` threads (and on one).
pub fn run(desc: &SceneDesc, threads: usize) -> crate::error::Result<BenchReport> {
    let tris = triangles(desc);
    let mut build_ms = f64::INFINITY;
    let mut bvh = TriangleBvh::default();
    for _ in 0..3 {
        let t = Instant::now();
        bvh = TriangleBvh::build(&tris);
        build_ms = build_ms.min(t.elapsed().as_secs_f64() * 1e3);
    }
    let scene_bounds = tris.iter().fold(Aabb::EMPTY, |a, t| a.union(&t.bounds()));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| crate::error::Error::Usage(e.to_string()))?;
    let ch = |r: &Ray| closest(&bvh, r) < r.t_max;
    let ah = |r: &Ray| any_hit(&bvh, r);
    let mut results = Vec::new();
    for (name, rays) in ray_sets(desc, &tris, &bvh, &scene_bounds) {
        // The shadow set is an any-hit workload; the bounce set a closest-hit one.
        if name != "shadow" {
            results.push((format!("{name} closest-hit"), measure(&rays, &pool, &ch)));
        }
        if name != "bounce" {
            results.push((format!("{name} any-hit"), measure(&rays, &pool, &ah)));
        }
    }
    let bytes = bvh.bytes();
    Ok(BenchReport {
        name: desc.name.clone(),
        triangles: tris.len(),
        nodes: bvh.bvh.nodes.len(),
        bytes_per_triangle: bytes as f64 / tris.len().max(1) as f64,
        build_ms,
        threads,
        results,
    })
}

impl fmt::Display for BenchReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "scene {}: {} triangles, {} BVH nodes",
            self.name, self.triangles, self.nodes
        )?;
        writeln!(
            f,
            "BVH build: {:.2} ms (best of 3); {:.1} bytes per triangle (nodes and triangle packs)",
            self.build_ms, self.bytes_per_triangle
        )?;
        writeln!(
            f,
            "{:<24} {:>12} {:>14} {:>8}",
            "rays",
            "1 thread",
            format!("{} threads", self.threads),
            "hits"
        )?;
        for (name, t) in &self.results {
            writeln!(
                f,
                "{:<24} {:>7.2} Mr/s {:>9.2} Mr/s {:>7.1}%",
                name,
                t.single,
                t.multi,
                t.hit_fraction * 100.0
            )?;
        }
        Ok(())
    }
}
