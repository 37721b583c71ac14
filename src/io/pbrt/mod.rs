//! pbrt-v4 scene files. This module reads the file syntax into a flat list of directives
//! with their positional arguments and typed parameter lists, each with its file, line and
//! column. `Include` and `Import` are followed relative to the including file (a cycle, a
//! missing file or a nesting deeper than [`MAX_INCLUDE_DEPTH`] is an error). `scene`
//! interprets the graphics state, `shapes`, `materials` and lights into a
//! [`crate::io::desc::SceneDesc`] ([`load_file`]).
//!
//! Syntax (pbrt-v4's `parser.cpp`): tokens are double-quoted strings (with `\` escapes),
//! numbers, bare words (directive names, `true`/`false`) and `[` `]`; `#` starts a comment to
//! the end of the line. A directive is a bare word, its positional arguments (numbers,
//! strings, or one bracketed list of numbers for `Transform`/`ConcatTransform`), then
//! parameters, each a string `"type name"` followed by one value or a bracketed list.

mod images;
mod lexer;
mod params;
mod scene;
pub mod spectra;
mod subdiv;

pub use scene::{load_file, load_text};

pub use lexer::{Token, TokenKind};

use crate::error::{Error, Loc, Result};
use std::path::{Path, PathBuf};

/// Deepest chain of `Include`/`Import`s followed.
pub const MAX_INCLUDE_DEPTH: usize = 32;
/// Most values one parameter or argument list may hold.
pub const MAX_VALUES: usize = 1 << 28;

/// A parameter's values.
#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    /// Numbers (`integer`, `float`, `point3`, `rgb`, `blackbody`, ...).
    Numbers(Vec<f64>),
    /// Strings (`string`, `texture`, `spectrum` by name).
    Strings(Vec<String>),
    /// Truth values (`bool`).
    Bools(Vec<bool>),
}

/// One `"type name" value(s)` parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    /// The declared type (`float`, `rgb`, `point3`, ...).
    pub ty: String,
    /// The parameter's name.
    pub name: String,
    /// Its values.
    pub values: Values,
    /// Where its declaration is.
    pub loc: Loc,
}

/// A positional argument of a directive.
#[derive(Clone, Debug, PartialEq)]
pub enum Arg {
    /// A number.
    Number(f64),
    /// A string.
    Str(String),
    /// A bracketed list of numbers (`Transform [ ... ]`).
    Numbers(Vec<f64>),
}

/// One directive of a scene file.
#[derive(Clone, Debug, PartialEq)]
pub struct Directive {
    /// Its name (`Shape`, `LookAt`, `AttributeBegin`, ...).
    pub name: String,
    /// Its positional arguments.
    pub args: Vec<Arg>,
    /// Its parameters.
    pub params: Vec<Param>,
    /// The file it is in (as given or joined to the including file's folder).
    pub file: PathBuf,
    /// Where its name is.
    pub loc: Loc,
}

/// The positional arguments a directive takes: how many numbers, strings, or whether it
/// takes one bracketed list of numbers.
fn arity(name: &str) -> Option<(usize, usize, bool)> {
    Some(match name {
        "AttributeBegin" | "AttributeEnd" | "WorldBegin" | "WorldEnd" | "ObjectEnd"
        | "ReverseOrientation" | "Identity" | "TransformBegin" | "TransformEnd" => (0, 0, false),
        "Translate" | "Scale" => (3, 0, false),
        "Rotate" => (4, 0, false),
        "LookAt" => (9, 0, false),
        "Transform" | "ConcatTransform" => (0, 0, true),
        "Shape" | "Material" | "Camera" | "Film" | "Sampler" | "Integrator" | "PixelFilter"
        | "Accelerator" | "LightSource" | "AreaLightSource" | "MakeNamedMaterial"
        | "NamedMaterial" | "ObjectBegin" | "ObjectInstance" | "CoordinateSystem"
        | "CoordSysTransform" | "Include" | "Import" | "ColorSpace" | "Option"
        | "ActiveTransform" | "Attribute" | "MakeNamedMedium" => (0, 1, false),
        "MediumInterface" => (0, 2, false),
        "Texture" => (0, 3, false),
        "TransformTimes" => (2, 0, false),
        _ => return None,
    })
}

