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
//! Why one file of about 550 code lines: the lexer, the recursive-descent parser and the `Ron`
//! tree share one position type and one error type, and the parser is one grammar read top to
//! bottom; split, each half would only make sense beside the other.

use std::fmt;

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

/// Guards against stack overflow on pathological input such as `[[[[...`.
const MAX_DEPTH: u32 = 128;

fn err(pos: Pos, message: impl Into<String>) -> SyntaxError {
    SyntaxError { pos, message: message.into() }
}

fn describe(c: Option<char>) -> String {
    match c {
        None => "end of file".to_string(),
        Some('\n') => "end of line".to_string(),
        // Invisible characters (a no-break space, say) are shown escaped.
        Some(c) if c.is_control() || (c.is_whitespace() && c != ' ') || c == '\u{feff}' => {
            format!("`{}`", c.escape_default())
        }
        Some(c) => format!("`{c}`"),
    }
}

/// RON's whitespace (Rust's `Pattern_White_Space`), not Unicode's `White_Space`: a no-break
/// space is not whitespace to `ron`, U+200E and U+200F are.
fn is_whitespace(c: char) -> bool {
    matches!(
        c,
        ' ' | '\t' | '\n' | '\r' | '\u{b}' | '\u{c}' | '\u{85}' | '\u{200e}' | '\u{200f}' | '\u{2028}' | '\u{2029}'
    )
}

fn is_ident_start(c: char) -> bool {
    c.is_ascii_alphabetic() || c == '_'
}

fn is_ident_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

#[derive(Clone, Copy)]
struct Cursor {
    i: usize,
    pos: Pos,
}

struct Parser {
    chars: Vec<char>,
    cur: Cursor,
    depth: u32,
}

impl Parser {
    fn new(text: &str) -> Self {
        Parser { chars: text.chars().collect(), cur: Cursor { i: 0, pos: Pos { line: 1, col: 1 } }, depth: 0 }
    }

    fn peek(&self) -> Option<char> {
        self.chars.get(self.cur.i).copied()
    }

    fn peek_at(&self, n: usize) -> Option<char> {
        self.chars.get(self.cur.i + n).copied()
    }

    fn pos(&self) -> Pos {
        self.cur.pos
    }

    fn bump(&mut self) -> Option<char> {
        let c = self.peek()?;
        self.cur.i += 1;
        if c == '\n' {
            self.cur.pos.line += 1;
            self.cur.pos.col = 1;
        } else {
            self.cur.pos.col += 1;
        }
        Some(c)
    }

    fn eat(&mut self, c: char) -> bool {
        if self.peek() == Some(c) {
            self.bump();
            true
        } else {
            false
        }
    }

    fn take_while(&mut self, f: impl Fn(char) -> bool) -> String {
        let mut s = String::new();
        while let Some(c) = self.peek().filter(|&c| f(c)) {
            s.push(c);
            self.bump();
        }
        s
    }

    /// "expected X, found `y`" (or "unexpected end of file, expected X") at the current position.
    fn unexpected(&self, expected: &str) -> SyntaxError {
        let message = match self.peek() {
            None => format!("unexpected end of file, expected {expected}"),
            found => format!("expected {expected}, found {}", describe(found)),
        };
        err(self.pos(), message)
    }

    /// Like [`Parser::unexpected`], inside a bracketed construct: at end of file, says where it opened.
    fn unexpected_in(&self, expected: &str, open: char, open_pos: Pos) -> SyntaxError {
        let mut e = self.unexpected(expected);
        if self.peek().is_none() {
            e.message.push_str(&format!(" (unclosed `{open}` at line {}, column {})", open_pos.line, open_pos.col));
        }
        e
    }

    fn skip_ws(&mut self) -> Result<(), SyntaxError> {
        loop {
            match (self.peek(), self.peek_at(1)) {
                (Some(c), _) if is_whitespace(c) => {
                    self.bump();
                }
                (Some('/'), Some('/')) => {
                    while let Some(c) = self.bump() {
                        if c == '\n' {
                            break;
                        }
                    }
                }
                (Some('/'), Some('*')) => self.skip_block_comment()?,
                _ => return Ok(()),
            }
        }
    }

