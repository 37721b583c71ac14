//! The format-neutral scene description: what a scene file says, before anything is built.
//!
//! Loaders (COLLADA, OBJ, PLY, glTF) produce a [`SceneDesc`]; `scene::build` turns it into a renderable
//! `scene::Scene`. Transforms are object-to-world 4×4 matrices that already include the
//! file's up-axis correction, so the world is Y-up. Colours are linear RGB.

use crate::bsdf::microfacet::Distribution;
use crate::error::Loc;
use crate::math::Rgb;
use glam::{Mat4, Vec3};

/// A whole scene as described by a file.
#[derive(Clone, Debug, Default)]
pub struct SceneDesc {
    /// Short name (the file stem), used for default output names.
    pub name: String,
    /// The file it came from, as given by the user (for messages).
    pub file: String,
    /// Materials, referenced by index from shapes.
    pub materials: Vec<MaterialDesc>,
    /// Geometry instances.
    pub shapes: Vec<ShapeDesc>,
    /// Light instances.
    pub lights: Vec<LightDesc>,
    /// The first camera instance, if any.
    pub camera: Option<CameraDesc>,
    /// Non-fatal problems found while reading (already carrying file and line).
    pub warnings: Vec<String>,
    /// Textures, each modulating one property of one material.
    pub textures: Vec<TextureDesc>,
    /// The files it was read from: the scene file first, then the files that one names and
    /// the loader read (MTL files, glTF buffers); empty for scenes made in memory.
    pub sources: Vec<std::path::PathBuf>,
    /// Render settings the file asks for (pbrt-v4's `Film`, `Sampler`, `Integrator`), as
    /// `(option name, value)` of `options`; the user's flags override them.
    pub options: Vec<(String, Value)>,
    /// Objects that instances share (pbrt-v4's `ObjectBegin`): their meshes are held once in
    /// memory however many instances there are.
    pub objects: Vec<ObjectDesc>,
    /// Placed copies of [`SceneDesc::objects`].
    pub instances: Vec<InstanceDesc>,
    /// Participating media the file defines (pbrt-v4's `MakeNamedMedium`, Mitsuba's
    /// `<medium>`), referenced by index from material interfaces and the camera.
    pub media: Vec<MediumDesc>,
    /// The medium the camera sits in (index into [`SceneDesc::media`]); `None` for vacuum.
    pub camera_medium: Option<u32>,
    /// The plugins or directives the file used, with counts (`"bsdf roughplastic ×4"`), for
    /// `--info`; empty for formats that do not list them.
    pub plugins: Vec<String>,
    /// The file's format, which decides what a file without a camera or lights gets.
    pub format: Format,
}

impl SceneDesc {
    /// A copy of material `m` (with its textures), named after it and `what`, changed by
    /// `change`; its index.
    pub fn copy_material(
        &mut self,
        m: u32,
        what: &str,
        change: impl FnOnce(&mut MaterialDesc),
    ) -> u32 {
        let mut copy = self.materials[m as usize].clone();
        copy.name = format!("{} ({what})", copy.name);
        change(&mut copy);
        self.materials.push(copy);
        let id = self.materials.len() as u32 - 1;
        let textures: Vec<TextureDesc> = self
            .textures
            .iter()
            .filter(|t| t.material == m)
            .map(|t| TextureDesc {
                material: id,
                ..t.clone()
            })
            .collect();
        self.textures.extend(textures);
        id
    }
}

/// The format a scene was read from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Format {
    /// CS184's COLLADA, or the built-in scene: CS184's camera placement, no default light.
    #[default]
    Collada,
    /// Wavefront OBJ (+ MTL).
    Obj,
    /// Stanford PLY.
    Ply,
    /// glTF 2.0 (`.gltf`, `.glb`).
    Gltf,
    /// pbrt-v4.
    Pbrt,
    /// Mitsuba 3 XML.
    Mitsuba,
}

impl Format {
    /// A model format (OBJ, PLY, glTF): a file of one without lights is lit by the built-in
    /// studio light, as model viewers do. Scene formats keep their lighting as written.
    pub fn is_model(self) -> bool {
        matches!(self, Format::Obj | Format::Ply | Format::Gltf)
    }