/// Reads the pbrt-v4 file at `path` and every file it includes into one list of directives,
/// in file order (an `Include`d file's directives in place of the `Include`).
pub fn read_file(path: &Path) -> Result<Vec<Directive>> {
    let mut out = Vec::new();
    let mut stack = Vec::new();
    read_into(path, &mut stack, &mut out)?;
    Ok(out)
}

fn read_into(path: &Path, stack: &mut Vec<PathBuf>, out: &mut Vec<Directive>) -> Result<()> {
    let file = path.display().to_string();
    let canonical = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    if stack.contains(&canonical) {
        return Err(Error::File {
            file,
            msg: "includes itself (an Include or Import cycle)".into(),
        });
    }
    if stack.len() >= MAX_INCLUDE_DEPTH {
        return Err(Error::File {
            file,
            msg: format!("Include/Import nested deeper than {MAX_INCLUDE_DEPTH} files"),
        });
    }
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: file.clone(),
        what: "cannot read scene file",
        source,
    })?;
    let text = String::from_utf8(bytes).map_err(|e| Error::File {
        file: file.clone(),
        msg: format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
    })?;
    stack.push(canonical);
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    for d in parse(&text, path)? {
        if d.name == "Include" || d.name == "Import" {
            let Some(Arg::Str(rel)) = d.args.first() else {
                continue;
            };
            let target = dir.join(rel);
            if !target.is_file() {
                return Err(Error::At {
                    file: d.file.display().to_string(),
                    loc: d.loc,
                    msg: format!(
                        "{} \"{rel}\": {} is not a readable file",
                        d.name,
                        target.display()
                    ),
                });
            }
            read_into(&target, stack, out)?;
        } else {
            out.push(d);
        }
    }
    stack.pop();
    Ok(())
}

/// Parses the text of one file (named `file` in messages) into its directives, without
/// following `Include`s.
pub fn parse(text: &str, file: &Path) -> Result<Vec<Directive>> {
    let name = file.display().to_string();
    let err = |loc: Loc, msg: String| Error::At {
        file: name.clone(),
        loc,
        msg,
    };
    let tokens = lexer::tokens(text).map_err(|(loc, msg)| err(loc, msg))?;
    let mut p = Parser {
        tokens: &tokens,
        at: 0,
    };
    let mut out = Vec::new();
    while let Some(t) = p.next() {
        let TokenKind::Word(w) = &t.kind else {
            return Err(err(
                t.loc,
                format!("expected a directive, found {}", t.kind),
            ));
        };
        let (numbers, strings, list) =
            arity(w).ok_or_else(|| err(t.loc, format!("unknown directive '{w}'")))?;
        let args = p
            .args(w, numbers, strings, list)
            .map_err(|(loc, msg)| err(loc, msg))?;
        let params = p.params().map_err(|(loc, msg)| err(loc, msg))?;
        out.push(Directive {
            name: w.clone(),
            args,
            params,
            file: file.to_path_buf(),
            loc: t.loc,
        });
    }
    Ok(out)
}

/// A syntax error: where, and what.
type SyntaxError = (Loc, String);

struct Parser<'a> {
    tokens: &'a [Token],
    at: usize,
}