    fn skip_block_comment(&mut self) -> Result<(), SyntaxError> {
        let start = self.pos();
        self.bump();
        self.bump();
        let mut depth = 1u32;
        while depth > 0 {
            match (self.peek(), self.peek_at(1)) {
                (None, _) => return Err(err(start, "unterminated block comment")),
                (Some('/'), Some('*')) => {
                    self.bump();
                    self.bump();
                    depth += 1;
                }
                (Some('*'), Some('/')) => {
                    self.bump();
                    self.bump();
                    depth -= 1;
                }
                _ => {
                    self.bump();
                }
            }
        }
        Ok(())
    }

    /// Skips `#![enable(...)]` attributes at the start of the file.
    fn skip_attributes(&mut self) -> Result<(), SyntaxError> {
        while self.peek() == Some('#') && self.peek_at(1) == Some('!') {
            let start = self.pos();
            self.bump();
            self.bump();
            if !self.eat('[') {
                return Err(self.unexpected("`[` after `#!`"));
            }
            loop {
                match self.bump() {
                    None => return Err(err(start, "unterminated attribute `#![...]`")),
                    Some(']') => break,
                    Some(_) => {}
                }
            }
            self.skip_ws()?;
        }
        Ok(())
    }

    fn value(&mut self) -> Result<Spanned<Ron>, SyntaxError> {
        if self.depth >= MAX_DEPTH {
            return Err(err(self.pos(), format!("values nested more than {MAX_DEPTH} deep")));
        }
        self.depth += 1;
        let pos = self.pos();
        let result = self.value_inner(pos);
        self.depth -= 1;
        Ok(Spanned { value: result?, pos })
    }

    fn value_inner(&mut self, pos: Pos) -> Result<Ron, SyntaxError> {
        match self.peek() {
            Some('"') => Ok(Ron::Str(self.string()?)),
            Some('\'') => Ok(Ron::Str(self.char_lit()?)),
            Some('r') if self.raw_string_ahead() => Ok(Ron::Str(self.raw_string()?)),
            Some('(') => self.paren_body(None),
            Some('[') => {
                let mut items = Vec::new();
                self.seq('[', ']', "list element", |p, _| {
                    items.push(p.value()?);
                    Ok(())
                })?;
                Ok(Ron::List(items))
            }
            Some('{') => {
                let mut entries = Vec::new();
                self.seq('{', '}', "map entry", |p, open| {
                    let key = p.value()?;
                    p.skip_ws()?;
                    if !p.eat(':') {
                        return Err(p.unexpected_in("`:` after map key", '{', open));
                    }
                    p.skip_ws()?;
                    entries.push((key, p.value()?));
                    Ok(())
                })?;
                Ok(Ron::Map(entries))
            }
            Some(c) if c.is_ascii_digit() || c == '+' || c == '-' => self.number(),
            Some('.') if self.peek_at(1).is_some_and(|c| c.is_ascii_digit()) => self.number(),
            Some(c) if is_ident_start(c) => {
                let raw = c == 'r' && self.peek_at(1) == Some('#'); // `r#true` is an identifier, not a bool
                let name = self.ident()?;
                match name.as_str() {
                    "true" if !raw => return Ok(Ron::Bool(true)),
                    "false" if !raw => return Ok(Ron::Bool(false)),
                    "inf" if !raw => return Ok(Ron::Float(f64::INFINITY)),
                    "NaN" if !raw => return Ok(Ron::Float(f64::NAN)),
                    _ => {}
                }
                let save = self.cur;
                self.skip_ws()?;
                if self.peek() == Some('(') {
                    self.paren_body(Some(Spanned { value: name, pos }))
                } else {
                    self.cur = save;
                    Ok(Ron::Ident(name))
                }
            }
            _ => Err(self.unexpected("a value")),
        }
    }

