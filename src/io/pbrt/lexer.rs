//! The tokens of a pbrt-v4 file, each with its line and column (1-based, columns in
//! characters).

use crate::error::Loc;
use std::fmt;

/// What a token is.
#[derive(Clone, Debug, PartialEq)]
pub enum TokenKind {
    /// A bare word: a directive name, `true` or `false`.
    Word(String),
    /// A double-quoted string, its escapes resolved.
    Str(String),
    /// A number.
    Number(f64),
    /// `[`.
    Open,
    /// `]`.
    Close,
}

impl fmt::Display for TokenKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TokenKind::Word(w) => write!(f, "'{w}'"),
            TokenKind::Str(s) => write!(f, "\"{s}\""),
            TokenKind::Number(x) => write!(f, "{x}"),
            TokenKind::Open => f.write_str("'['"),
            TokenKind::Close => f.write_str("']'"),
        }
    }
}

/// A token and where it starts.
#[derive(Clone, Debug, PartialEq)]
pub struct Token {
    /// What it is.
    pub kind: TokenKind,
    /// Where it starts.
    pub loc: Loc,
}

/// The tokens of `text`, or where and why it cannot be read.
pub fn tokens(text: &str) -> Result<Vec<Token>, (Loc, String)> {
    let mut out = Vec::new();
    let mut chars = text.chars().peekable();
    let (mut line, mut col) = (1u32, 1u32);
    while let Some(&c) = chars.peek() {
        let loc = Loc { line, col };
        let mut step = |chars: &mut std::iter::Peekable<std::str::Chars>| {
            let c = chars.next();
            if c == Some('\n') {
                line += 1;
                col = 1;
            } else {
                col += 1;
            }
            c
        };
        match c {
            c if c.is_whitespace() => {
                step(&mut chars);
            }
            '#' => {
                while chars.peek().is_some_and(|&c| c != '\n') {
                    step(&mut chars);
                }
            }
            '[' | ']' => {
                step(&mut chars);
                let kind = if c == '[' {
                    TokenKind::Open
                } else {
                    TokenKind::Close
                };
                out.push(Token { kind, loc });
            }
            '"' => {
                step(&mut chars);
                let mut s = String::new();
                loop {
                    match step(&mut chars) {
                        None | Some('\n') => {
                            return Err((loc, "a string is never closed".into()));
                        }
                        Some('"') => break,
                        Some('\\') => match step(&mut chars) {
                            Some('n') => s.push('\n'),
                            Some('t') => s.push('\t'),
                            Some(e @ ('\\' | '"' | '\'')) => s.push(e),
                            Some(e) => {
                                return Err((loc, format!("unknown escape '\\{e}' in a string")))
                            }
                            None => return Err((loc, "a string is never closed".into())),
                        },
                        Some(ch) => s.push(ch),
                    }
                }
                out.push(Token {
                    kind: TokenKind::Str(s),
                    loc,
                });
            }
            _ => {
                let mut word = String::new();
                while chars
                    .peek()
                    .is_some_and(|&c| !c.is_whitespace() && !matches!(c, '"' | '[' | ']' | '#'))
                {
                    if let Some(ch) = step(&mut chars) {
                        word.push(ch);
                    }
                }
                let numeric = word.starts_with(|c: char| c.is_ascii_digit() || "+-.".contains(c));
                let kind = if numeric {
                    TokenKind::Number(
                        word.parse::<f64>()
                            .map_err(|_| (loc, format!("not a number: '{word}'")))?,
                    )
                } else {
                    TokenKind::Word(word)
                };
                out.push(Token { kind, loc });
            }
        }
    }
    Ok(out)
}
