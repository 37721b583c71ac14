//! The `--info` summary of a built scene.

use crate::scene::Scene;
use std::fmt::Write;

fn by_type(list: &[(String, usize)]) -> String {
    if list.is_empty() {
        return "none".into();
    }
    list.iter()
        .map(|(k, n)| format!("{n} {k}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A multi-line, human-readable summary: triangles, spheres, lights and materials by type,
/// camera and bounding box.
pub fn summary(scene: &Scene) -> String {
    let mut s = String::new();
    let st = &scene.stats;
    let v = |p: glam::Vec3| format!("({:.4}, {:.4}, {:.4})", p.x, p.y, p.z);
    let _ = writeln!(s, "scene        {}", scene.name);
    let _ = writeln!(
        s,
        "triangles    {} in {} meshes{}",
        st.mesh_triangles,
        st.meshes,
        if st.degenerate > 0 {
            format!(" ({} degenerate dropped)", st.degenerate)
        } else {
            String::new()
        }
    );
    if st.instances > 0 {
        let shared: usize = scene.prototypes.iter().map(|p| p.tris.len()).sum();
        let _ = writeln!(
            s,
            "instances    {} of {} objects ({} shared triangles, held once)",
            st.instances,
            scene.prototypes.len(),
            shared
        );
    }
    let _ = writeln!(s, "spheres      {}", scene.spheres.len());
    let nlights: usize = st.lights_by_type.iter().map(|x| x.1).sum();
    let _ = writeln!(
        s,
        "lights       {} ({})",
        nlights,
        by_type(&st.lights_by_type)
    );
    let nmat: usize = st.materials_by_type.iter().map(|x| x.1).sum();
    let _ = writeln!(
        s,
        "materials    {} ({})",
        nmat,
        by_type(&st.materials_by_type)
    );
    if !st.plugins.is_empty() {
        let _ = writeln!(s, "plugins      {}", st.plugins.join(", "));
    }
    let c = &scene.camera;
    let _ = writeln!(
        s,
        "camera       eye {} looking {} up {}",
        v(c.pos),
        v(c.forward),
        v(c.up)
    );
    let _ = writeln!(
        s,
        "             hfov {:.3}° vfov {:.3}° (800×600 window), screen distance {:.1} px",
        c.hfov_deg, c.vfov_deg, c.focal_px
    );
    let b = &scene.bounds;
    if b.is_empty() {
        let _ = writeln!(s, "bounding box empty");
    } else {
        let _ = writeln!(
            s,
            "bounding box min {} max {} (diagonal {:.4})",
            v(b.min),
            v(b.max),
            b.extent().length()
        );
    }
    let _ = writeln!(
        s,
        "BVH          {} nodes over {} triangles in {} packs of 4; {} nodes over {} spheres",
        scene.tri_bvh.bvh.nodes.len(),
        scene.tris.len(),
        scene.tri_bvh.packs.len(),
        scene.sphere_bvh.nodes.len(),
        scene.spheres.len()
    );
    s
}

/// The process's peak resident memory in bytes (Linux `VmHWM`), if the system reports it.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// The peak resident memory as text (`"123.4 MiB"`, or `"unknown"`).
pub fn peak_rss_text() -> String {
    peak_rss_bytes().map_or("unknown".into(), |b| {
        format!("{:.1} MiB", b as f64 / (1024.0 * 1024.0))
    })
}