    /// Parses `open item, item, ... close` (trailing comma allowed); the
    /// closure parses one item and receives the position of `open`.
    fn seq(
        &mut self,
        open: char,
        close: char,
        what: &str,
        mut item: impl FnMut(&mut Self, Pos) -> Result<(), SyntaxError>,
    ) -> Result<(), SyntaxError> {
        let open_pos = self.pos();
        self.bump();
        loop {
            self.skip_ws()?;
            if self.eat(close) {
                return Ok(());
            }
            if self.peek().is_none() {
                return Err(self.unexpected_in(&format!("a {what} or `{close}`"), open, open_pos));
            }
            item(&mut *self, open_pos)?;
            self.skip_ws()?;
            if self.eat(',') {
                continue;
            }
            if self.eat(close) {
                return Ok(());
            }
            return Err(self.unexpected_in(&format!("`,` or `{close}` after {what}"), open, open_pos));
        }
    }

    /// At `(`: a struct if the body starts with `ident :` (or is empty after a name), else a tuple.
    fn paren_body(&mut self, name: Option<Spanned<String>>) -> Result<Ron, SyntaxError> {
        let save = self.cur;
        self.bump();
        self.skip_ws()?;
        let is_struct = (name.is_some() && self.peek() == Some(')')) || self.struct_field_ahead();
        self.cur = save;

        if is_struct {
            let mut fields = Vec::new();
            self.seq('(', ')', "struct field", |p, open| {
                if !p.peek().is_some_and(is_ident_start) {
                    return Err(p.unexpected_in("a field name or `)`", '(', open));
                }
                let fpos = p.pos();
                let fname = p.ident()?;
                p.skip_ws()?;
                if !p.eat(':') {
                    return Err(p.unexpected_in(&format!("`:` after field `{fname}`"), '(', open));
                }
                p.skip_ws()?;
                fields.push((Spanned { value: fname, pos: fpos }, p.value()?));
                Ok(())
            })?;
            Ok(Ron::Struct { name, fields })
        } else {
            let mut items = Vec::new();
            self.seq('(', ')', "tuple element", |p, _| {
                items.push(p.value()?);
                Ok(())
            })?;
            Ok(Ron::Tuple { name, items })
        }
    }

    /// Lookahead: identifier, then `:` but not `::`. Never moves the cursor.
    fn struct_field_ahead(&mut self) -> bool {
        let save = self.cur;
        let found = self.peek().is_some_and(is_ident_start)
            && self.ident().is_ok()
            && self.skip_ws().is_ok()
            && self.peek() == Some(':')
            && self.peek_at(1) != Some(':');
        self.cur = save;
        found
    }

    /// An identifier, or a raw identifier `r#name` (returned without `r#`).
    fn ident(&mut self) -> Result<String, SyntaxError> {
        if self.peek() == Some('r') && self.peek_at(1) == Some('#') && self.peek_at(2).is_some_and(is_ident_start) {
            self.bump();
            self.bump();
        }
        if !self.peek().is_some_and(is_ident_start) {
            return Err(self.unexpected("an identifier"));
        }
        Ok(self.take_while(is_ident_char))
    }

    fn raw_string_ahead(&self) -> bool {
        let mut n = 1;
        while self.peek_at(n) == Some('#') {
            n += 1;
        }
        self.peek_at(n) == Some('"')
    }

    fn string(&mut self) -> Result<String, SyntaxError> {
        let start = self.pos();
        self.bump();
        let mut s = String::new();
        loop {
            match self.peek() {
                None => return Err(err(start, "unterminated string")),
                Some('"') => {
                    self.bump();
                    return Ok(s);
                }
                Some('\\') => s.push(self.escape()?),
                Some(c) => {
                    self.bump();
                    s.push(c);
                }
            }
        }
    }

    fn raw_string(&mut self) -> Result<String, SyntaxError> {
        let start = self.pos();
        self.bump(); // `r`
        let mut hashes = 0;
        while self.eat('#') {
            hashes += 1;
        }
        self.bump(); // opening `"`, checked by raw_string_ahead
        let mut s = String::new();
        loop {
            match self.bump() {
                None => return Err(err(start, "unterminated raw string")),
                Some('"') if (0..hashes).all(|k| self.peek_at(k) == Some('#')) => {
                    for _ in 0..hashes {
                        self.bump();
                    }
                    return Ok(s);
                }
                Some(c) => s.push(c),
            }
        }
    }

