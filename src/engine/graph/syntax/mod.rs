//! Position-preserving parser for the RON subset used by pipeline files.
//!
//! The `ron` crate reports where a *syntax* error happens, but once a value
//! has parsed it forgets where it came from. Pipeline validation (unknown
//! field, wrong type, missing input, cycle, ...) must still point the user at
//! `file:line:column`, so this module parses the text into a small [`Ron`]
//! tree in which every value, field name and struct name carries its [`Pos`].
//!
//! Accepted subset:
//! - whitespace (RON's: space, `\t`, `\n`, `\r`, U+000B, U+000C, U+0085, U+200E, U+200F,
//!   U+2028, U+2029), `//` line comments and nested `/* */` block comments;
//! - optional leading `#![enable(...)]` attributes (skipped);
//! - strings `"..."` with escapes `\" \' \\ \n \t \r \0 \u{XXXX}`,
//!   raw strings `r"..."` / `r#"..."#`, and chars `'c'` (read as strings);
//! - integers (decimal, `0x`/`0o`/`0b`, optional sign, `_` separators, not right after the
//!   prefix) and floats (`1.5`, `1.`, `.5`, `1e10`, `-1.0e-3`, `inf`, `-inf`, `NaN`; no `_`
//!   right after the `.`);
//! - `true` / `false`; identifiers `[A-Za-z_][A-Za-z0-9_]*` and `r#ident` (always an
//!   identifier: `r#true` is not a bool);
//! - tuples `(a, b)`, structs `(f: 1)`, named forms `Name(a)` / `Name(f: 1)`
//!   / `Name()`, lists `[a, b]` and maps `{k: v}`; trailing commas anywhere.
//!
//! Positions are 1-based; columns count characters, not bytes, like `ron`.
//!
//! Every text this parser accepts is RON that the `ron` crate reads the same way, and the other
//! way round within the subset: `tests/ron_oracle.rs` checks it, and lists the deliberate
//! differences (a leading byte-order mark, unread `#![...]` attributes, what lies outside the
//! subset).
//!
//! Files: this one holds the tree ([`Ron`], [`Spanned`], [`Pos`]) and [`parse`]; `cursor` the
//! parser's state and character-level steps, `grammar` the recursive descent, `literals` strings
//! and numbers, each an `impl Parser` block on the one state; `tests` their tests.

mod cursor;
mod grammar;
mod literals;
#[cfg(test)]
mod tests;

use std::fmt;

use cursor::Parser;

/// 1-based line and column (columns count characters, not bytes), like the ron crate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Pos {
    pub line: u32,
    pub col: u32,
}

impl fmt::Display for Pos {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.line, self.col)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Spanned<T> {
    pub value: T,
    pub pos: Pos,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Ron {
    Str(String),
    /// An integer literal (decimal, or 0x/0o/0b, optional sign, `_` separators).
    Int(i64),
    /// A float literal (with `.`, exponent, or `inf`/`NaN`/`-inf`).
    Float(f64),
    Bool(bool),
    /// A bare identifier: unit enum variant or unit struct, e.g. `Rec709`, `None`.
    Ident(String),
    /// `(a, b, c)` or `Name(a, b)`: name is the identifier before the parenthesis, if any.
    Tuple {
        name: Option<Spanned<String>>,
        items: Vec<Spanned<Ron>>,
    },
    /// `(f: 1, g: 2)` or `Name(f: 1)`; also `Name()` with no fields when the name is present and the body empty.
    Struct {
        name: Option<Spanned<String>>,
        fields: Vec<(Spanned<String>, Spanned<Ron>)>,
    },
    List(Vec<Spanned<Ron>>),
    /// `{ key: value, ... }`, entries in file order (duplicates kept: the caller reports them).
    Map(Vec<(Spanned<Ron>, Spanned<Ron>)>),
}

impl Ron {
    /// Short name of the value's kind, for error messages.
    pub fn kind_name(&self) -> &'static str {
        match self {
            Ron::Str(_) => "string",
            Ron::Int(_) => "integer",
            Ron::Float(_) => "float",
            Ron::Bool(_) => "bool",
            Ron::Ident(_) => "identifier",
            Ron::Tuple { .. } => "tuple",
            Ron::Struct { .. } => "struct",
            Ron::List(_) => "list",
            Ron::Map(_) => "map",
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct SyntaxError {
    pub pos: Pos,
    pub message: String,
}

impl fmt::Display for SyntaxError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.pos, self.message)
    }
}

impl std::error::Error for SyntaxError {}

/// Parses one value, followed only by whitespace and comments.
pub fn parse(text: &str) -> Result<Spanned<Ron>, SyntaxError> {
    let mut p = Parser::new(text);
    if p.peek() == Some('\u{feff}') {
        p.cur.i += 1; // a byte-order mark is not part of the text, nor of column counts
    }
    p.skip_ws()?;
    p.skip_attributes()?;
    let value = p.value()?;
    p.skip_ws()?;
    if p.peek().is_some() {
        return Err(p.unexpected("end of file after the value"));
    }
    Ok(value)
}