    /// Whether a file of this format without a camera is framed whole for the image asked:
    /// all but CS184's COLLADA (which keeps CS184's view; pbrt-v4 files always have one, the
    /// default camera where the file gives none).
    pub fn frames_camera_less(self) -> bool {
        self != Format::Collada
    }
}

/// A participating medium as the file defines it.
#[derive(Clone, Debug)]
pub struct MediumDesc {
    /// Its name.
    pub name: String,
    /// Its type as the file names it (`homogeneous`, `uniformgrid`, `nanovdb`, ...).
    pub kind: String,
    /// Henyey-Greenstein asymmetry.
    pub g: f32,
    /// What fills its space; `None` for a kind not rendered (the loader has warned).
    pub coefficients: Option<MediumCoefficients>,
    /// Where it was defined.
    pub loc: Loc,
}

/// A medium's coefficients, per unit length and per channel, after any scale the file gives.
#[derive(Clone, Debug, PartialEq)]
pub enum MediumCoefficients {
    /// The same everywhere.
    Homogeneous {
        /// Absorption.
        sigma_a: Rgb,
        /// Scattering.
        sigma_s: Rgb,
        /// Emitted radiance (the source term is `σa·Le`).
        le: Rgb,
    },
    /// From voxel grids over a box.
    Grid(GridMediumDesc),
}

/// A grid medium: its fields over the grids' unit cube (see [`crate::medium::grid`]).
#[derive(Clone, Debug, PartialEq)]
pub struct GridMediumDesc {
    /// World space → the grids' unit cube.
    pub to_unit: Mat4,
    /// The grids the fields refer to by index.
    pub grids: Vec<std::sync::Arc<crate::medium::grid::VoxelGrid>>,
    /// Absorption.
    pub sigma_a: crate::medium::grid::Field,
    /// Scattering.
    pub sigma_s: crate::medium::grid::Field,
    /// Emitted radiance.
    pub emission: crate::medium::grid::Field,
    /// The box of the unit cube the medium fills, min and max (`[0, 1]³` but for NanoVDB
    /// grids).
    pub bounds: (glam::Vec3, glam::Vec3),
    /// Blackbody emission from a temperature grid: its index, the offset subtracted from its
    /// values and the scale then applied (kelvins); the emission field scales it.
    pub temperature: Option<(u8, f32, f32)>,
}

/// The media on the two sides of a surface (indices into [`SceneDesc::media`]; `None` is
/// vacuum). `outside` is the side the surface's normal (its winding normal) faces.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct MediumInterfaceDesc {
    /// Behind the normal.
    pub inside: Option<u32>,
    /// Where the normal points.
    pub outside: Option<u32>,
}

/// A shape group that instances share.
#[derive(Clone, Debug)]
pub struct ObjectDesc {
    /// Its name in the file.
    pub name: String,
    /// Its shapes; their transforms place them in the object's own space. They do not emit.
    pub shapes: Vec<ShapeDesc>,
}

/// One placed copy of an object.
#[derive(Clone, Debug)]
pub struct InstanceDesc {
    /// Index into [`SceneDesc::objects`].
    pub object: u32,
    /// Object-to-world transform.
    pub transform: Mat4,
    /// Where it was placed.
    pub loc: Loc,
}

/// One material.
#[derive(Clone, Debug)]
pub struct MaterialDesc {
    /// Name or id in the file.
    pub name: String,
    /// The scattering model and its parameters.
    pub kind: MaterialKind,
    /// Emitted radiance (both sides); zero for non-emitters.
    pub emission: Rgb,
    /// Scatters only on the front side of its surfaces (the side the geometric normal
    /// faces) and is black from behind, as Mitsuba's BSDFs outside `twosided`; otherwise
    /// the same on both sides.
    pub one_sided: bool,
    /// The media this material's surfaces separate, where they differ on the two sides
    /// (loaders make one material per interface they use it with).
    pub interface: Option<MediumInterfaceDesc>,
    /// Where it was defined.
    pub loc: Loc,
}