    fn char_lit(&mut self) -> Result<String, SyntaxError> {
        let start = self.pos();
        self.bump();
        let c = match self.peek() {
            None | Some('\n') => return Err(err(start, "unterminated character literal")),
            Some('\'') => return Err(err(start, "empty character literal")),
            Some('\\') => self.escape()?,
            Some(c) => {
                self.bump();
                c
            }
        };
        if !self.eat('\'') {
            return Err(self.unexpected("`'` to close the character literal"));
        }
        Ok(c.to_string())
    }

    /// At a backslash inside a string or char literal.
    fn escape(&mut self) -> Result<char, SyntaxError> {
        let start = self.pos();
        self.bump();
        let Some(c) = self.bump() else {
            return Err(self.unexpected("an escape character"));
        };
        Ok(match c {
            '"' => '"',
            '\'' => '\'',
            '\\' => '\\',
            'n' => '\n',
            't' => '\t',
            'r' => '\r',
            '0' => '\0',
            'u' => {
                if !self.eat('{') {
                    return Err(self.unexpected("`{` after `\\u`"));
                }
                let digits = self.take_while(|c| c.is_ascii_hexdigit());
                if digits.is_empty() || digits.len() > 6 {
                    return Err(err(start, "unicode escape must have 1 to 6 hex digits"));
                }
                if !self.eat('}') {
                    return Err(self.unexpected("`}` to close the unicode escape"));
                }
                let code = u32::from_str_radix(&digits, 16).unwrap_or(u32::MAX);
                char::from_u32(code).ok_or_else(|| err(start, format!("invalid unicode escape `\\u{{{digits}}}`")))?
            }
            other => return Err(err(start, format!("unknown escape `\\{other}`"))),
        })
    }

