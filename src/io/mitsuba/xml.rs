//! Mitsuba 3's XML syntax, read into a tree of objects with typed properties.
//!
//! - The root is `<scene version="…">`; objects (`bsdf`, `shape`, `emitter`, `texture`,
//!   `sensor`, `film`, `sampler`, `integrator`, `rfilter`, `medium`, `phase`, `volume`)
//!   carry `type`, optional `id` and (as a parameter of their parent) `name`.
//! - Properties: `integer`, `float`, `boolean`, `string`, `rgb` (one or three numbers),
//!   `spectrum` (a value, or `wavelength:value` pairs), `point`, `vector` (`x`/`y`/`z` or one
//!   `value`), `transform` (`translate`, `rotate`, `scale`, `matrix`, `lookat`, each applied
//!   after the ones before it, as Mitsuba's parser does).
//! - `<default name value>` defines `$name` unless the user gave it (`-D name=value`);
//!   every attribute value has its `$name`s replaced, longest names first.
//! - `<include filename>` splices the children of another file's `<scene>` (relative to the
//!   including file); `<ref id>` shares an object defined anywhere in the document.
//! - Files older than version 2.0 have their property names upgraded as Mitsuba 3 does
//!   (`camelCase` → `snake_case`, a `diffuse`'s `diffuse_reflectance` → `reflectance`,
//!   `uoffset`/`uscale`/… → `to_uv`).
//!
//! Every error names the file and line; nothing here panics on any input.

use crate::error::{Error, Loc, Result};
use glam::{DMat4, DVec3};
use std::cell::Cell;
use std::path::{Path, PathBuf};

/// Deepest chain of `<include>`s followed.
pub const MAX_INCLUDE_DEPTH: usize = 32;
/// Deepest nesting of objects.
const MAX_NESTING: usize = 64;
/// Longest attribute value after `$parameter` substitution, in bytes.
const MAX_ATTRIBUTE: usize = 1 << 20;

/// A property's value.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// `<float>`.
    Float(f64),
    /// `<integer>`.
    Integer(i64),
    /// `<boolean>`.
    Bool(bool),
    /// `<string>`.
    Str(String),
    /// `<rgb>`.
    Rgb(DVec3),
    /// `<spectrum>`: a constant.
    Uniform(f64),
    /// `<spectrum>`: `(wavelength in nm, value)` pairs.
    Sampled(Vec<(f64, f64)>),
    /// `<point>`.
    Point(DVec3),
    /// `<vector>`.
    Vector(DVec3),
    /// `<transform>`.
    Transform(DMat4),
}

impl Value {
    /// The element name of this kind of value, for messages.
    pub fn tag(&self) -> &'static str {
        match self {
            Value::Float(_) => "float",
            Value::Integer(_) => "integer",
            Value::Bool(_) => "boolean",
            Value::Str(_) => "string",
            Value::Rgb(_) => "rgb",
            Value::Uniform(_) | Value::Sampled(_) => "spectrum",
            Value::Point(_) => "point",
            Value::Vector(_) => "vector",
            Value::Transform(_) => "transform",
        }
    }
}

/// One named property of an object.
#[derive(Clone, Debug)]
pub struct Prop {
    /// Its name.
    pub name: String,
    /// Its value.
    pub value: Value,
    /// Where it is.
    pub loc: Loc,
    /// Set once the interpreter has read it (unread ones are reported).
    pub used: Cell<bool>,
}

/// A nested object or reference: the object (an index into [`Doc::nodes`]) and the
/// parameter name it was given, if any.
#[derive(Clone, Debug)]
pub struct Child {
    /// The `name` attribute.
    pub name: Option<String>,
    /// The object.
    pub node: usize,
    /// Where the nesting element or `<ref>` is.
    pub loc: Loc,
}