/// Scattering models of the CS184 CGL profile.
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialKind {
    /// Lambertian reflection with the given albedo.
    Diffuse {
        /// Albedo in [0, 1].
        albedo: Rgb,
    },
    /// Pure emitter that scatters nothing (CGL `<emission>`).
    Emission,
    /// Perfect specular reflection (CGL `<mirror>`).
    Mirror {
        /// Reflection tint.
        reflectance: Rgb,
    },
    /// Smooth dielectric, reflection and refraction (CGL `<glass>`).
    Glass {
        /// Reflection tint.
        reflectance: Rgb,
        /// Transmission tint.
        transmittance: Rgb,
        /// Roughness (parsed, unused by CS184).
        roughness: f32,
        /// Index of refraction of the inside.
        ior: f32,
    },
    /// Smooth dielectric, refraction only (CGL `<refraction>`).
    Refraction {
        /// Transmission tint.
        transmittance: Rgb,
        /// Roughness (parsed, unused by CS184).
        roughness: f32,
        /// Index of refraction of the inside.
        ior: f32,
    },
    /// Rough conductor, Beckmann distribution (CGL `<microfacet>`).
    Microfacet {
        /// Beckmann roughness α.
        alpha: f32,
        /// Real part of the conductor's index of refraction, per channel.
        eta: Rgb,
        /// Imaginary part (absorption), per channel.
        k: Rgb,
    },
    /// glTF's metallic-roughness material (see [`crate::bsdf::pbr`]).
    MetallicRoughness {
        /// Base colour, linear RGB.
        base: Rgb,
        /// Metalness in [0, 1].
        metallic: f32,
        /// Perceptual roughness in [0, 1] (GGX α = roughness²).
        roughness: f32,
        /// Transmission factor in [0, 1] (`KHR_materials_transmission`; 0 is opaque).
        transmission: f32,
        /// Index of refraction of the inside (`KHR_materials_ior`; glTF's default 1.5).
        ior: f32,
    },
    /// pbrt-v4's `conductor` and Mitsuba's `conductor`/`roughconductor`: a microfacet
    /// conductor (see [`crate::bsdf::conductor`]; a Beckmann one is isotropic, see
    /// [`crate::bsdf::microfacet`]).
    Conductor {
        /// Real part of the index of refraction, per channel.
        eta: Rgb,
        /// Absorption (imaginary part), per channel.
        k: Rgb,
        /// Microfacet α along u and v (already remapped from roughness); below 10⁻³ smooth.
        alpha: [f32; 2],
        /// A factor on the reflection (Mitsuba's `specular_reflectance`).
        tint: Rgb,
        /// The microfacet distribution (Trowbridge-Reitz for pbrt-v4).
        distribution: Distribution,
    },
    /// Mitsuba's `plastic` (α 0) and `roughplastic` (see [`crate::bsdf::plastic`]).
    Plastic {
        /// Diffuse reflectance.
        diffuse: Rgb,
        /// Tint of the specular reflection.
        specular: Rgb,
        /// Index of the coating relative to the outside.
        ior: f32,
        /// Microfacet α of the coating; 0 smooth.
        alpha: f32,
        /// The coating's microfacet distribution.
        distribution: Distribution,
        /// Mitsuba's `nonlinear`.
        nonlinear: bool,
    },
    /// pbrt-v4's `dielectric` (smooth or rough) and `thindielectric`; Mitsuba's
    /// `dielectric`, `roughdielectric` and `thindielectric`.
    Dielectric {
        /// Index of refraction of the inside over the outside.
        ior: f32,
        /// Microfacet α along u and v (already remapped).
        alpha: [f32; 2],
        /// The microfacet distribution (pbrt-v4's is GGX).
        distribution: Distribution,
        /// A thin sheet (`thindielectric`).
        thin: bool,
    },
    /// Mitsuba's `principled` (see [`crate::bsdf::principled`]).
    Principled(crate::bsdf::principled::Principled),
    /// pbrt-v4's `coateddiffuse` and `coatedconductor` (see [`crate::bsdf::layered`]).
    Coated {
        /// What lies under the coating.
        base: CoatedBase,
        /// The coating's index of refraction.
        ior: f32,
        /// The coating's Trowbridge-Reitz α along u and v.
        alpha: [f32; 2],
        /// The coating's thickness.
        thickness: f32,
        /// Most scatterings of one random walk.
        max_depth: u32,
        /// Random walks per estimate.
        samples: u32,
    },
    /// pbrt-v4's `mix`: material `b` with probability `amount` at each shading point, else
    /// `a` (indices into [`SceneDesc::materials`]).
    Mix {
        /// Chosen with probability `1 − amount`.
        a: u32,
        /// Chosen with probability `amount`.
        b: u32,
        /// In [0, 1].
        amount: f32,
    },
    /// Mitsuba's `twosided` with two BSDFs: material `front` on the side the geometric normal
    /// faces, `back` on the other (indices into [`SceneDesc::materials`]).
    Sided {
        /// Seen from the front.
        front: u32,
        /// Seen from behind.
        back: u32,
    },
    /// A surface that only bounds media (pbrt-v4's `interface`, Mitsuba's `null`): rays pass
    /// through it unchanged, and it counts as no bounce.
    Null,
    /// pbrt-v4's `diffusetransmission`.
    DiffuseTransmission {
        /// Lambertian reflectance.
        reflectance: Rgb,
        /// Lambertian transmittance.
        transmittance: Rgb,
    },
}