impl<'a> Parser<'a> {
    fn next(&mut self) -> Option<&'a Token> {
        let t = self.tokens.get(self.at)?;
        self.at += 1;
        Some(t)
    }

    fn peek(&self) -> Option<&'a Token> {
        self.tokens.get(self.at)
    }

    /// Where the file ends (for errors at its end).
    fn end(&self) -> Loc {
        self.tokens.last().map_or(Loc::default(), |t| t.loc)
    }

    /// The positional arguments of directive `name`.
    fn args(
        &mut self,
        name: &str,
        numbers: usize,
        strings: usize,
        list: bool,
    ) -> std::result::Result<Vec<Arg>, SyntaxError> {
        let mut args = Vec::new();
        for _ in 0..numbers {
            let t = self
                .next()
                .ok_or((self.end(), format!("{name}: missing a number")))?;
            match t.kind {
                TokenKind::Number(x) => args.push(Arg::Number(finite(x, t.loc)?)),
                _ => {
                    return Err((
                        t.loc,
                        format!("{name}: expected a number, found {}", t.kind),
                    ))
                }
            }
        }
        for _ in 0..strings {
            let t = self
                .next()
                .ok_or((self.end(), format!("{name}: missing a string")))?;
            match &t.kind {
                TokenKind::Str(s) => args.push(Arg::Str(s.clone())),
                k => return Err((t.loc, format!("{name}: expected a string, found {k}"))),
            }
        }
        if list {
            let open = self
                .next()
                .ok_or((self.end(), format!("{name}: missing '['")))?;
            if open.kind != TokenKind::Open {
                return Err((
                    open.loc,
                    format!("{name}: expected '[', found {}", open.kind),
                ));
            }
            match self.list(open.loc)? {
                Values::Numbers(v) => args.push(Arg::Numbers(v)),
                _ => return Err((open.loc, format!("{name}: expected numbers"))),
            }
        }
        Ok(args)
    }

    /// The parameters that follow a directive's arguments.
    fn params(&mut self) -> std::result::Result<Vec<Param>, SyntaxError> {
        let mut params = Vec::new();
        while let Some(Token {
            kind: TokenKind::Str(decl),
            loc,
        }) = self.peek()
        {
            self.at += 1;
            let mut words = decl.split_whitespace();
            let (Some(ty), Some(name), None) = (words.next(), words.next(), words.next()) else {
                return Err((
                    *loc,
                    format!("expected a parameter \"type name\", found \"{decl}\""),
                ));
            };
            let t = self
                .next()
                .ok_or((self.end(), format!("parameter '{name}' has no value")))?;
            let values = match &t.kind {
                TokenKind::Open => self.list(t.loc)?,
                _ => single(t)?,
            };
            params.push(Param {
                ty: ty.to_string(),
                name: name.to_string(),
                values,
                loc: *loc,
            });
        }
        Ok(params)
    }

    /// The values of a bracketed list, after its `[`: all numbers, all strings or all truth
    /// values.
    fn list(&mut self, open: Loc) -> std::result::Result<Values, SyntaxError> {
        let mut numbers = Vec::new();
        let mut strings = Vec::new();
        let mut bools = Vec::new();
        loop {
            let t = self
                .next()
                .ok_or((open, "a '[' is never closed".to_string()))?;
            match &t.kind {
                TokenKind::Close => break,
                TokenKind::Number(x) => numbers.push(finite(*x, t.loc)?),
                TokenKind::Str(s) => strings.push(s.clone()),
                TokenKind::Word(w) if w == "true" || w == "false" => bools.push(w == "true"),
                k => return Err((t.loc, format!("unexpected {k} in a list"))),
            }
            if numbers.len() + strings.len() + bools.len() > MAX_VALUES {
                return Err((open, format!("a list of more than {MAX_VALUES} values")));
            }
        }
        let kinds = [!numbers.is_empty(), !strings.is_empty(), !bools.is_empty()];
        if kinds.iter().filter(|&&k| k).count() > 1 {
            return Err((
                open,
                "a list mixes numbers, strings and truth values".into(),
            ));
        }
        Ok(if !strings.is_empty() {
            Values::Strings(strings)
        } else if !bools.is_empty() {
            Values::Bools(bools)
        } else {
            Values::Numbers(numbers)
        })
    }
}

/// The value of a parameter given without brackets.
fn single(t: &Token) -> std::result::Result<Values, SyntaxError> {
    Ok(match &t.kind {
        TokenKind::Number(x) => Values::Numbers(vec![finite(*x, t.loc)?]),
        TokenKind::Str(s) => Values::Strings(vec![s.clone()]),
        TokenKind::Word(w) if w == "true" || w == "false" => Values::Bools(vec![w == "true"]),
        k => return Err((t.loc, format!("expected a value, found {k}"))),
    })
}

