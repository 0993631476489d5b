//! The parser's state and its character-level steps: the cursor with its position, peeking and
//! advancing, whitespace, comments and `#![...]` attributes, and the error helpers. The grammar
//! (`grammar.rs`) and the literals (`literals.rs`) are further `impl Parser` blocks on this state.

use super::{Pos, SyntaxError};

pub(super) fn err(pos: Pos, message: impl Into<String>) -> SyntaxError {
    SyntaxError { pos, message: message.into() }
}

pub(super) fn describe(c: Option<char>) -> String {
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
pub(super) fn is_whitespace(c: char) -> bool {
    matches!(
        c,
        ' ' | '\t' | '\n' | '\r' | '\u{b}' | '\u{c}' | '\u{85}' | '\u{200e}' | '\u{200f}' | '\u{2028}' | '\u{2029}'
    )
}

pub(super) fn is_ident_start(c: char) -> bool {
    c.is_ascii_alphabetic() || c == '_'
}

pub(super) fn is_ident_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

#[derive(Clone, Copy)]
pub(super) struct Cursor {
    pub(super) i: usize,
    pub(super) pos: Pos,
}

pub(super) struct Parser {
    pub(super) chars: Vec<char>,
    pub(super) cur: Cursor,
    pub(super) depth: u32,
}

impl Parser {
    pub(super) fn new(text: &str) -> Self {
        Parser { chars: text.chars().collect(), cur: Cursor { i: 0, pos: Pos { line: 1, col: 1 } }, depth: 0 }
    }

    pub(super) fn peek(&self) -> Option<char> {
        self.chars.get(self.cur.i).copied()
    }

    pub(super) fn peek_at(&self, n: usize) -> Option<char> {
        self.chars.get(self.cur.i + n).copied()
    }

    pub(super) fn pos(&self) -> Pos {
        self.cur.pos
    }

    pub(super) fn bump(&mut self) -> Option<char> {
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

    pub(super) fn eat(&mut self, c: char) -> bool {
        if self.peek() == Some(c) {
            self.bump();
            true
        } else {
            false
        }
    }

    pub(super) fn take_while(&mut self, f: impl Fn(char) -> bool) -> String {
        let mut s = String::new();
        while let Some(c) = self.peek().filter(|&c| f(c)) {
            s.push(c);
            self.bump();
        }
        s
    }

    /// "expected X, found `y`" (or "unexpected end of file, expected X") at the current position.
    pub(super) fn unexpected(&self, expected: &str) -> SyntaxError {
        let message = match self.peek() {
            None => format!("unexpected end of file, expected {expected}"),
            found => format!("expected {expected}, found {}", describe(found)),
        };
        err(self.pos(), message)
    }

    /// Like [`Parser::unexpected`], inside a bracketed construct: at end of file, says where it opened.
    pub(super) fn unexpected_in(&self, expected: &str, open: char, open_pos: Pos) -> SyntaxError {
        let mut e = self.unexpected(expected);
        if self.peek().is_none() {
            e.message.push_str(&format!(" (unclosed `{open}` at line {}, column {})", open_pos.line, open_pos.col));
        }
        e
    }

    pub(super) fn skip_ws(&mut self) -> Result<(), SyntaxError> {
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

    pub(super) fn skip_block_comment(&mut self) -> Result<(), SyntaxError> {
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
    pub(super) fn skip_attributes(&mut self) -> Result<(), SyntaxError> {
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
}
