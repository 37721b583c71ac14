//! Mitsuba 3 XML scene files (and the 0.6 / 2.0 files Mitsuba 3 still reads), interpreted
//! with Mitsuba's own plugin semantics into a [`SceneDesc`].
//!
//! [`xml`] reads the syntax into objects with typed properties; `scene` interprets the
//! sensor, film, sampler, integrator and emitters; `bsdfs` and `textures` the materials;
//! `shapes` the geometry. What a file asks for that is not rendered yet is one warning
//! naming file, line and the stand-in; a property no plugin reads is a warning too. Errors
//! (malformed XML, dangling references, wrong property types, missing files) name file and
//! line.

mod bsdfs;
mod media;
mod scene;
pub mod serialized;
mod shapes;
mod textures;
pub mod xml;

use crate::error::{Loc, Result};
use crate::io::desc::SceneDesc;
use crate::math::Rgb;
use glam::{DMat4, DVec3, Mat4, Vec3};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::Path;
use xml::{Doc, Node, Prop, Value};

/// Reads the Mitsuba scene at `path` (and the files it includes); `defines` are the user's
/// `-D name=value`s, which override the file's `<default>`s.
pub fn load_file(path: &Path, defines: &[(String, String)]) -> Result<SceneDesc> {
    interpret(&xml::read_file(path, defines)?, path)
}

/// Interprets the text of one Mitsuba file named `path` (its `<include>`s are not followed;
/// files it names are read relative to `path`'s folder): the fuzz target's entry.
pub fn load_text(text: &str, path: &Path) -> Result<SceneDesc> {
    interpret(&xml::read_text_as(text, path, &[], false)?, path)
}

/// Whether `text` (the start of an `.xml` file) is a Mitsuba scene rather than COLLADA.
pub fn is_mitsuba(text: &[u8]) -> bool {
    let head = String::from_utf8_lossy(&text[..text.len().min(4096)]);
    let without_prolog = head
        .split("<scene")
        .next()
        .is_some_and(|before| !before.contains("<COLLADA"));
    without_prolog && head.contains("<scene")
}

fn interpret(doc: &Doc, path: &Path) -> Result<SceneDesc> {
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let mut it = Interp {
        doc,
        desc: SceneDesc {
            name,
            file: path.display().to_string(),
            ..Default::default()
        },
        materials: HashMap::new(),
        groups: HashMap::new(),
        warned: HashSet::new(),
        plugins: BTreeMap::new(),
        depth: 0,
        two_sided_depth: 0,
        media: HashMap::new(),
        bounding: HashMap::new(),
        media_ignored_by: None,
    };
    it.scene()?;
    it.finish_media();
    it.report_unused();
    for f in doc.files.iter().skip(1) {
        if !it.desc.sources.contains(f) {
            it.desc.sources.push(f.clone());
        }
    }
    let read: Vec<String> = it
        .plugins
        .iter()
        .map(|(k, n)| {
            if *n > 1 {
                format!("{k} ×{n}")
            } else {
                k.clone()
            }
        })
        .collect();
    it.desc.plugins = read;
    Ok(it.desc)
}

/// The interpreter's state.
pub(crate) struct Interp<'a> {
    doc: &'a Doc,
    desc: SceneDesc,
    /// (BSDF object or `usize::MAX` for the default, emitted radiance bits, one-sided) →
    /// material.
    materials: HashMap<(usize, [u32; 3], bool), u32>,
    /// `shapegroup` object → index in [`SceneDesc::objects`].
    groups: HashMap<usize, u32>,
    /// Warnings given once per kind.
    warned: HashSet<String>,
    /// `"tag plugin"` → how many were read (for `--info`).
    plugins: BTreeMap<String, usize>,
    /// Nesting of BSDFs being interpreted (reference cycles end here).
    depth: usize,
    /// How many `twosided`s the BSDF being interpreted is inside.
    two_sided_depth: usize,
    /// Medium object → index in [`SceneDesc::media`].
    media: HashMap<usize, u32>,
    /// (material, interface) → the material as that medium boundary.
    bounding: HashMap<(u32, crate::io::desc::MediumInterfaceDesc), u32>,
    /// The integrator object that leaves media out (`path`), if any.
    media_ignored_by: Option<usize>,
}

/// Deepest nesting of BSDFs (`twosided`, `blendbsdf`, `mask`, ...).
const MAX_BSDF_DEPTH: usize = 16;

