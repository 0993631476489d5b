//! The literals of the RON subset: strings (with escapes), raw strings, chars and numbers
//! (integers in four bases, floats, `inf` and `NaN`).

use super::cursor::{err, is_ident_char, is_ident_start, Parser};
use super::{Ron, SyntaxError};

impl Parser {
    pub(super) fn raw_string_ahead(&self) -> bool {
        let mut n = 1;
        while self.peek_at(n) == Some('#') {
            n += 1;
        }
        self.peek_at(n) == Some('"')
    }

    pub(super) fn string(&mut self) -> Result<String, SyntaxError> {
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

    pub(super) fn raw_string(&mut self) -> Result<String, SyntaxError> {
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

    pub(super) fn char_lit(&mut self) -> Result<String, SyntaxError> {
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
    pub(super) fn escape(&mut self) -> Result<char, SyntaxError> {
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

    pub(super) fn number(&mut self) -> Result<Ron, SyntaxError> {
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