/// One object (`<bsdf type="diffuse">`, ...).
#[derive(Clone, Debug)]
pub struct Node {
    /// The element name (`bsdf`, `shape`, ...; `scene` for the root).
    pub tag: String,
    /// The `type` attribute (the plugin).
    pub plugin: String,
    /// The `id` attribute.
    pub id: Option<String>,
    /// Its properties, in file order.
    pub props: Vec<Prop>,
    /// Its nested objects and references, in file order.
    pub children: Vec<Child>,
    /// Index of its file in [`Doc::files`].
    pub file: usize,
    /// Where its element starts.
    pub loc: Loc,
}

/// A whole document: the objects, the root first.
#[derive(Debug, Default)]
pub struct Doc {
    /// Every object; `nodes[0]` is the root `<scene>`.
    pub nodes: Vec<Node>,
    /// The files read (the scene file first), as given or joined to the including folder.
    pub files: Vec<PathBuf>,
}

impl Doc {
    /// An error at `loc` of `node`'s file.
    pub fn error(&self, node: &Node, loc: Loc, msg: impl Into<String>) -> Error {
        Error::At {
            file: self.file_name(node),
            loc,
            msg: msg.into(),
        }
    }

    /// A warning line at `loc` of `node`'s file.
    pub fn warning(&self, node: &Node, loc: Loc, msg: impl std::fmt::Display) -> String {
        format!("{}:{loc}: {msg}", self.file_name(node))
    }

    /// The file `node` is in, for messages.
    pub fn file_name(&self, node: &Node) -> String {
        self.files
            .get(node.file)
            .map(|p| p.display().to_string())
            .unwrap_or_default()
    }

    /// The folder of `node`'s file (paths in it are relative to this).
    pub fn folder(&self, node: &Node) -> PathBuf {
        self.files
            .get(node.file)
            .and_then(|p| p.parent())
            .map(Path::to_path_buf)
            .unwrap_or_default()
    }
}

/// Reads the document at `path`; `defines` are the user's `-D name=value`s, which win over
/// the file's `<default>`s.
pub fn read_file(path: &Path, defines: &[(String, String)]) -> Result<Doc> {
    let text = read_text(path)?;
    read_text_as(&text, path, defines, true)
}

/// Reads `text` as the document `path` (its `<include>`s are followed only when `follow`).
pub fn read_text_as(
    text: &str,
    path: &Path,
    defines: &[(String, String)],
    follow: bool,
) -> Result<Doc> {
    let mut reader = Reader {
        doc: Doc::default(),
        params: defines
            .iter()
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect(),
        ids: Vec::new(),
        pending: Vec::new(),
        stack: Vec::new(),
        follow,
        version_below_2: Vec::new(),
    };
    reader.sort_params();
    reader.root(text, path)?;
    reader.resolve_refs()?;
    Ok(reader.doc)
}

fn read_text(path: &Path) -> Result<String> {
    let (file, bytes, _) = crate::io::read_scene_file(path, "scene")?;
    String::from_utf8(bytes).map_err(|e| Error::File {
        file,
        msg: format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
    })
}

/// The reader's state while it walks the files.
struct Reader {
    doc: Doc,
    /// `$name` → value, longest names first.
    params: Vec<(String, String)>,
    /// `id` → node.
    ids: Vec<(String, usize)>,
    /// `<ref>`s to resolve once every id is known: (parent, child slot, id).
    pending: Vec<(usize, usize, String)>,
    /// The canonical paths of the files being read (include cycles).
    stack: Vec<PathBuf>,
    follow: bool,
    /// Per file: written for a Mitsuba version before 2.0.
    version_below_2: Vec<bool>,
}

/// Where `node` starts in `doc`'s text.
fn loc_of(doc: &roxmltree::Document, node: roxmltree::Node) -> Loc {
    let p = doc.text_pos_at(node.range().start);
    Loc {
        line: p.row,
        col: p.col,
    }
}

/// The element names that make objects.
fn is_object(tag: &str) -> bool {
    matches!(
        tag,
        "bsdf"
            | "shape"
            | "emitter"
            | "texture"
            | "sensor"
            | "film"
            | "sampler"
            | "integrator"
            | "rfilter"
            | "medium"
            | "phase"
            | "volume"
    )
}