impl<'a> Interp<'a> {
    /// The object at `index`.
    fn node(&self, index: usize) -> &'a Node {
        &self.doc.nodes[index]
    }

    /// Counts `node` as read, for `--info`.
    fn count(&mut self, node: &Node) {
        *self
            .plugins
            .entry(format!("{} {}", node.tag, node.plugin))
            .or_default() += 1;
    }

    /// A warning at `loc` of `node`'s file, given once per `kind`.
    fn warn_once(&mut self, node: &Node, loc: Loc, kind: &str, msg: impl std::fmt::Display) {
        if self.warned.insert(kind.to_string()) {
            let w = self.doc.warning(node, loc, msg);
            self.desc.warnings.push(w);
        }
    }

    /// An unsupported plugin: one warning per plugin naming the stand-in.
    fn unsupported(&mut self, node: &Node, stand_in: &str) {
        let kind = format!("{} {}", node.tag, node.plugin);
        self.warn_once(
            node,
            node.loc,
            &kind,
            format!(
                "{} \"{}\" is not supported yet; {stand_in}",
                node.tag, node.plugin
            ),
        );
        for p in &node.props {
            p.used.set(true);
        }
    }

    /// Warnings for properties no plugin read.
    fn report_unused(&mut self) {
        for node in &self.doc.nodes {
            for p in &node.props {
                if !p.used.get() {
                    let w = self.doc.warning(
                        node,
                        p.loc,
                        format!(
                            "property \"{}\" of {} \"{}\" is not used",
                            p.name, node.tag, node.plugin
                        ),
                    );
                    self.desc.warnings.push(w);
                }
            }
        }
    }

    /// The property `name` of `node`, marked as read.
    fn prop(node: &'a Node, name: &str) -> Option<&'a Prop> {
        let p = node.props.iter().find(|p| p.name == name)?;
        p.used.set(true);
        Some(p)
    }

    fn type_error(&self, node: &Node, p: &Prop, want: &str) -> crate::error::Error {
        self.doc.error(
            node,
            p.loc,
            format!(
                "property \"{}\" of {} \"{}\" must be {want}, not <{}>",
                p.name,
                node.tag,
                node.plugin,
                p.value.tag()
            ),
        )
    }

    /// A number property (`float` or `integer`).
    fn float(&self, node: &'a Node, name: &str, default: f32) -> Result<f32> {
        Ok(self.float_opt(node, name)?.unwrap_or(default))
    }

    fn float_opt(&self, node: &'a Node, name: &str) -> Result<Option<f32>> {
        match Self::prop(node, name) {
            None => Ok(None),
            Some(Prop {
                value: Value::Float(v),
                ..
            }) => Ok(Some(*v as f32)),
            Some(Prop {
                value: Value::Integer(v),
                ..
            }) => Ok(Some(*v as f32)),
            Some(p) => Err(self.type_error(node, p, "a <float>")),
        }
    }

    /// An `integer` property.
    fn int(&self, node: &'a Node, name: &str, default: i64) -> Result<i64> {
        match Self::prop(node, name) {
            None => Ok(default),
            Some(Prop {
                value: Value::Integer(v),
                ..
            }) => Ok(*v),
            Some(p) => Err(self.type_error(node, p, "an <integer>")),
        }
    }

    /// A `boolean` property.
    fn bool(&self, node: &'a Node, name: &str, default: bool) -> Result<bool> {
        match Self::prop(node, name) {
            None => Ok(default),
            Some(Prop {
                value: Value::Bool(v),
                ..
            }) => Ok(*v),
            Some(p) => Err(self.type_error(node, p, "a <boolean>")),
        }
    }

    /// A `string` property.
    fn string(&self, node: &'a Node, name: &str) -> Result<Option<&'a str>> {
        match Self::prop(node, name) {
            None => Ok(None),
            Some(Prop {
                value: Value::Str(v),
                ..
            }) => Ok(Some(v.as_str())),
            Some(p) => Err(self.type_error(node, p, "a <string>")),
        }
    }

    /// A colour property (`rgb`, `spectrum`, or a number for grey), if given.
    fn colour_opt(&self, node: &'a Node, name: &str) -> Result<Option<Rgb>> {
        let Some(p) = Self::prop(node, name) else {
            return Ok(None);
        };
        let c = match &p.value {
            Value::Rgb(v) => v.as_vec3(),
            Value::Float(v) | Value::Uniform(v) => Vec3::splat(*v as f32),
            Value::Integer(v) => Vec3::splat(*v as f32),
            Value::Sampled(pairs) => {
                let flat: Vec<f64> = pairs.iter().flat_map(|&(l, v)| [l, v]).collect();
                crate::io::pbrt::spectra::sampled_rgb(&flat)
                    .map_err(|e| self.doc.error(node, p.loc, e))?
            }
            _ => return Err(self.type_error(node, p, "a colour (<rgb>, <spectrum>, <float>)")),
        };
        Ok(Some(c))
    }

    /// A point or vector property.
    fn vector_opt(&self, node: &'a Node, name: &str) -> Result<Option<DVec3>> {
        match Self::prop(node, name) {
            None => Ok(None),
            Some(Prop {
                value: Value::Point(v) | Value::Vector(v),
                ..
            }) => Ok(Some(*v)),
            Some(p) => Err(self.type_error(node, p, "a <point> or <vector>")),
        }
    }

    /// A `transform` property (identity when absent).
    fn transform(&self, node: &'a Node, name: &str) -> Result<DMat4> {
        match Self::prop(node, name) {
            None => Ok(DMat4::IDENTITY),
            Some(Prop {
                value: Value::Transform(m),
                ..
            }) => Ok(*m),
            Some(p) => Err(self.type_error(node, p, "a <transform>")),
        }
    }

    /// `to_world` in single precision.
    fn to_world(&self, node: &'a Node) -> Result<Mat4> {
        Ok(self.transform(node, "to_world")?.as_mat4())
    }

    /// The nested objects and references of `node` with element name `tag`, with their
    /// parameter names.
    fn children(
        &self,
        node: &'a Node,
        tag: &'a str,
    ) -> impl Iterator<Item = (usize, Option<&'a str>)> + 'a {
        let doc = self.doc;
        node.children
            .iter()
            .filter(move |c| doc.nodes[c.node].tag == tag)
            .map(|c| (c.node, c.name.as_deref()))
    }

    /// The nested object or reference named `name` (any element), if any.
    fn named_child(&self, node: &'a Node, name: &str) -> Option<usize> {
        node.children
            .iter()
            .find(|c| c.name.as_deref() == Some(name))
            .map(|c| c.node)
    }
}