/// The base of a [`MaterialKind::Coated`] material.
#[derive(Clone, Debug, PartialEq)]
pub enum CoatedBase {
    /// Lambertian (`coateddiffuse`).
    Diffuse {
        /// Reflectance.
        reflectance: Rgb,
    },
    /// A conductor (`coatedconductor`), its index relative to the coating's.
    Conductor {
        /// Real part of the relative index, per channel.
        eta: Rgb,
        /// Imaginary part, per channel.
        k: Rgb,
        /// Trowbridge-Reitz α along u and v.
        alpha: [f32; 2],
    },
}

impl MaterialKind {
    /// Lower-case type name as in the CGL profile ("diffuse" for the common profile).
    pub fn type_name(&self) -> &'static str {
        match self {
            MaterialKind::Diffuse { .. } => "diffuse",
            MaterialKind::Emission => "emission",
            MaterialKind::Mirror { .. } => "mirror",
            MaterialKind::Glass { .. } => "glass",
            MaterialKind::Refraction { .. } => "refraction",
            MaterialKind::Microfacet { .. } => "microfacet",
            MaterialKind::MetallicRoughness { .. } => "metallic-roughness",
            MaterialKind::Conductor { .. } => "conductor",
            MaterialKind::Plastic { alpha, .. } if *alpha == 0.0 => "plastic",
            MaterialKind::Plastic { .. } => "roughplastic",
            MaterialKind::Dielectric { thin: false, .. } => "dielectric",
            MaterialKind::Dielectric { thin: true, .. } => "thindielectric",
            MaterialKind::Coated {
                base: CoatedBase::Diffuse { .. },
                ..
            } => "coateddiffuse",
            MaterialKind::Coated { .. } => "coatedconductor",
            MaterialKind::DiffuseTransmission { .. } => "diffusetransmission",
            MaterialKind::Null => "null",
            MaterialKind::Principled(_) => "principled",
            MaterialKind::Mix { .. } => "mix",
            MaterialKind::Sided { .. } => "twosided",
        }
    }
}

/// One geometry instance.
#[derive(Clone, Debug)]
pub enum ShapeDesc {
    /// A triangle mesh in object space.
    Mesh {
        /// Geometry name or id.
        name: String,
        /// Vertex positions, object space.
        positions: Vec<Vec3>,
        /// Triangles as indices into `positions` (polygons already fan-triangulated).
        triangles: Vec<[u32; 3]>,
        /// Material index per triangle.
        materials: Vec<u32>,
        /// Shading normals.
        normals: MeshNormals,
        /// Texture coordinates, one per position, or empty. Convention (glTF's): (0, 0) is
        /// the image's top-left corner and v grows downwards; loaders of formats whose v grows
        /// upwards (OBJ) flip it.
        uvs: Vec<glam::Vec2>,
        /// Emissive triangles emit only from their front side (the side their winding
        /// `(b − a) × (c − a)` faces), as OBJ/PLY/glTF emitters in pbrt-v4 and Mitsuba;
        /// otherwise from both (CS184's emissive meshes).
        one_sided: bool,
        /// Object-to-world transform.
        transform: Mat4,
        /// Where it was instanced.
        loc: Loc,
    },
    /// A sphere of `radius` centred at the object-space origin.
    Sphere {
        /// Geometry name or id.
        name: String,
        /// Radius, object space.
        radius: f32,
        /// Which side emits, if its material does.
        side: EmitSide,
        /// Material index.
        material: u32,
        /// Object-to-world transform.
        transform: Mat4,
        /// Where it was instanced.
        loc: Loc,
    },
}