impl Reader {
    fn sort_params(&mut self) {
        self.params
            .sort_by(|a, b| b.0.len().cmp(&a.0.len()).then(a.0.cmp(&b.0)));
    }

    fn file_error(&self, file: usize, loc: Loc, msg: impl Into<String>) -> Error {
        Error::At {
            file: self.doc.files[file].display().to_string(),
            loc,
            msg: msg.into(),
        }
    }

    /// Reads the root file.
    fn root(&mut self, text: &str, path: &Path) -> Result<()> {
        self.doc.nodes.push(Node {
            tag: "scene".into(),
            plugin: "scene".into(),
            id: None,
            props: Vec::new(),
            children: Vec::new(),
            file: 0,
            loc: Loc::default(),
        });
        self.file(text, path, 0, true)
    }

    /// Reads one file's `<scene>` into `parent` (the root for the scene file).
    fn file(&mut self, text: &str, path: &Path, parent: usize, is_root: bool) -> Result<()> {
        let file = self.doc.files.len();
        self.doc.files.push(path.to_path_buf());
        let canonical = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        self.stack.push(canonical);
        let xml = roxmltree::Document::parse(text).map_err(|e| {
            let p = e.pos();
            self.file_error(
                file,
                Loc {
                    line: p.row,
                    col: p.col,
                },
                format!("malformed XML: {e}"),
            )
        })?;
        let root = xml.root_element();
        let loc = loc_of(&xml, root);
        if root.tag_name().name() != "scene" {
            return Err(self.file_error(
                file,
                loc,
                format!(
                    "the root element is <{}>, not a Mitsuba <scene>",
                    root.tag_name().name()
                ),
            ));
        }
        let version = root
            .attribute("version")
            .ok_or_else(|| self.file_error(file, loc, "<scene> has no version attribute"))?;
        let below_2 = parse_version(version)
            .ok_or_else(|| {
                self.file_error(file, loc, format!("invalid version number \"{version}\""))
            })?
            .0
            < 2;
        self.version_below_2.push(below_2);
        if is_root {
            self.doc.nodes[0].loc = loc;
        }
        for child in root.children().filter(|c| c.is_element()) {
            self.element(&xml, child, parent, file, 1)?;
        }
        self.stack.pop();
        Ok(())
    }

    /// The attribute `name` of `node` with its `$parameters` replaced.
    fn attr(
        &self,
        xml: &roxmltree::Document,
        node: roxmltree::Node,
        file: usize,
        name: &str,
    ) -> Result<Option<String>> {
        let Some(raw) = node.attribute(name) else {
            return Ok(None);
        };
        if !raw.contains('$') {
            return Ok(Some(raw.to_string()));
        }
        let mut s = raw.to_string();
        for (k, v) in &self.params {
            s = s.replace(&format!("${k}"), v);
            if s.len() > MAX_ATTRIBUTE {
                return Err(self.file_error(
                    file,
                    loc_of(xml, node),
                    format!("an attribute grows beyond {MAX_ATTRIBUTE} bytes with its parameters"),
                ));
            }
        }
        if let Some(i) = s.find('$') {
            let rest: String = s[i + 1..]
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            return Err(self.file_error(
                file,
                loc_of(xml, node),
                format!(
                    "undefined parameter \"${rest}\" (give it with -D {rest}=VALUE or a <default>)"
                ),
            ));
        }
        Ok(Some(s))
    }

    /// The attribute `name`, which must be there.
    fn required(
        &self,
        xml: &roxmltree::Document,
        node: roxmltree::Node,
        file: usize,
        name: &str,
    ) -> Result<String> {
        self.attr(xml, node, file, name)?.ok_or_else(|| {
            self.file_error(
                file,
                loc_of(xml, node),
                format!("<{}> needs a \"{name}\" attribute", node.tag_name().name()),
            )
        })
    }