fn finite(x: f64, loc: Loc) -> std::result::Result<f64, SyntaxError> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err((loc, format!("not a finite number: {x}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parsed(text: &str) -> Vec<Directive> {
        parse(text, Path::new("t.pbrt")).unwrap()
    }

    fn error(text: &str) -> String {
        parse(text, Path::new("t.pbrt")).unwrap_err().to_string()
    }

    #[test]
    fn directives_arguments_and_parameters() {
        let d = parsed(
            "# a comment\nLookAt 0 1 2  3 4 5 0 1 0\nCamera \"perspective\" \"float fov\" [ 45 ]\n\
             Transform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]\n\
             Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 2]\n\
             \"bool flip\" true \"string name\" \"a \\\"b\\\"\"\n\
             Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"x.png\"\n",
        );
        let names: Vec<&str> = d.iter().map(|d| d.name.as_str()).collect();
        assert_eq!(names, ["LookAt", "Camera", "Transform", "Shape", "Texture"]);
        assert_eq!(d[0].args.len(), 9);
        assert_eq!(d[0].loc, Loc { line: 2, col: 1 });
        assert_eq!(d[1].params[0].values, Values::Numbers(vec![45.0]));
        assert_eq!(d[1].params[0].loc, Loc { line: 3, col: 22 });
        assert!(matches!(&d[2].args[0], Arg::Numbers(v) if v.len() == 16));
        let shape = &d[3];
        assert_eq!(shape.args, [Arg::Str("trianglemesh".into())]);
        assert_eq!(
            (shape.params[0].ty.as_str(), shape.params[0].name.as_str()),
            ("point3", "P")
        );
        assert_eq!(shape.params[2].values, Values::Bools(vec![true]));
        assert_eq!(
            shape.params[3].values,
            Values::Strings(vec!["a \"b\"".into()])
        );
        assert_eq!(d[4].args.len(), 3);
    }

    #[test]
    fn malformed_files_name_the_place() {
        for (text, want) in [
            ("Frobnicate 1", "t.pbrt:1:1: unknown directive 'Frobnicate'"),
            ("Translate 1 2", "Translate: missing a number"),
            (
                "Shape \"sphere\" \"float radius\" [ 1",
                "t.pbrt:1:31: a '[' is never closed",
            ),
            (
                "Shape \"sphere\" \"radius\" 1",
                "expected a parameter \"type name\"",
            ),
            (
                "Shape \"sphere\" \"float r\" [1 \"x\"]",
                "mixes numbers, strings",
            ),
            (
                "Shape \"s\" \"string a\" \"unterminated",
                "t.pbrt:1:22: a string is never closed",
            ),
            ("Scale 1 1e999 1", "not a finite number"),
            ("Shape \"s\" \"float r\"", "parameter 'r' has no value"),
            (
                "LookAt 0 0 0 0 0 1 0 1 x",
                "LookAt: expected a number, found 'x'",
            ),
        ] {
            let e = error(text);
            assert!(e.contains(want), "{text}: {e}");
        }
    }

    #[test]
    fn includes_are_followed_and_cycles_refused() {
        let dir = std::env::temp_dir().join(format!("pbrt-include-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        std::fs::write(
            dir.join("main.pbrt"),
            "Scale 1 1 1\nInclude \"sub/a.pbrt\"\nWorldBegin\n",
        )
        .unwrap();
        std::fs::write(
            dir.join("sub/a.pbrt"),
            "Translate 1 2 3\nImport \"b.pbrt\"\n",
        )
        .unwrap();
        std::fs::write(dir.join("sub/b.pbrt"), "Rotate 90 0 1 0\n").unwrap();
        let d = read_file(&dir.join("main.pbrt")).unwrap();
        let names: Vec<&str> = d.iter().map(|d| d.name.as_str()).collect();
        assert_eq!(names, ["Scale", "Translate", "Rotate", "WorldBegin"]);
        assert!(d[2].file.ends_with("sub/b.pbrt"));
        std::fs::write(dir.join("sub/b.pbrt"), "Include \"a.pbrt\"\n").unwrap();
        let e = read_file(&dir.join("main.pbrt")).unwrap_err().to_string();
        assert!(e.contains("a.pbrt: includes itself"), "{e}");
        std::fs::write(dir.join("sub/b.pbrt"), "Include \"missing.pbrt\"\n").unwrap();
        let e = read_file(&dir.join("main.pbrt")).unwrap_err().to_string();
        assert!(
            e.contains("b.pbrt:1:1: Include \"missing.pbrt\": ")
                && e.contains("is not a readable file"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