/// The side of a closed surface that emits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EmitSide {
    /// Both (CS184's emissive spheres).
    #[default]
    Both,
    /// The outside only (pbrt-v4's area lights).
    Outside,
    /// The inside only (pbrt-v4's area lights under `ReverseOrientation`).
    Inside,
}

/// How a mesh's shading normals are made.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum MeshNormals {
    /// Per vertex, the area-weighted mean of the normals of the faces that share it (CS184).
    #[default]
    Smooth,
    /// Each triangle's own geometric normal (flat shading; OBJ and PLY files without normals).
    Flat,
    /// Given per vertex in object space (one per position).
    Given(Vec<Vec3>),
}

/// One light instance.
#[derive(Clone, Debug)]
pub struct LightDesc {
    /// Light name or id.
    pub name: String,
    /// Type and parameters.
    pub kind: LightKind,
    /// Object-to-world transform of the instancing node.
    pub transform: Mat4,
    /// Where it was instanced.
    pub loc: Loc,
}

/// Light types of COLLADA and the CGL profile.
#[derive(Clone, Debug, PartialEq)]
pub enum LightKind {
    /// CGL one-sided rectangle: centre `T·(0,0,0)`, full edge vectors `T·(−1,0,0)` and `T·(0,1,0)`
    /// (relative to the centre), emitting towards `T·(0,0,−1)`; `radiance` in W/(m²·sr).
    Area {
        /// Emitted radiance.
        radiance: Rgb,
    },
    /// Isotropic point light at `T·(0,0,0)` with intensity `intensity` (W/sr).
    Point {
        /// Radiant intensity.
        intensity: Rgb,
    },
    /// Distant light; direction to the light `normalize(T·(0,0,−1,1))` (CS184 convention).
    Directional {
        /// Irradiance on a surface facing the light.
        irradiance: Rgb,
    },
    /// Point light restricted to a cone around `T·(0,0,−1)` (direction).
    Spot {
        /// Radiant intensity on the axis.
        intensity: Rgb,
        /// Full cone angle in degrees.
        falloff_angle_deg: f32,
        /// Exponent of the cosine falloff inside the cone.
        falloff_exponent: f32,
        /// Full angle in degrees where pbrt-v4's smooth falloff (a smoothstep down to
        /// `falloff_angle_deg`) begins; `None` for none.
        falloff_start_deg: Option<f32>,
        /// Between the two angles the intensity falls linearly in angle (Mitsuba's spot),
        /// not by pbrt-v4's smoothstep.
        linear_falloff: bool,
    },
    /// Constant radiance from the upper hemisphere (world +Y), infinitely far away.
    Ambient {
        /// Radiance of the sky.
        radiance: Rgb,
    },
    /// pbrt-v4's `infinite` light: constant radiance from every direction, or a square image
    /// in the equal-area octahedral mapping (see [`crate::light::infinite`]) turned by the
    /// light's transform.
    Infinite {
        /// The radiance, or the image's multiplier.
        scale: Rgb,
        /// The image's side in texels and its texels, rows from the top (linear RGB).
        image: Option<(u32, Vec<Rgb>)>,
    },
    /// Mitsuba's `envmap`: a latitude-longitude image, a direction `v` of the light's space
    /// (world directions through the inverse of the transform's rotation) seen at
    /// `u = atan2(v.x, −v.z) / 2π` (wrapped to [0, 1)), `v = acos(v.y) / π`.
    LatLong {
        /// The image's multiplier.
        scale: Rgb,
        /// The image (linear RGB).
        image: crate::io::image::Image,
    },
}