    /// One element under object `parent`.
    fn element(
        &mut self,
        xml: &roxmltree::Document,
        node: roxmltree::Node,
        parent: usize,
        file: usize,
        depth: usize,
    ) -> Result<()> {
        let tag = node.tag_name().name();
        let loc = loc_of(xml, node);
        if depth > MAX_NESTING {
            return Err(self.file_error(file, loc, "objects nested too deeply"));
        }
        match tag {
            t if is_object(t) => self.object(xml, node, parent, file, depth),
            "ref" => {
                let id = self.required(xml, node, file, "id")?;
                let name = self.attr(xml, node, file, "name")?;
                let slot = self.doc.nodes[parent].children.len();
                self.doc.nodes[parent].children.push(Child {
                    name,
                    node: usize::MAX,
                    loc,
                });
                self.pending.push((parent, slot, id));
                Ok(())
            }
            "default" => {
                let name = self.required(xml, node, file, "name")?;
                let value = self.required(xml, node, file, "value")?;
                if name.is_empty() {
                    return Err(self.file_error(file, loc, "<default> needs a non-empty name"));
                }
                if !self.params.iter().any(|(k, _)| *k == name) {
                    self.params.push((name, value));
                    self.sort_params();
                }
                Ok(())
            }
            "include" => self.include(xml, node, parent, file),
            "alias" => {
                let from = self.required(xml, node, file, "id")?;
                let to = self.required(xml, node, file, "as")?;
                let Some(&(_, target)) = self.ids.iter().find(|(k, _)| *k == from) else {
                    return Err(self.file_error(
                        file,
                        loc,
                        format!("<alias>: no object has id \"{from}\""),
                    ));
                };
                self.add_id(to, target, file, loc)
            }
            "path" => Ok(()),
            _ => {
                let value = self.property(xml, node, file)?;
                let name = self.required(xml, node, file, "name")?;
                let name = if self.version_below_2[file] {
                    camel_to_snake(&name)
                } else {
                    name
                };
                let props = &mut self.doc.nodes[parent].props;
                props.retain(|p| p.name != name);
                props.push(Prop {
                    name,
                    value,
                    loc,
                    used: Cell::new(false),
                });
                Ok(())
            }
        }
    }

    fn add_id(&mut self, id: String, node: usize, file: usize, loc: Loc) -> Result<()> {
        if self.ids.iter().any(|(k, _)| *k == id) {
            return Err(self.file_error(file, loc, format!("duplicate id \"{id}\"")));
        }
        self.ids.push((id, node));
        Ok(())
    }

    /// An object element and everything in it.
    fn object(
        &mut self,
        xml: &roxmltree::Document,
        node: roxmltree::Node,
        parent: usize,
        file: usize,
        depth: usize,
    ) -> Result<()> {
        let tag = node.tag_name().name().to_string();
        let loc = loc_of(xml, node);
        let plugin = self.required(xml, node, file, "type")?;
        let id = self.attr(xml, node, file, "id")?;
        let name = self.attr(xml, node, file, "name")?;
        let index = self.doc.nodes.len();
        self.doc.nodes.push(Node {
            tag,
            plugin,
            id: id.clone(),
            props: Vec::new(),
            children: Vec::new(),
            file,
            loc,
        });
        if let Some(id) = id {
            self.add_id(id, index, file, loc)?;
        }
        self.doc.nodes[parent].children.push(Child {
            name,
            node: index,
            loc,
        });
        for child in node.children().filter(|c| c.is_element()) {
            self.element(xml, child, index, file, depth + 1)?;
        }
        if self.version_below_2[file] {
            upgrade_from_v1(&mut self.doc.nodes[index]);
        }
        Ok(())
    }

