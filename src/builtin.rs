//! The built-in scene: a Cornell box defined by this project (its own geometry and materials),
//! rendered when no scene file is given.

use crate::error::Loc;
use crate::io::desc::*;
use glam::{Mat4, Vec3};

/// Name of the built-in scene (also the default output name).
pub const NAME: &str = "cornell";

fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    (vec![a, b, c, d], vec![[0, 1, 2], [0, 2, 3]])
}

fn mesh(
    name: &str,
    (positions, triangles): (Vec<Vec3>, Vec<[u32; 3]>),
    material: u32,
    transform: Mat4,
) -> ShapeDesc {
    let materials = vec![material; triangles.len()];
    ShapeDesc::Mesh {
        normals: crate::io::desc::MeshNormals::Smooth,
        uvs: Vec::new(),
        one_sided: false,
        name: name.into(),
        positions,
        triangles,
        materials,
        transform,
        loc: Loc::default(),
    }
}

/// An axis-aligned box from `-half` to `half`: 24 vertices (four per face, so that the
/// recomputed normals are flat) and 12 outward-facing triangles.
pub fn cuboid(half: Vec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let p = |i: u32| {
        Vec3::new(
            if i & 1 == 0 { -half.x } else { half.x },
            if i & 2 == 0 { -half.y } else { half.y },
            if i & 4 == 0 { -half.z } else { half.z },
        )
    };
    let faces: [[u32; 4]; 6] = [
        [0, 4, 6, 2],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 2, 3, 1],
        [4, 5, 7, 6],
    ];
    // Each face has its own four vertices so that the recomputed vertex normals stay flat.
    let positions = faces.iter().flat_map(|f| f.map(p)).collect();
    let triangles = (0..6u32)
        .flat_map(|i| [[4 * i, 4 * i + 1, 4 * i + 2], [4 * i, 4 * i + 2, 4 * i + 3]])
        .collect();
    (positions, triangles)
}

/// The built-in Cornell box: a 2×2×2 room (floor at y = 0), white floor, ceiling and back
/// wall, red left and green right walls, a ceiling area light, a rotated tall block and a
/// sphere. The camera looks down −Z.
pub fn cornell_box() -> SceneDesc {
    SceneDesc {
        camera_medium: None,
        name: NAME.into(),
        file: "<built-in cornell box>".into(),
        materials: cornell_materials(),
        shapes: cornell_shapes(),
        lights: vec![ceiling_light()],
        camera: Some(cornell_camera()),
        warnings: Vec::new(),
        textures: Vec::new(),
        sources: Vec::new(),
        options: Vec::new(),
        objects: Vec::new(),
        instances: Vec::new(),
        media: Vec::new(),
        plugins: Vec::new(),
        format: Format::Collada,
    }
}

/// The box's diffuse materials, by id: white, red, green, block and sphere.
fn cornell_materials() -> Vec<MaterialDesc> {
    let mat = |name: &str, kind: MaterialKind| MaterialDesc {
        name: name.into(),
        kind,
        emission: Vec3::ZERO,
        loc: Loc::default(),
        one_sided: false,
        interface: None,
    };
    let diffuse = |c: Vec3| MaterialKind::Diffuse { albedo: c };
    vec![
        mat("white", diffuse(Vec3::new(0.73, 0.73, 0.73))),
        mat("red", diffuse(Vec3::new(0.63, 0.065, 0.05))),
        mat("green", diffuse(Vec3::new(0.14, 0.45, 0.09))),
        mat("block", diffuse(Vec3::new(0.7, 0.7, 0.65))),
        mat("sphere", diffuse(Vec3::new(0.3, 0.45, 0.75))),
    ]
}

/// The box's shapes: floor, ceiling, back, left and right walls, the rotated block and the
/// ball.
fn cornell_shapes() -> Vec<ShapeDesc> {
    let v = Vec3::new;
    let mut shapes = room_walls();
    shapes.push(mesh(
        "block",
        cuboid(v(0.28, 0.55, 0.28)),
        3,
        Mat4::from_translation(v(-0.4, 0.55, -0.35)) * Mat4::from_rotation_y(0.3),
    ));
    shapes.push(ShapeDesc::Sphere {
        name: "ball".into(),
        radius: 0.35,
        material: 4,
        transform: Mat4::from_translation(v(0.45, 0.35, 0.3)),
        side: crate::io::desc::EmitSide::Both,
        loc: Loc::default(),
    });
    shapes
}

/// The room's five quads: white floor, ceiling and back wall, red left and green right
/// walls.
fn room_walls() -> Vec<ShapeDesc> {
    let v = Vec3::new;
    let id = Mat4::IDENTITY;
    vec![
        mesh(
            "floor",
            quad(
                v(-1.0, 0.0, -1.0),
                v(-1.0, 0.0, 1.0),
                v(1.0, 0.0, 1.0),
                v(1.0, 0.0, -1.0),
            ),
            0,
            id,
        ),
        mesh(
            "ceiling",
            quad(
                v(-1.0, 2.0, -1.0),
                v(1.0, 2.0, -1.0),
                v(1.0, 2.0, 1.0),
                v(-1.0, 2.0, 1.0),
            ),
            0,
            id,
        ),
        mesh(
            "back",
            quad(
                v(-1.0, 0.0, -1.0),
                v(1.0, 0.0, -1.0),
                v(1.0, 2.0, -1.0),
                v(-1.0, 2.0, -1.0),
            ),
            0,
            id,
        ),
        mesh(
            "left",
            quad(
                v(-1.0, 0.0, -1.0),
                v(-1.0, 2.0, -1.0),
                v(-1.0, 2.0, 1.0),
                v(-1.0, 0.0, 1.0),
            ),
            1,
            id,
        ),
        mesh(
            "right",
            quad(
                v(1.0, 0.0, -1.0),
                v(1.0, 0.0, 1.0),
                v(1.0, 2.0, 1.0),
                v(1.0, 2.0, -1.0),
            ),
            2,
            id,
        ),
    ]
}

/// The area light: a 0.6 × 0.5 rectangle just under the ceiling, emitting downwards.
fn ceiling_light() -> LightDesc {
    let v = Vec3::new;
    let light_t = Mat4::from_translation(v(0.0, 1.99, 0.0))
        * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2)
        * Mat4::from_scale(v(0.6, 0.5, 1.0));
    LightDesc {
        name: "ceiling light".into(),
        kind: LightKind::Area {
            radiance: Vec3::new(12.0, 11.0, 9.5),
        },
        transform: light_t,
        loc: Loc::default(),
    }
}

/// The camera: 2 units in front of the box, looking down −Z.
fn cornell_camera() -> CameraDesc {
    CameraDesc {
        exact: false,
        fov_axis: crate::io::desc::FovAxis::Height,
        right_is_x: false,
        lens: None,
        orthographic: false,
        name: "camera".into(),
        xfov_deg: Some(68.0),
        yfov_deg: None,
        aspect: Some(4.0 / 3.0),
        znear: 0.1,
        zfar: 100.0,
        transform: Mat4::from_translation(Vec3::new(0.0, 0.0, 2.0)),
        loc: Loc::default(),
    }
}