impl LightKind {
    /// Lower-case type name.
    pub fn type_name(&self) -> &'static str {
        match self {
            LightKind::Area { .. } => "area",
            LightKind::Point { .. } => "point",
            LightKind::Directional { .. } => "directional",
            LightKind::Spot { .. } => "spot",
            LightKind::Ambient { .. } => "ambient",
            LightKind::Infinite { .. } => "infinite",
            LightKind::LatLong { .. } => "envmap",
        }
    }
}

/// A perspective camera as the file describes it. CS184 uses only its viewing direction
/// and field of view (see `camera::Camera::cs184`).
#[derive(Clone, Debug)]
pub struct CameraDesc {
    /// Camera name or id.
    pub name: String,
    /// Horizontal field of view in degrees, if given.
    pub xfov_deg: Option<f32>,
    /// Vertical field of view in degrees, if given.
    pub yfov_deg: Option<f32>,
    /// Width / height, if given.
    pub aspect: Option<f32>,
    /// Near clip distance.
    pub znear: f32,
    /// Far clip distance.
    pub zfar: f32,
    /// Object-to-world transform of the instancing node.
    pub transform: Mat4,
    /// Where it was instanced.
    pub loc: Loc,
    /// The camera sits where its node says, looks down the node's −Z with +Y up, and
    /// `yfov_deg` spans the image's height (glTF; pbrt-v4 with [`CameraDesc::fov_axis`]);
    /// otherwise CS184's placement applies.
    pub exact: bool,
    /// Which image axis `yfov_deg` spans for an exact camera.
    pub fov_axis: FovAxis,
    /// The image's right is the node's +X even where the transform mirrors (pbrt-v4's
    /// left-handed camera space); otherwise it is the view direction × up.
    pub right_is_x: bool,
    /// Thin-lens radius and focal distance in scene units (pbrt-v4's `lensradius`,
    /// `focaldistance`), if the file gives a lens.
    pub lens: Option<(f32, f32)>,
    /// An orthographic projection (pbrt-v4's `orthographic`: the shorter image axis spans 2
    /// units); otherwise perspective.
    pub orthographic: bool,
}

/// The image axis a camera's field of view spans.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FovAxis {
    /// The image's height (glTF, Mitsuba's default `y`).
    #[default]
    Height,
    /// The shorter of width and height (pbrt-v4, Mitsuba's `smaller`).
    Shorter,
    /// The image's width (Mitsuba's default `x`).
    Width,
    /// The image's diagonal (Mitsuba's `diagonal`, and its `focal_length`).
    Diagonal,
    /// The longer of width and height (Mitsuba's `larger`).
    Longer,
}

/// How texture coordinates outside [0, 1] map into a texture, along one axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Wrap {
    /// The texture repeats.
    #[default]
    Repeat,
    /// The edge texels extend.
    Clamp,
    /// The texture repeats, every other copy mirrored.
    Mirror,
}