    /// `<include filename>`: the other file's scene children join `parent`.
    fn include(
        &mut self,
        xml: &roxmltree::Document,
        node: roxmltree::Node,
        parent: usize,
        file: usize,
    ) -> Result<()> {
        let loc = loc_of(xml, node);
        let name = self.required(xml, node, file, "filename")?;
        if !self.follow {
            return Ok(());
        }
        let dir = self.doc.files[file]
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        let path = dir.join(&name);
        let canonical = std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone());
        if self.stack.contains(&canonical) {
            return Err(self.file_error(file, loc, format!("\"{name}\" includes itself")));
        }
        if self.stack.len() >= MAX_INCLUDE_DEPTH {
            return Err(self.file_error(
                file,
                loc,
                format!("<include> nested deeper than {MAX_INCLUDE_DEPTH} files"),
            ));
        }
        let text =
            read_text(&path).map_err(|e| self.file_error(file, loc, format!("<include>: {e}")))?;
        self.file(&text, &path, parent, false)
    }

    /// Points every `<ref>` at its object.
    fn resolve_refs(&mut self) -> Result<()> {
        for (parent, slot, id) in std::mem::take(&mut self.pending) {
            let Some(&(_, target)) = self.ids.iter().find(|(k, _)| *k == id) else {
                let p = &self.doc.nodes[parent];
                let loc = p.children[slot].loc;
                return Err(self
                    .doc
                    .error(p, loc, format!("<ref>: no object has id \"{id}\"")));
            };
            if target == parent || self.contains(target, parent) {
                let p = &self.doc.nodes[parent];
                let loc = p.children[slot].loc;
                return Err(self.doc.error(
                    p,
                    loc,
                    format!("<ref id=\"{id}\"> refers to an object that contains it"),
                ));
            }
            self.doc.nodes[parent].children[slot].node = target;
        }
        Ok(())
    }

    /// Whether `inner` is nested (directly or deeper, by nesting only) inside `outer`.
    fn contains(&self, outer: usize, inner: usize) -> bool {
        self.doc.nodes[outer]
            .children
            .iter()
            .filter(|c| c.node != usize::MAX && c.node > outer)
            .any(|c| c.node == inner || self.contains(c.node, inner))
    }

    /// A property element's value.
    fn property(
        &self,
        xml: &roxmltree::Document,
        node: roxmltree::Node,
        file: usize,
    ) -> Result<Value> {
        let tag = node.tag_name().name();
        let loc = loc_of(xml, node);
        let err = |msg: String| self.file_error(file, loc, msg);
        let value = |this: &Self| this.required(xml, node, file, "value");
        Ok(match tag {
            "float" => Value::Float(number(&value(self)?).ok_or_else(|| {
                err(format!(
                    "could not parse floating point value \"{}\"",
                    node.attribute("value").unwrap_or("")
                ))
            })?),
            "integer" => {
                let v = value(self)?;
                Value::Integer(
                    v.trim()
                        .parse::<i64>()
                        .map_err(|_| err(format!("could not parse integer value \"{v}\"")))?,
                )
            }
            "boolean" => {
                let v = value(self)?;
                Value::Bool(match v.trim().to_ascii_lowercase().as_str() {
                    "true" => true,
                    "false" => false,
                    _ => {
                        return Err(err(format!(
                            "could not parse boolean value \"{v}\": must be true or false"
                        )))
                    }
                })
            }
            "string" => Value::Str(value(self)?),
            "rgb" | "srgb" => {
                let v = value(self)?;
                let n =
                    numbers(&v).ok_or_else(|| err(format!("could not parse RGB value \"{v}\"")))?;
                match n[..] {
                    [a] => Value::Rgb(DVec3::splat(a)),
                    [r, g, b] => Value::Rgb(DVec3::new(r, g, b)),
                    _ => {
                        return Err(err(format!(
                            "<rgb> needs one or three values (got {})",
                            n.len()
                        )))
                    }
                }
            }
            "spectrum" => self.spectrum(xml, node, file)?,
            "point" | "vector" => {
                let v = self.xyz(xml, node, file, 0.0)?;
                if tag == "point" {
                    Value::Point(v)
                } else {
                    Value::Vector(v)
                }
            }
            "transform" => {
                let mut m = DMat4::IDENTITY;
                for op in node.children().filter(|c| c.is_element()) {
                    m = self.transform_op(xml, op, file)? * m;
                }
                Value::Transform(m)
            }
            _ => return Err(err(format!("unexpected element <{tag}>"))),
        })
    }

    fn spectrum(
        &self,
        xml: &roxmltree::Document,
        node: roxmltree::Node,
        file: usize,
    ) -> Result<Value> {
        let loc = loc_of(xml, node);
        let err = |msg: String| self.file_error(file, loc, msg);
        if self.attr(xml, node, file, "filename")?.is_some() {
            return Err(err(
                "<spectrum filename=…> (a spectrum file) is not supported; give the values".into(),
            ));
        }
        let v = self.required(xml, node, file, "value")?;
        if !v.contains(':') {
            return number(&v)
                .map(Value::Uniform)
                .ok_or_else(|| err(format!("could not parse spectrum value \"{v}\"")));
        }
        let mut pairs = Vec::new();
        for item in v.split([',', ' ', '\t', '\n']).filter(|s| !s.is_empty()) {
            let pair = item
                .split_once(':')
                .and_then(|(l, x)| Some((number(l)?, number(x)?)));
            let Some(pair) = pair else {
                return Err(err(format!("could not parse spectrum pair \"{item}\"")));
            };
            pairs.push(pair);
        }
        if pairs.windows(2).any(|w| w[1].0 <= w[0].0) {
            return Err(err("spectrum wavelengths must increase".into()));
        }
        Ok(Value::Sampled(pairs))
    }

    /// `x`/`y`/`z` attributes (missing ones `default`) or one `value` of one or three numbers.
    fn xyz(
        &self,
        xml: &roxmltree::Document,
        node: roxmltree::Node,
        file: usize,
        default: f64,
    ) -> Result<DVec3> {
        let loc = loc_of(xml, node);
        let err = |msg: String| self.file_error(file, loc, msg);
        if let Some(v) = self.attr(xml, node, file, "value")? {
            let n = numbers(&v).ok_or_else(|| err(format!("could not parse vector \"{v}\"")))?;
            return match n[..] {
                [a] => Ok(DVec3::splat(a)),
                [x, y, z] => Ok(DVec3::new(x, y, z)),
                _ => Err(err(format!("\"{v}\": needs one or three numbers"))),
            };
        }
        let mut out = [default; 3];
        for (i, k) in ["x", "y", "z"].iter().enumerate() {
            if let Some(v) = self.attr(xml, node, file, k)? {
                out[i] = number(&v)
                    .ok_or_else(|| err(format!("could not parse \"{k}\" value \"{v}\"")))?;
            }
        }
        Ok(DVec3::from_array(out))
    }

    /// One operation inside `<transform>`.
    fn transform_op(
        &self,
        xml: &roxmltree::Document,
        op: roxmltree::Node,
        file: usize,
    ) -> Result<DMat4> {
        let loc = loc_of(xml, op);
        let err = |msg: String| self.file_error(file, loc, msg);
        let m = match op.tag_name().name() {
            "translate" => DMat4::from_translation(self.xyz(xml, op, file, 0.0)?),
            "scale" => DMat4::from_scale(self.xyz(xml, op, file, 1.0)?),
            "rotate" => {
                let axis = self.xyz(xml, op, file, 0.0)?;
                let angle = self.required(xml, op, file, "angle")?;
                let angle = number(&angle)
                    .ok_or_else(|| err(format!("could not parse angle value \"{angle}\"")))?;
                if axis == DVec3::ZERO {
                    return Err(err("rotation axis cannot be zero".into()));
                }
                DMat4::from_axis_angle(axis.normalize(), angle.to_radians())
            }
            "matrix" => {
                let v = self.required(xml, op, file, "value")?;
                let n = numbers(&v)
                    .ok_or_else(|| err(format!("could not parse matrix value \"{v}\"")))?;
                let size = match n.len() {
                    16 => 4,
                    9 => 3,
                    k => return Err(err(format!("matrix must have 9 or 16 values, got {k}"))),
                };
                let mut cols = DMat4::IDENTITY.to_cols_array_2d();
                for row in 0..size {
                    for col in 0..size {
                        cols[col][row] = n[row * size + col];
                    }
                }
                DMat4::from_cols_array_2d(&cols)
            }
            "lookat" => self.lookat(xml, op, file)?,
            other => {
                return Err(err(format!(
                    "unexpected <{other}> element inside <transform>"
                )))
            }
        };
        if !m.is_finite() {
            return Err(err("the transform is not finite".into()));
        }
        Ok(m)
    }

    /// `<lookat origin target up>`: columns left, up, forward, origin (Mitsuba's camera space
    /// has +X to the image's left).
    fn lookat(&self, xml: &roxmltree::Document, op: roxmltree::Node, file: usize) -> Result<DMat4> {
        let loc = loc_of(xml, op);
        let err = |msg: String| self.file_error(file, loc, msg);
        let vector = |name: &str| -> Result<Option<DVec3>> {
            let Some(v) = self.attr(xml, op, file, name)? else {
                return Ok(None);
            };
            match numbers(&v).as_deref() {
                Some([x, y, z]) => Ok(Some(DVec3::new(*x, *y, *z))),
                _ => Err(err(format!(
                    "<lookat> \"{name}\" needs three numbers, not \"{v}\""
                ))),
            }
        };
        let need = |name: &str| -> Result<DVec3> {
            vector(name)?.ok_or_else(|| err(format!("<lookat> needs \"{name}\"")))
        };
        let (origin, target) = (need("origin")?, need("target")?);
        let dir = (target - origin).normalize_or_zero();
        let mut up = vector("up")?.unwrap_or(DVec3::ZERO);
        if up == DVec3::ZERO {
            up = dir.any_orthonormal_vector();
        }
        let left = up.cross(dir).normalize_or_zero();
        if dir == DVec3::ZERO || left == DVec3::ZERO {
            return Err(err("invalid lookat transformation (origin equals target, or up is parallel to the view)".into()));
        }
        let new_up = dir.cross(left);
        Ok(DMat4::from_cols(
            left.extend(0.0),
            new_up.extend(0.0),
            dir.extend(0.0),
            origin.extend(1.0),
        ))
    }
}