    fn number(&mut self) -> Result<Ron, SyntaxError> {
        let start = self.cur;
        let negative = match self.peek() {
            Some('-') => {
                self.bump();
                true
            }
            Some('+') => {
                self.bump();
                false
            }
            _ => false,
        };
        let starts_number = match self.peek() {
            Some(c) if c.is_ascii_digit() => true,
            Some('.') => self.peek_at(1).is_some_and(|c| c.is_ascii_digit()),
            _ => false,
        };
        if !starts_number {
            // `-inf`, `+inf`, `-NaN`
            if self.peek().is_some_and(is_ident_start) {
                let save = self.cur;
                let v = match self.take_while(is_ident_char).as_str() {
                    "inf" => f64::INFINITY,
                    "NaN" => f64::NAN,
                    _ => {
                        self.cur = save;
                        return Err(self.unexpected("a number"));
                    }
                };
                return Ok(Ron::Float(if negative { -v } else { v }));
            }
            return Err(self.unexpected("a number"));
        }

        let radix = match (self.peek(), self.peek_at(1)) {
            (Some('0'), Some('x')) => 16,
            (Some('0'), Some('o')) => 8,
            (Some('0'), Some('b')) => 2,
            _ => 10,
        };
        let mut text = String::new();
        let mut is_float = false;
        if radix != 10 {
            self.bump();
            self.bump();
            if self.peek() == Some('_') {
                return Err(self.unexpected("a digit"));
            }
            text = self.take_while(|c| c.is_digit(radix) || c == '_');
            if !text.chars().any(|c| c != '_') {
                return Err(self.unexpected("a digit"));
            }
        } else {
            text.push_str(&self.take_while(|c| c.is_ascii_digit() || c == '_'));
            if self.peek() == Some('.') {
                self.bump();
                if self.peek() == Some('_') {
                    return Err(self.unexpected("a digit after `.`"));
                }
                is_float = true;
                text.push('.');
                text.push_str(&self.take_while(|c| c.is_ascii_digit() || c == '_'));
            }
            if matches!(self.peek(), Some('e' | 'E')) {
                self.bump();
                is_float = true;
                text.push('e');
                if let Some(sign @ ('+' | '-')) = self.peek() {
                    self.bump();
                    text.push(sign);
                }
                let exp = self.take_while(|c| c.is_ascii_digit() || c == '_');
                if !exp.chars().any(|c| c.is_ascii_digit()) {
                    return Err(self.unexpected("exponent digits"));
                }
                text.push_str(&exp);
            }
        }
        if let Some(c) = self.peek().filter(|&c| is_ident_char(c) || c == '.') {
            return Err(err(self.pos(), format!("unexpected character `{c}` in number")));
        }

        let literal: String = self.chars[start.i..self.cur.i].iter().collect();
        let cleaned: String = text.chars().filter(|&c| c != '_').collect();
        if is_float {
            let v: f64 = cleaned.parse().map_err(|_| err(start.pos, format!("invalid float literal `{literal}`")))?;
            return Ok(Ron::Float(if negative { -v } else { v }));
        }
        let overflow = || err(start.pos, format!("integer overflow: `{literal}` does not fit in i64"));
        let magnitude = u64::from_str_radix(&cleaned, radix).map_err(|_| overflow())?;
        let signed = if negative { -(magnitude as i128) } else { magnitude as i128 };
        i64::try_from(signed).map(Ron::Int).map_err(|_| overflow())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXAMPLE: &str = r#"// graphs/example.ron
(
    nodes: {
        "env":  LoadHdr(path: "builtin:sky"),
        "lum":  Luminance(image: "env"),
        "save": Save(input: "lum", path: "luminance.exr"),
    },
)
"#;

    fn p(line: u32, col: u32) -> Pos {
        Pos { line, col }
    }

    fn ok(text: &str) -> Spanned<Ron> {
        parse(text).unwrap_or_else(|e| panic!("parse failed: {e}"))
    }

    fn fail(text: &str) -> SyntaxError {
        parse(text).expect_err("expected a syntax error")
    }

    fn fields(v: &Ron) -> &[(Spanned<String>, Spanned<Ron>)] {
        match v {
            Ron::Struct { fields, .. } => fields,
            other => panic!("expected struct, got {other:?}"),
        }
    }

    fn name_of(v: &Ron) -> Option<&Spanned<String>> {
        match v {
            Ron::Struct { name, .. } | Ron::Tuple { name, .. } => name.as_ref(),
            _ => None,
        }
    }

    #[test]
    fn example_positions() {
        let root = ok(EXAMPLE);
        assert_eq!(root.pos, p(2, 1));
        let top = fields(&root.value);
        assert_eq!(top.len(), 1);
        assert_eq!(top[0].0.value, "nodes");
        assert_eq!(top[0].0.pos, p(3, 5));
        assert_eq!(top[0].1.pos, p(3, 12));
        let Ron::Map(nodes) = &top[0].1.value else { panic!("nodes is not a map") };
        assert_eq!(nodes.len(), 3);

        let (key, node) = &nodes[0];
        assert_eq!(key.value, Ron::Str("env".into()));
        assert_eq!(key.pos, p(4, 9));
        assert_eq!(node.pos, p(4, 17));
        assert_eq!(name_of(&node.value).unwrap(), &Spanned { value: "LoadHdr".to_string(), pos: p(4, 17) });
        let f = fields(&node.value);
        assert_eq!(f[0].0, Spanned { value: "path".to_string(), pos: p(4, 25) });
        assert_eq!(f[0].1, Spanned { value: Ron::Str("builtin:sky".into()), pos: p(4, 31) });

        let (key, node) = &nodes[1];
        assert_eq!(key.pos, p(5, 9));
        assert_eq!(name_of(&node.value).unwrap().value, "Luminance");
        let f = fields(&node.value);
        assert_eq!(f[0].0.pos, p(5, 27));
        assert_eq!(f[0].1, Spanned { value: Ron::Str("env".into()), pos: p(5, 34) });

        let (key, node) = &nodes[2];
        assert_eq!(key, &Spanned { value: Ron::Str("save".into()), pos: p(6, 9) });
        let f = fields(&node.value);
        assert_eq!(f[0].0, Spanned { value: "input".to_string(), pos: p(6, 22) });
        assert_eq!(f[1].0, Spanned { value: "path".to_string(), pos: p(6, 36) });
        assert_eq!(f[1].1.pos, p(6, 42));
    }

    #[test]
    fn comments_and_attributes() {
        let v = ok("#![enable(implicit_some)]\n/* a /* nested */ comment */ // line\n(a: /* x */ 1, // c\n)");
        let f = fields(&v.value);
        assert_eq!(f[0].1, Spanned { value: Ron::Int(1), pos: p(3, 13) });
    }

    #[test]
    fn nested_structs_tuples_and_idents() {
        let v = ok("Outer(inner: Inner(x: 1, y: (0.0, 1.0, 0.0)), list: [A, B(c: 1), Some(\"s\")], space: Rec709, u: (), e: Empty(),)");
        let f = fields(&v.value);
        let inner = fields(&f[0].1.value);
        assert_eq!(
            inner[1].1.value,
            Ron::Tuple {
                name: None,
                items: vec![
                    Spanned { value: Ron::Float(0.0), pos: p(1, 30) },
                    Spanned { value: Ron::Float(1.0), pos: p(1, 35) },
                    Spanned { value: Ron::Float(0.0), pos: p(1, 40) },
                ],
            }
        );
        let Ron::List(list) = &f[1].1.value else { panic!() };
        assert_eq!(list[0].value, Ron::Ident("A".into()));
        assert_eq!(list[1].value.kind_name(), "struct");
        assert_eq!(list[2].value.kind_name(), "tuple");
        assert_eq!(name_of(&list[2].value).unwrap().value, "Some");
        assert_eq!(f[2].1.value, Ron::Ident("Rec709".into()));
        assert_eq!(f[3].1.value, Ron::Tuple { name: None, items: vec![] });
        assert_eq!(fields(&f[4].1.value).len(), 0);
        assert_eq!(name_of(&f[4].1.value).unwrap().value, "Empty");
    }

    #[test]
    fn numbers() {
        let v = ok(
            "[-2, +3, 1.5, -1.5e-3, 1e10, 1., .5, 0xff, 0b1010, 0o17, 1_000, -inf, inf, -9223372036854775808, true]",
        );
        let Ron::List(items) = v.value else { panic!() };
        let got: Vec<Ron> = items.into_iter().map(|s| s.value).collect();
        assert_eq!(
            got,
            vec![
                Ron::Int(-2),
                Ron::Int(3),
                Ron::Float(1.5),
                Ron::Float(-1.5e-3),
                Ron::Float(1e10),
                Ron::Float(1.0),
                Ron::Float(0.5),
                Ron::Int(255),
                Ron::Int(10),
                Ron::Int(15),
                Ron::Int(1000),
                Ron::Float(f64::NEG_INFINITY),
                Ron::Float(f64::INFINITY),
                Ron::Int(i64::MIN),
                Ron::Bool(true),
            ]
        );
        assert!(matches!(ok("NaN").value, Ron::Float(x) if x.is_nan()));
        let e = fail("[1, 9223372036854775808]");
        assert_eq!(e.pos, p(1, 5));
        assert!(e.message.contains("integer overflow"), "{}", e.message);
        assert_eq!(fail("12ab").pos, p(1, 3));
        assert_eq!(fail("1e").pos, p(1, 3));
    }

    #[test]
    fn strings() {
        assert_eq!(ok(r##"r#"a "quoted" \n"#"##).value, Ron::Str(r#"a "quoted" \n"#.into()));
        assert_eq!(ok(r#"r"x""#).value, Ron::Str("x".into()));
        assert_eq!(ok(r#""a\"b\\c\n\u{e9}""#).value, Ron::Str("a\"b\\c\n\u{e9}".into()));
        assert_eq!(
            ok("['c', '\\n']").value,
            Ron::List(vec![
                Spanned { value: Ron::Str("c".into()), pos: p(1, 2) },
                Spanned { value: Ron::Str("\n".into()), pos: p(1, 7) },
            ])
        );
        let v = ok("(r#type: 1)");
        assert_eq!(fields(&v.value)[0].0.value, "type");
        assert_eq!(fail(r#""bad \q""#).pos, p(1, 6));
    }

    #[test]
    fn multibyte_columns() {
        assert_eq!(ok("/* é€😀 */ 42").pos, p(1, 11));
        let Ron::List(items) = ok("[\"héllo\", x]").value else { panic!() };
        assert_eq!(items[1].pos, p(1, 11));
    }

    #[test]
    fn error_missing_comma() {
        let e = fail("(\n    a: 1\n    b: 2,\n)");
        assert_eq!(e.pos, p(3, 5));
        assert_eq!(e.message, "expected `,` or `)` after struct field, found `b`");
        let e = fail("[1 2]");
        assert_eq!(e.pos, p(1, 4));
    }

    #[test]
    fn error_unterminated() {
        let e = fail("(\n  name: \"abc\n)");
        assert_eq!(e.pos, p(2, 9));
        assert_eq!(e.message, "unterminated string");
        assert_eq!(fail("1 /* a /* b */").pos, p(1, 3));
        assert_eq!(fail("  r#\"abc\"").pos, p(1, 3));
    }

    #[test]
    fn error_unexpected_char_and_trailing() {
        let e = fail("[1, @]");
        assert_eq!(e.pos, p(1, 5));
        assert_eq!(e.message, "expected a value, found `@`");
        let e = fail("(a: 1) x");
        assert_eq!(e.pos, p(1, 8));
        assert_eq!(e.message, "expected end of file after the value, found `x`");
        let e = fail("(a 1)");
        assert_eq!(e.pos, p(1, 4));
        let e = fail("(a: 1, 2)");
        assert_eq!(e.message, "expected a field name or `)`, found `2`");
    }

    /// Found by `tests/ron_oracle.rs`: texts we read differently from the `ron` crate.
    #[test]
    fn agrees_with_ron() {
        // Raw identifiers are never keywords.
        assert_eq!(
            ok("[r#true, r#false, r#inf, r#NaN]").value,
            Ron::List(vec![
                Spanned { value: Ron::Ident("true".into()), pos: p(1, 2) },
                Spanned { value: Ron::Ident("false".into()), pos: p(1, 10) },
                Spanned { value: Ron::Ident("inf".into()), pos: p(1, 19) },
                Spanned { value: Ron::Ident("NaN".into()), pos: p(1, 26) },
            ])
        );
        assert_eq!(name_of(&ok("r#true(1)").value).unwrap().value, "true");
        // `\/`, `\b` and `\f` are JSON escapes, not RON ones: "C:\folder" is an error, not a form feed.
        let e = fail(r#""C:\folder""#);
        assert_eq!((e.pos, e.message.as_str()), (p(1, 4), "unknown escape `\\f`"));
        assert_eq!(fail(r#""\/""#).message, "unknown escape `\\/`");
        assert_eq!(fail(r#"'\b'"#).message, "unknown escape `\\b`");
        // RON's whitespace: U+200E and U+200F are whitespace, a no-break space (shown escaped) is not.
        assert_eq!(ok("[1,\u{200e}2,\u{200f}3]").value.kind_name(), "list");
        let e = fail("[1,\u{a0}2]");
        assert_eq!((e.pos, e.message.as_str()), (p(1, 4), "expected a value, found `\\u{a0}`"));
        assert!(fail("(a:\u{3000}1)").message.contains("found `\\u{3000}`"));
        // No `_` right after a radix prefix or a decimal point (`_` elsewhere is fine).
        assert_eq!(fail("0x_1").message, "expected a digit, found `_`");
        assert_eq!(fail("-0b_1").pos, p(1, 4));
        let e = fail("1._5");
        assert_eq!((e.pos, e.message.as_str()), (p(1, 3), "expected a digit after `.`, found `_`"));
        assert_eq!(ok("[0x1_, 1_.5, 1.5_, 1e_5]").value.kind_name(), "list");
    }

    #[test]
    fn error_eof() {
        let e = fail("{ \"a\": 1,\n");
        assert_eq!(e.pos, p(2, 1));
        assert!(e.message.starts_with("unexpected end of file"), "{}", e.message);
        assert!(e.message.contains("unclosed `{` at line 1, column 1"), "{}", e.message);
        let e = fail("");
        assert_eq!(e.message, "unexpected end of file, expected a value");
        assert!(fail(&"[".repeat(10_000)).message.contains("nested"));
    }
}
