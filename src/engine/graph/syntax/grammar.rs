//! The recursive-descent grammar of the RON subset: a value, sequences, the parenthesised forms
//! (tuple, struct, named) and identifiers, nesting limited to [`MAX_DEPTH`].

use super::cursor::{err, is_ident_char, is_ident_start, Parser};
use super::{Pos, Ron, Spanned, SyntaxError};

/// Guards against stack overflow on pathological input such as `[[[[...`.
const MAX_DEPTH: u32 = 128;

impl Parser {
    pub(super) fn value(&mut self) -> Result<Spanned<Ron>, SyntaxError> {
        if self.depth >= MAX_DEPTH {
            return Err(err(self.pos(), format!("values nested more than {MAX_DEPTH} deep")));
        }
        self.depth += 1;
        let pos = self.pos();
        let result = self.value_inner(pos);
        self.depth -= 1;
        Ok(Spanned { value: result?, pos })
    }

    pub(super) fn value_inner(&mut self, pos: Pos) -> Result<Ron, SyntaxError> {
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
    pub(super) fn seq(
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
    pub(super) fn paren_body(&mut self, name: Option<Spanned<String>>) -> Result<Ron, SyntaxError> {
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
    pub(super) fn struct_field_ahead(&mut self) -> bool {
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
    pub(super) fn ident(&mut self) -> Result<String, SyntaxError> {
        if self.peek() == Some('r') && self.peek_at(1) == Some('#') && self.peek_at(2).is_some_and(is_ident_start) {
            self.bump();
            self.bump();
        }
        if !self.peek().is_some_and(is_ident_start) {
            return Err(self.unexpected("an identifier"));
        }
        Ok(self.take_while(is_ident_char))
    }
}