/// `major.minor.patch` (minor and patch optional).
fn parse_version(s: &str) -> Option<(u32, u32, u32)> {
    let mut it = s.trim().split('.');
    let major = it.next()?.parse().ok()?;
    let minor = it.next().map_or(Some(0), |x| x.parse().ok())?;
    let patch = it.next().map_or(Some(0), |x| x.parse().ok())?;
    it.next().is_none().then_some((major, minor, patch))
}

/// A finite number.
fn number(s: &str) -> Option<f64> {
    s.trim().parse::<f64>().ok().filter(|v| v.is_finite())
}

/// Finite numbers separated by commas and white space.
fn numbers(s: &str) -> Option<Vec<f64>> {
    s.split([',', ' ', '\t', '\n', '\r'])
        .filter(|t| !t.is_empty())
        .map(number)
        .collect()
}

/// Mitsuba 3's renaming of version-1 property names: `intIOR` → `int_ior`,
/// `specularReflectance` → `specular_reflectance`.
pub fn camel_to_snake(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if i > 0 && chars[i - 1].is_lowercase() && c.is_uppercase() {
            out.push('_');
            out.push(c.to_ascii_lowercase());
            while i + 1 < chars.len() && chars[i + 1].is_uppercase() {
                i += 1;
                out.push(chars[i].to_ascii_lowercase());
            }
        } else {
            out.push(c);
        }
        i += 1;
    }
    out
}