/// What a texture modulates.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum TextureSlot {
    /// Multiplies the diffuse albedo or base colour (glTF `baseColorTexture`, MTL `map_Kd`);
    /// texels are linear RGB, decoded from sRGB.
    #[default]
    BaseColor,
    /// glTF `metallicRoughnessTexture`: blue multiplies the metalness, green the roughness;
    /// texels are the stored values in [0, 1] (no sRGB decoding).
    MetallicRoughness,
    /// glTF `normalTexture`: a tangent-space normal `2·texel − 1` (+x along +u, +y towards
    /// the image's top, that is along −v, +z the surface normal), its x and y multiplied by
    /// `scale`; texels are the stored values in [0, 1].
    Normal {
        /// glTF's `normalTexture.scale`.
        scale: f32,
        /// Mitsuba's `normalmap`: +y runs along `n × ∂p/∂u` whatever way v runs, and the
        /// BSDF is multiplied by Mitsuba's shadowing term for the bent normal.
        mitsuba: bool,
    },
    /// Multiplies the emitted radiance (glTF `emissiveTexture`); linear RGB, decoded from
    /// sRGB.
    Emission,
    /// Mitsuba's `bumpmap`: red is a height whose gradient in texture space, times `scale`,
    /// bends the shading normal (and Mitsuba's shadowing term applies, as for its normal
    /// maps).
    Bump {
        /// Mitsuba's `scale`.
        scale: f32,
    },
    /// An alpha cut-out (pbrt-v4's `alpha`, Mitsuba's `mask`): red is the opacity in [0, 1]
    /// (1 solid, 0 a hole, between: kept by that fraction of rays).
    Alpha {
        /// Each surface a ray crosses keeps it by its own random number (Mitsuba's `mask`);
        /// otherwise one number per ray decides at every surface (pbrt-v4).
        per_crossing: bool,
        /// Light-sampling rays stop at the surface, holes included (Mitsuba's `path`
        /// integrator: its shadow rays test only for a surface), so light through the holes
        /// arrives only along paths that pass them; otherwise light-sampling rays pass the
        /// holes as every other ray does (pbrt-v4).
        blocks_light: bool,
    },
    /// A number parameter of the BSDF (Mitsuba's texture for a float): red is its value at
    /// each shading point, in place of the material's (the texture's mean).
    Number(crate::bsdf::Param),
    /// Multiplies a diffuse transmitter's transmittance (pbrt-v4's `diffusetransmission`;
    /// [`TextureSlot::BaseColor`] multiplies its reflectance); linear RGB.
    Transmittance,
    /// pbrt-v4's `displacement`: red is a displacement along the shading normal, in scene
    /// units, whose gradient bends the shading normal as pbrt-v4's `BumpMap` does (see
    /// `src/scene/bump.rs`).
    Displacement,
}

/// A texture of one material (see [`TextureSlot`] for what it modulates).
#[derive(Clone, Debug)]
pub struct TextureDesc {
    /// The image's name or file, for messages.
    pub name: String,
    /// The material it belongs to.
    pub material: u32,
    /// What it modulates.
    pub slot: TextureSlot,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width × height` texels, row-major from the top-left corner: linear RGB for colours
    /// (sRGB images are decoded when loaded), the stored values for data ([`TextureSlot`]).
    pub texels: Vec<Rgb>,
    /// Wrap modes along u and v.
    pub wrap: [Wrap; 2],
    /// Looks up the nearest texel instead of interpolating bilinearly.
    pub nearest: bool,
    /// A transform of the texture coordinates before the lookup (Mitsuba's `to_uv`).
    pub uv_transform: Option<glam::Affine2>,
}

/// A value as a shell or a scene file gives it, before the option table checks it
/// (`options::check`).
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// True or false.
    Bool(bool),
    /// An integer (wide enough for every shell's integers; a larger one is out of range).
    Int(i128),
    /// A number.
    Real(f64),
    /// A name.
    Text(String),
    /// Several values (a tuple).
    List(Vec<Value>),
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Bool(b) => write!(f, "{b}"),
            Value::Int(i) => write!(f, "{i}"),
            Value::Real(x) => write!(f, "{x}"),
            Value::Text(t) => write!(f, "{t}"),
            Value::List(l) => {
                for (i, v) in l.iter().enumerate() {
                    if i > 0 {
                        f.write_str(" ")?;
                    }
                    write!(f, "{v}")?;
                }
                Ok(())
            }
        }
    }
}

impl Value {
    /// The integer, if this is one.
    pub fn as_int(&self) -> Option<i128> {
        match self {
            Value::Int(i) => Some(*i),
            _ => None,
        }
    }

    /// The number, if this is one (an integer too).
    pub fn as_real(&self) -> Option<f64> {
        match self {
            Value::Int(i) => Some(*i as f64),
            Value::Real(x) => Some(*x),
            _ => None,
        }
    }

    /// The truth value, if this is one.
    pub fn as_bool(&self) -> Option<bool> {
        match self {
            Value::Bool(b) => Some(*b),
            _ => None,
        }
    }

    /// The text, if this is a name.
    pub fn as_text(&self) -> Option<&str> {
        match self {
            Value::Text(t) => Some(t),
            _ => None,
        }
    }

    /// The values, if this is a tuple.
    pub fn as_list(&self) -> Option<&[Value]> {
        match self {
            Value::List(l) => Some(l),
            _ => None,
        }
    }
}