/// The upgrades of an object from a version-1 file that go beyond names.
fn upgrade_from_v1(node: &mut Node) {
    if node.plugin == "diffuse" {
        for p in &mut node.props {
            if p.name == "diffuse_reflectance" {
                p.name = "reflectance".into();
            }
        }
        for c in &mut node.children {
            if c.name.as_deref() == Some("diffuse_reflectance") {
                c.name = Some("reflectance".into());
            }
        }
    }
    let take = |node: &mut Node, name: &str| -> Option<(f64, Loc)> {
        let i = node.props.iter().position(|p| p.name == name)?;
        let p = node.props.remove(i);
        match p.value {
            Value::Float(v) => Some((v, p.loc)),
            Value::Integer(v) => Some((v as f64, p.loc)),
            _ => None,
        }
    };
    let (uo, vo, us, vs) = (
        take(node, "uoffset"),
        take(node, "voffset"),
        take(node, "uscale"),
        take(node, "vscale"),
    );
    if uo.is_some() || vo.is_some() || us.is_some() || vs.is_some() {
        let loc = [uo, vo, us, vs]
            .iter()
            .flatten()
            .map(|x| x.1)
            .next()
            .unwrap_or_default();
        let offset = DVec3::new(uo.map_or(0.0, |x| x.0), vo.map_or(0.0, |x| x.0), 0.0);
        let scale = DVec3::new(us.map_or(1.0, |x| x.0), vs.map_or(1.0, |x| x.0), 1.0);
        node.props.push(Prop {
            name: "to_uv".into(),
            value: Value::Transform(DMat4::from_scale(scale) * DMat4::from_translation(offset)),
            loc,
            used: Cell::new(false),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<Doc> {
        read_text_as(text, Path::new("t.xml"), &[], false)
    }

    #[test]
    fn camel_case_becomes_snake_case() {
        assert_eq!(camel_to_snake("intIOR"), "int_ior");
        assert_eq!(
            camel_to_snake("specularReflectance"),
            "specular_reflectance"
        );
        assert_eq!(camel_to_snake("toWorld"), "to_world");
        assert_eq!(camel_to_snake("alpha"), "alpha");
    }

    #[test]
    fn defaults_substitute_and_user_values_win() {
        let text = r#"<scene version="3.0.0"><default name="spp" value="64"/>
            <default name="s" value="2"/>
            <sampler type="independent"><integer name="sample_count" value="$spp$s"/></sampler></scene>"#;
        let doc = read(text).unwrap();
        assert_eq!(doc.nodes[1].props[0].value, Value::Integer(642));
        let doc = read_text_as(
            text,
            Path::new("t.xml"),
            &[("spp".into(), "8".into())],
            false,
        )
        .unwrap();
        assert_eq!(doc.nodes[1].props[0].value, Value::Integer(82));
    }

    #[test]
    fn transforms_apply_in_order() {
        let text = r#"<scene version="3.0.0"><shape type="sphere"><transform name="to_world">
            <scale value="2"/><translate x="1"/><rotate y="1" angle="90"/></transform></shape></scene>"#;
        let doc = read(text).unwrap();
        let Value::Transform(m) = doc.nodes[1].props[0].value else {
            panic!()
        };
        let p = m.transform_point3(DVec3::new(1.0, 0.0, 0.0));
        // scale → (2,0,0), translate → (3,0,0), rotate 90° about y → (0,0,−3).
        assert!((p - DVec3::new(0.0, 0.0, -3.0)).length() < 1e-9, "{p}");
    }

    #[test]
    fn matrices_are_row_major() {
        let text = r#"<scene version="3.0.0"><shape type="sphere"><transform name="to_world">
            <matrix value="1 0 0 5 0 1 0 6 0 0 1 7 0 0 0 1"/></transform></shape></scene>"#;
        let doc = read(text).unwrap();
        let Value::Transform(m) = doc.nodes[1].props[0].value else {
            panic!()
        };
        assert_eq!(m.transform_point3(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0));
    }

    #[test]
    fn refs_resolve_in_any_order_and_old_names_upgrade() {
        let text = r#"<scene version="0.6.0"><shape type="obj"><ref id="m"/></shape>
            <bsdf type="diffuse" id="m"><rgb name="diffuseReflectance" value="0.5"/></bsdf></scene>"#;
        let doc = read(text).unwrap();
        let target = doc.nodes[1].children[0].node;
        assert_eq!(doc.nodes[target].id.as_deref(), Some("m"));
        assert_eq!(doc.nodes[target].props[0].name, "reflectance");
    }
}
