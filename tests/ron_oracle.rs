//! The `ron` crate (0.12) as the oracle for our position-tracking parser,
//! `hdrflow::engine::graph::syntax` (issue 9).
//!
//! Every text is given to both parsers ([`verdict`]):
//!
//! - both accept: our tree, normalised ([`ours_n`]), must equal `ron::from_str::<ron::Value>`,
//!   normalised ([`ron_n`]). Because `ron::Value` forgets a lot (names, tuple or list, struct or
//!   map, field order and duplicates), two more checks follow. [`guided`] drives ron's *typed*
//!   deserialiser with our tree: an enum variant named `LoadHdr` with struct fields where we
//!   found `LoadHdr(..)`, `deserialize_tuple` where we found an unnamed tuple, a unit variant
//!   `Rec709` for an identifier, and so on. So ron checks every name, field name, field order
//!   and kind, duplicates included. [`check_positions`] asks ron to read one value starting at
//!   each position we recorded: it must read that node's value, and names must start where we
//!   say.
//! - exactly one accepts: the difference must be one of the deliberate ones in [`Known`], each
//!   recognised by a precise test, not by "ron said no".
//! - both reject: fine (error messages and positions are ours to choose).
//!
//! Normalisation (what `ron::Value` 0.12.3 makes of RON, read from its `deserialize_any`):
//!
//! | text | ron::Value | our tree | normalised |
//! |---|---|---|---|
//! | `Name(f: 1)`, `(f: 1)` | `Map {"f": 1}`, name dropped | `Struct` | `Map` with string keys |
//! | `Name()`, `Name( )` | `Seq []` | `Struct` with no fields | `Seq []` |
//! | `Name(a, b)`, `(a, b)`, `[a, b]` | `Seq` | `Tuple` / `List` | `Seq` |
//! | `()` exactly | `Unit` | empty `Tuple` | `Unit` |
//! | `( )`, `(/**/)` | `Seq []` (ron looks for the two characters `()`) | empty `Tuple` | `Seq []` |
//! | `Rec709`, `r#None` | `Unit`, name dropped | `Ident` | `Unit` |
//! | `None`, `Some(x)` | `Option` | `Ident`, one-element `Tuple` | `Option` |
//! | `'c'` | `Char` | `Str` | `Str` |
//! | `1`, `-1`, `0xff` | `Number::U8/I8/..`, smallest fitting type | `Int(i64)` | `Int(i128)` |
//! | `1.5`, `1e3`, `inf` | `F32` if exact as f32, else `F64` (so f32 -> f64 is exact) | `Float(f64)` | f64 bits, every NaN alike |
//! | `{k: 1, k: 2}`, `(f: 1, f: 2)` | a map: the last duplicate wins | every entry, in order | sorted, last duplicate wins |
//!
//! Generated texts ([`document`]): arbitrary values and pipeline-shaped texts
//! (`( nodes: { "a": Op(field: ...), ... } )`) in the subset both parsers share, with random
//! whitespace (RON's exotic kinds too), nested and line comments, trailing commas, attributes,
//! all four integer radixes with signs and `_`, floats in every form, strings with every escape,
//! raw strings, chars, raw identifiers, duplicate keys and fields. Near misses ([`mutate`]) delete,
//! insert, replace, duplicate or swap characters of those texts, and every one-character
//! deletion and insertion of `graphs/example.ron` (and deletions in `graphs/seed.ron`) is tried.
//! ron's own output (`ron::to_string`, `to_string_pretty` with many settings) must read the
//! same. The files in `graphs/` and `tests/bad/` and the minimised fuzz corpus
//! `fuzz/regressions/pipeline/` are compared too.
//!
//! Map keys are generated without `NaN`, `-0` and chars: ron keys its maps by typed value
//! (`-0` is `I8(0)`, `0` is `U8(0)`; `'a'` is not `"a"`; `NaN` and `-NaN` differ), which the
//! normalised form (one integer type, chars as strings, one NaN) cannot follow.
//!
//! `HDRFLOW_ORACLE_CASES=N` runs N cases per property instead of the CI counts.

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use hdrflow::engine::graph::syntax::{self, Pos, Ron, Spanned, SyntaxError};
use proptest::prelude::*;
use proptest::test_runner::TestRunner;
use ron::ser::PrettyConfig;
use ron::{Number, Value};
use serde::de::{
    self, DeserializeSeed, Deserializer, EnumAccess, IgnoredAny, MapAccess, SeqAccess, VariantAccess, Visitor,
};

// -------------------------------------------------------------------------------------------------
// Deliberate differences
// -------------------------------------------------------------------------------------------------

/// Why the two parsers may legitimately disagree on a text. Each variant is recognised by a
/// specific test in [`verdict`], [`ours_only`] or [`ron_only`]; anything else fails.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Known {
    /// We accept, `ron::Value` cannot hold it, yet it is RON: ron's typed deserialiser reads our
    /// tree (checked with [`guided`]). `Some` with 0 or 2+ elements or with fields, a bare
    /// `Some`, `None(..)`: `deserialize_any` reads `Some`/`None` as an `Option`, while an enum
    /// with such variants deserialises fine.
    ValueCannotHold,
    /// A leading U+FEFF byte-order mark: we skip it (editors on Windows write one), ron reads it
    /// as an unexpected character. The text without it must give the same verdict.
    ByteOrderMark,
    /// `#![...]` attributes. We skip them unread up to the first `]`: they do not change the
    /// subset. ron checks them (`enable(..)` with known extensions, `type = ".."`,
    /// `schema = ".."`), allows spaces in `# ! [`, and its extensions change how it reads (e.g.
    /// `unwrap_variant_newtypes`). The text with the attributes blanked out must agree.
    Attribute,
    /// Ranges `1..2`, `..=3`, `..` (RON 0.12 syntax): outside the subset.
    Range,
    /// Type suffixes `1u8`, `2.5f32`, `inff64`: outside the subset (and `inff32` alone is an
    /// identifier to us, a float to ron).
    NumberSuffix,
    /// Byte literals `b'a'` and byte strings `b"..."`, `br"..."`: outside the subset.
    Bytes,
    /// Integers outside i64: ron reads them as u64 or, past u64, as floats. We report an
    /// overflow: pipeline integers are i64.
    IntegerRange,
    /// Non-ASCII identifiers (`Größe`) and raw identifiers that only `r#` makes legal
    /// (`r#a.b`, `r#1`): the subset's identifiers are ASCII `[A-Za-z_][A-Za-z0-9_]*`.
    Identifier,
    /// `\x41` escapes and `\`-newline string continuations: outside the subset.
    Escape,
    /// `'''` and a line break between quotes: ron reads any one character between `'`s, we
    /// report an empty or unterminated character literal.
    CharLiteral,
    /// `1e_-5`: ron drops every `_` that follows a digit or the `e` before parsing a float, so
    /// it also reads a `_` before the exponent's sign; we follow Rust, where digits (and `_`)
    /// come after the sign.
    ExponentUnderscore,
    /// A map with two keys that are one key to us: `0` and `-0` (to ron an unsigned and a signed
    /// zero), or `'a'` and `"a"` (a char and a string). We keep the last, as for any duplicate
    /// key; ron keeps both. Generated texts avoid such keys; near misses reach them (a deleted
    /// digit turns `-0x8` into `-0x`...`0`).
    KeysRonKeepsApart,
    /// Nesting limits: we read 127 nested values; ron's default recursion limit (128) counts two
    /// per list, tuple, struct or map (64 of those nested) and one per `Some(..)` (128).
    Depth,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Verdict {
    /// Both accept, and read the same.
    Agree,
    /// Both reject.
    BothReject,
    /// One accepts, for a documented reason.
    Known(Known),
}

// -------------------------------------------------------------------------------------------------
// Positions back to byte offsets
// -------------------------------------------------------------------------------------------------

/// The text, with our parser's [`Pos`] (1-based line, column in characters; a leading byte-order
/// mark is not counted) mapped back to byte offsets.
struct Source<'a> {
    text: &'a str,
    line_starts: Vec<usize>,
}

impl<'a> Source<'a> {
    fn new(text: &'a str) -> Self {
        let first = if text.starts_with('\u{feff}') { '\u{feff}'.len_utf8() } else { 0 };
        let mut line_starts = vec![first];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        Source { text, line_starts }
    }

    fn offset(&self, pos: Pos) -> usize {
        let start = self.line_starts[pos.line as usize - 1];
        self.text[start..].char_indices().nth(pos.col as usize - 1).map_or(self.text.len(), |(i, _)| start + i)
    }

    fn at(&self, pos: Pos) -> &'a str {
        &self.text[self.offset(pos)..]
    }
}

// -------------------------------------------------------------------------------------------------
// The common normalised form
// -------------------------------------------------------------------------------------------------

/// What both trees become (see the table in the module documentation).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum N {
    Unit,
    Bool(bool),
    Int(i128),
    /// f64 bits; every NaN is the same NaN.
    Float(u64),
    Str(String),
    Seq(Vec<N>),
    /// Sorted by key.
    Map(Vec<(N, N)>),
    Opt(Option<Box<N>>),
}

fn float(x: f64) -> N {
    N::Float(if x.is_nan() { f64::NAN.to_bits() } else { x.to_bits() })
}

/// `Some` or `None` written as such: `r#Some` is an ordinary identifier to ron.
fn keyword<'n>(name: &'n str, pos: Pos, src: &Source) -> Option<&'n str> {
    (matches!(name, "Some" | "None") && !src.at(pos).starts_with("r#")).then_some(name)
}

/// Like ron's map: the last of duplicate keys wins.
fn last_wins(entries: impl Iterator<Item = Result<(N, N), String>>) -> Result<N, String> {
    let mut map = BTreeMap::new();
    for entry in entries {
        let (k, v) = entry?;
        map.insert(k, v);
    }
    Ok(N::Map(map.into_iter().collect()))
}

/// Our tree, normalised; `Err` says why `ron::Value` has no counterpart ([`Known::ValueCannotHold`]).
fn ours_n(v: &Spanned<Ron>, src: &Source) -> Result<N, String> {
    let seq = |items: &[Spanned<Ron>]| items.iter().map(|i| ours_n(i, src)).collect::<Result<Vec<_>, _>>();
    Ok(match &v.value {
        Ron::Str(s) => N::Str(s.clone()),
        Ron::Int(i) => N::Int(i128::from(*i)),
        Ron::Float(x) => float(*x),
        Ron::Bool(b) => N::Bool(*b),
        Ron::Ident(name) => match keyword(name, v.pos, src) {
            Some("None") => N::Opt(None),
            Some(_) => return Err("a bare `Some`".into()),
            None => N::Unit,
        },
        Ron::Tuple { name, items } => {
            let mut items = seq(items)?;
            match name.as_ref().and_then(|n| keyword(&n.value, n.pos, src)) {
                Some("Some") if items.len() == 1 => N::Opt(items.pop().map(Box::new)),
                Some(k) => return Err(format!("`{k}(..)` with {} elements", items.len())),
                None if name.is_none() && items.is_empty() && src.at(v.pos).starts_with("()") => N::Unit,
                None => N::Seq(items),
            }
        }
        Ron::Struct { name, fields } => {
            if let Some(k) = name.as_ref().and_then(|n| keyword(&n.value, n.pos, src)) {
                return Err(format!("`{k}(field: ..)`"));
            }
            if fields.is_empty() {
                N::Seq(vec![])
            } else {
                last_wins(fields.iter().map(|(k, v)| Ok((N::Str(k.value.clone()), ours_n(v, src)?))))?
            }
        }
        Ron::List(items) => N::Seq(seq(items)?),
        Ron::Map(entries) => last_wins(entries.iter().map(|(k, v)| Ok((ours_n(k, src)?, ours_n(v, src)?))))?,
    })
}

/// A `ron::Value`, normalised; `Err` for what our subset has no counterpart for (bytes).
fn ron_n(v: &Value) -> Result<N, String> {
    Ok(match v {
        Value::Bool(b) => N::Bool(*b),
        Value::Char(c) => N::Str(c.to_string()),
        Value::Map(m) => {
            // Sorted, not deduplicated: keys that ron keeps apart but the normalised form
            // merges show up as a difference.
            let mut entries = m.iter().map(|(k, v)| Ok((ron_n(k)?, ron_n(v)?))).collect::<Result<Vec<_>, String>>()?;
            entries.sort_by(|a, b| a.0.cmp(&b.0));
            N::Map(entries)
        }
        Value::Number(n) => match *n {
            Number::I8(x) => N::Int(x.into()),
            Number::I16(x) => N::Int(x.into()),
            Number::I32(x) => N::Int(x.into()),
            Number::I64(x) => N::Int(x.into()),
            Number::U8(x) => N::Int(x.into()),
            Number::U16(x) => N::Int(x.into()),
            Number::U32(x) => N::Int(x.into()),
            Number::U64(x) => N::Int(x.into()),
            Number::F32(x) => float(f64::from(x.get())),
            Number::F64(x) => float(x.get()),
            _ => return Err(format!("the number {n:?}")),
        },
        Value::Option(o) => N::Opt(match o {
            Some(x) => Some(Box::new(ron_n(x)?)),
            None => None,
        }),
        Value::String(s) => N::Str(s.clone()),
        Value::Bytes(b) => return Err(format!("the bytes {b:?}")),
        Value::Seq(items) => N::Seq(items.iter().map(ron_n).collect::<Result<_, _>>()?),
        Value::Unit => N::Unit,
    })
}

// -------------------------------------------------------------------------------------------------
// ron's typed deserialiser, guided by our tree
// -------------------------------------------------------------------------------------------------

/// ron reads `text` as the types our tree says, names included: `Ok` if ron agrees on every name,
/// field name, field order, kind (struct, tuple, list, map, unit) and leaf value.
fn guided(text: &str, root: &Spanned<Ron>) -> Result<(), String> {
    ron::Options::default().from_str_seed(text, Guide(&root.value)).map_err(|e| e.to_string())
}

fn mismatch<E: de::Error>(found: impl fmt::Debug, ours: impl fmt::Debug) -> E {
    E::custom(format!("ron found {found:?} where we found {ours:?}"))
}

struct Guide<'a>(&'a Ron);

impl<'de> DeserializeSeed<'de> for Guide<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        match self.0 {
            // Named forms are read as enum variants, as serde types them in a pipeline, where
            // ron requires the name. (ron's `deserialize_tuple_struct` would also do, but it
            // refuses whitespace between the name and `(`, unlike the rest of ron.)
            Ron::Struct { name: Some(_), .. } | Ron::Tuple { name: Some(_), .. } | Ron::Ident(_) => {
                d.deserialize_enum("", &[], Variant(self.0))
            }
            Ron::Struct { name: None, fields } => d.deserialize_struct("", &[], Fields(fields)),
            Ron::Tuple { name: None, items } => d.deserialize_tuple(items.len(), Items(items)),
            Ron::List(items) => d.deserialize_seq(Items(items)),
            Ron::Map(entries) => d.deserialize_map(Entries(entries)),
            leaf => d.deserialize_any(Leaf(leaf)),
        }
    }
}

struct Fields<'a>(&'a [(Spanned<String>, Spanned<Ron>)]);

impl<'de> Visitor<'de> for Fields<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "fields {:?}", self.0.iter().map(|(k, _)| &k.value).collect::<Vec<_>>())
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        for (name, value) in self.0 {
            if map.next_key_seed(Name(&name.value))?.is_none() {
                return Err(mismatch("no more fields", &name.value));
            }
            map.next_value_seed(Guide(&value.value))?;
        }
        match map.next_key::<IgnoredAny>()? {
            None => Ok(()),
            Some(_) => Err(mismatch("another field", "none")),
        }
    }
}

/// A field or variant name.
struct Name<'a>(&'a str);

impl<'de> DeserializeSeed<'de> for Name<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_identifier(self)
    }
}

impl<'de> Visitor<'de> for Name<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "the name {:?}", self.0)
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<(), E> {
        if v == self.0 {
            Ok(())
        } else {
            Err(mismatch(v, self.0))
        }
    }
}

struct Items<'a>(&'a [Spanned<Ron>]);

impl<'de> Visitor<'de> for Items<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "{} elements", self.0.len())
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        for item in self.0 {
            if seq.next_element_seed(Guide(&item.value))?.is_none() {
                return Err(mismatch("no more elements", &item.value));
            }
        }
        match seq.next_element::<IgnoredAny>()? {
            None => Ok(()),
            Some(_) => Err(mismatch("another element", "none")),
        }
    }
}

struct Entries<'a>(&'a [(Spanned<Ron>, Spanned<Ron>)]);

impl<'de> Visitor<'de> for Entries<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        // Not "struct ...": ron would then read the map as a flattened struct.
        write!(f, "a map of {} entries", self.0.len())
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        for (key, value) in self.0 {
            if map.next_key_seed(Guide(&key.value))?.is_none() {
                return Err(mismatch("no more entries", &key.value));
            }
            map.next_value_seed(Guide(&value.value))?;
        }
        match map.next_key::<IgnoredAny>()? {
            None => Ok(()),
            Some(_) => Err(mismatch("another entry", "none")),
        }
    }
}

/// `Name(field: ..)`, `Name(a, b)` or `Name`, as an enum variant.
struct Variant<'a>(&'a Ron);

impl<'de> Visitor<'de> for Variant<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "the variant {:?}", self.0)
    }

    fn visit_enum<A: EnumAccess<'de>>(self, data: A) -> Result<(), A::Error> {
        match self.0 {
            Ron::Struct { name: Some(name), fields } => {
                let ((), variant) = data.variant_seed(Name(&name.value))?;
                variant.struct_variant(&[], Fields(fields))
            }
            Ron::Tuple { name: Some(name), items } => {
                let ((), variant) = data.variant_seed(Name(&name.value))?;
                variant.tuple_variant(items.len(), Items(items))
            }
            Ron::Ident(name) => {
                let ((), variant) = data.variant_seed(Name(name))?;
                variant.unit_variant()
            }
            other => Err(mismatch("a variant", other)),
        }
    }
}

/// A string, number or bool. serde forwards chars to `visit_str`, the small integer types to
/// `visit_i64`/`visit_u64` and f32 to `visit_f64` (exactly).
struct Leaf<'a>(&'a Ron);

impl<'de> Visitor<'de> for Leaf<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "{:?}", self.0)
    }

    fn visit_bool<E: de::Error>(self, v: bool) -> Result<(), E> {
        match self.0 {
            Ron::Bool(b) if *b == v => Ok(()),
            ours => Err(mismatch(v, ours)),
        }
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<(), E> {
        match self.0 {
            Ron::Int(i) if *i == v => Ok(()),
            ours => Err(mismatch(v, ours)),
        }
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<(), E> {
        match self.0 {
            Ron::Int(i) if i128::from(*i) == i128::from(v) => Ok(()),
            ours => Err(mismatch(v, ours)),
        }
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<(), E> {
        match self.0 {
            Ron::Float(x) if float(*x) == float(v) => Ok(()),
            ours => Err(mismatch(v, ours)),
        }
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<(), E> {
        match self.0 {
            Ron::Str(s) if s == v => Ok(()),
            ours => Err(mismatch(v, ours)),
        }
    }
}

// -------------------------------------------------------------------------------------------------
// Positions
// -------------------------------------------------------------------------------------------------

/// Every recorded position is where that value (or name) starts: ron, reading one value from
/// there, reads the node's value; names and field names are spelled there (`r#` allowed).
fn check_positions(v: &Spanned<Ron>, src: &Source, problems: &mut Vec<String>) {
    if let Ok(ours) = ours_n(v, src) {
        let theirs = ron::Deserializer::from_str(src.at(v.pos))
            .map_err(|e| e.to_string())
            .and_then(|mut de| serde::Deserialize::deserialize(&mut de).map_err(|e| de.span_error(e).to_string()))
            .and_then(|value: Value| ron_n(&value));
        if theirs.as_ref() != Ok(&ours) {
            problems.push(format!("at {}: ron reads {theirs:?}, we read {ours:?}", v.pos));
        }
    }
    match &v.value {
        Ron::Ident(name) => check_name(name, v.pos, src, problems),
        Ron::Tuple { name, .. } | Ron::Struct { name, .. } => {
            if let Some(n) = name {
                check_name(&n.value, n.pos, src, problems);
                if n.pos != v.pos {
                    problems.push(format!("the name `{}` is at {}, its value at {}", n.value, n.pos, v.pos));
                }
            }
        }
        _ => {}
    }
    if let Ron::Struct { fields, .. } = &v.value {
        for (k, _) in fields {
            check_name(&k.value, k.pos, src, problems);
        }
    }
    match &v.value {
        Ron::Tuple { items, .. } | Ron::List(items) => items.iter().for_each(|i| check_positions(i, src, problems)),
        Ron::Struct { fields, .. } => fields.iter().for_each(|(_, f)| check_positions(f, src, problems)),
        Ron::Map(entries) => entries.iter().for_each(|(k, e)| {
            check_positions(k, src, problems);
            check_positions(e, src, problems);
        }),
        _ => {}
    }
}

/// `name` (or `r#name`) is spelled at `pos`, as a whole identifier.
fn check_name(name: &str, pos: Pos, src: &Source, problems: &mut Vec<String>) {
    let at = src.at(pos);
    let rest = at.strip_prefix("r#").unwrap_or(at);
    let spelled = rest.strip_prefix(name).is_some_and(|after| !after.starts_with(is_ident_char));
    if !spelled {
        problems
            .push(format!("at {pos}: expected the name `{name}`, found {:?}", at.chars().take(20).collect::<String>()));
    }
}

// -------------------------------------------------------------------------------------------------
// The verdict
// -------------------------------------------------------------------------------------------------

/// RON's whitespace (Rust's `Pattern_White_Space`), as both parsers read it.
fn is_ron_whitespace(c: char) -> bool {
    matches!(
        c,
        ' ' | '\t' | '\n' | '\r' | '\u{b}' | '\u{c}' | '\u{85}' | '\u{200e}' | '\u{200f}' | '\u{2028}' | '\u{2029}'
    )
}

fn is_ident_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Compares the two parsers on `text`; `Err` describes an unexplained difference.
fn verdict(text: &str) -> Result<Verdict, String> {
    let why = match compare(text) {
        Ok(v) => return Ok(v),
        Err(why) => why,
    };
    if let Some(rest) = text.strip_prefix('\u{feff}') {
        // We skip the mark without counting it, so we must read the rest identically.
        let (with, without) = (syntax::parse(text), syntax::parse(rest));
        if format!("{with:?}") != format!("{without:?}") {
            return Err(format!("{why}\nwe read it differently without its byte-order mark: {without:?}"));
        }
        verdict(rest).map_err(|e| format!("{why}\nwithout its byte-order mark: {e}"))?;
        return Ok(Verdict::Known(Known::ByteOrderMark));
    }
    let blanked = blank_attributes(text);
    if blanked != text {
        verdict(&blanked).map_err(|e| format!("{why}\nwith its attributes blanked out: {e}"))?;
        return Ok(Verdict::Known(Known::Attribute));
    }
    Err(why)
}

fn compare(text: &str) -> Result<Verdict, String> {
    let src = Source::new(text);
    match (syntax::parse(text), ron::from_str::<Value>(text)) {
        (Err(_), Err(_)) => Ok(Verdict::BothReject),
        (Ok(tree), Ok(value)) => {
            let theirs = ron_n(&value);
            match ours_n(&tree, &src) {
                Ok(ours) if Ok(&ours) == theirs.as_ref() => {}
                _ if has_suffixed_special(&tree.value) => return Ok(Verdict::Known(Known::NumberSuffix)),
                _ if keeps_equal_keys_apart(&value) => return Ok(Verdict::Known(Known::KeysRonKeepsApart)),
                ours => {
                    return Err(format!("both accept, but read differently:\n  ours: {ours:?}\n  ron:  {theirs:?}"))
                }
            }
            guided(text, &tree).map_err(|e| format!("ron's typed deserialiser does not read our tree: {e}"))?;
            let mut problems = Vec::new();
            check_positions(&tree, &src, &mut problems);
            if !problems.is_empty() {
                return Err(format!("wrong positions:\n  {}", problems.join("\n  ")));
            }
            Ok(Verdict::Agree)
        }
        (Ok(tree), Err(e)) => ours_only(text, &src, &tree, &e).map(Verdict::Known),
        (Err(e), Ok(value)) => ron_only(&src, &e)
            .map(Verdict::Known)
            .ok_or_else(|| format!("ron accepts (as {:?}), we reject: {e}", ron_n(&value))),
    }
}

/// Whether a map in `v` holds two keys that normalise to one (see [`Known::KeysRonKeepsApart`]).
fn keeps_equal_keys_apart(v: &Value) -> bool {
    match v {
        Value::Map(m) => {
            let keys: Vec<N> = m.keys().filter_map(|k| ron_n(k).ok()).collect();
            let distinct: std::collections::BTreeSet<&N> = keys.iter().collect();
            distinct.len() < keys.len() || m.values().any(keeps_equal_keys_apart)
        }
        Value::Seq(items) => items.iter().any(keeps_equal_keys_apart),
        Value::Option(Some(x)) => keeps_equal_keys_apart(x),
        _ => false,
    }
}

/// `inff32` and friends: identifiers to us, suffixed floats to ron.
fn has_suffixed_special(v: &Ron) -> bool {
    match v {
        Ron::Ident(name) => matches!(name.as_str(), "inff32" | "inff64" | "NaNf32" | "NaNf64"),
        Ron::Tuple { items, .. } | Ron::List(items) => items.iter().any(|i| has_suffixed_special(&i.value)),
        Ron::Struct { fields, .. } => fields.iter().any(|(_, f)| has_suffixed_special(&f.value)),
        Ron::Map(entries) => {
            entries.iter().any(|(k, e)| has_suffixed_special(&k.value) || has_suffixed_special(&e.value))
        }
        _ => false,
    }
}

/// We accept, `ron::Value` rejects.
fn ours_only(text: &str, src: &Source, tree: &Spanned<Ron>, e: &ron::error::SpannedError) -> Result<Known, String> {
    if e.code == ron::Error::ExceededRecursionLimit {
        return Ok(Known::Depth);
    }
    match ours_n(tree, src) {
        Ok(ours) => Err(format!("we accept (as {ours:?}), ron rejects: {e}")),
        Err(what) => {
            guided(text, tree).map_err(|g| {
                format!("we accept {what}, which ron::Value cannot hold, but ron's typed deserialiser rejects our tree too: {g}")
            })?;
            let mut problems = Vec::new();
            check_positions(tree, src, &mut problems);
            if !problems.is_empty() {
                return Err(format!("wrong positions:\n  {}", problems.join("\n  ")));
            }
            Ok(Known::ValueCannotHold)
        }
    }
}

/// ron accepts, we reject: recognised from our error and the text where we stopped.
fn ron_only(src: &Source, e: &SyntaxError) -> Option<Known> {
    let (before, after) = src.text.split_at(src.offset(e.pos));
    let message = e.message.as_str();
    let next = after.chars().next();
    let starts_word = |w: &str| after.strip_prefix(w).is_some_and(|rest| !rest.starts_with(is_ident_char));
    let suffixes = ["i8", "i16", "i32", "i64", "i128", "u8", "u16", "u32", "u64", "u128", "f32", "f64"];
    let specials = ["inff32", "inff64", "NaNf32", "NaNf64"];
    if message.contains("integer overflow") {
        Some(Known::IntegerRange)
    } else if message.contains("nested more than") {
        Some(Known::Depth)
    } else if after.starts_with("..") || (before.ends_with('.') && after.starts_with('.')) {
        Some(Known::Range)
    } else if (message.starts_with("unexpected character") && suffixes.iter().any(|s| starts_word(s)))
        || (message.starts_with("expected a number") && specials.iter().any(|s| starts_word(s)))
    {
        Some(Known::NumberSuffix)
    } else if message.starts_with("expected exponent digits")
        && before.ends_with('_')
        && before.trim_end_matches('_').ends_with(['e', 'E'])
        && matches!(next, Some('+' | '-'))
    {
        Some(Known::ExponentUnderscore)
    } else if (before.ends_with('b') || before.ends_with("br")) && matches!(next, Some('\'' | '"' | '#')) {
        Some(Known::Bytes)
    } else if ["unknown escape `\\x`", "unknown escape `\\\n`", "unknown escape `\\\r`"].contains(&message) {
        Some(Known::Escape)
    } else if (message == "empty character literal" && after.starts_with("'''"))
        || (message == "unterminated character literal" && after.starts_with("'\n'"))
    {
        Some(Known::CharLiteral)
    } else if next.is_some_and(|c| !c.is_ascii() && c.is_alphanumeric())
        || (before.ends_with('r') && after.starts_with('#'))
        || (before.trim_end_matches(is_ident_char).ends_with("r#") && matches!(next, Some('.' | '+' | '-')))
    {
        Some(Known::Identifier)
    } else if next == Some('#') || message.starts_with("expected `[` after `#!`") {
        Some(Known::Attribute)
    } else {
        None
    }
}

/// The text with the `#![...]` attributes we skip replaced by spaces (line breaks kept).
fn blank_attributes(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = chars.clone();
    let mut i = usize::from(chars.first() == Some(&'\u{feff}'));
    loop {
        loop {
            match (chars.get(i), chars.get(i + 1)) {
                (Some(&c), _) if is_ron_whitespace(c) => i += 1,
                (Some('/'), Some('/')) => {
                    while i < chars.len() && chars[i] != '\n' {
                        i += 1;
                    }
                }
                (Some('/'), Some('*')) => {
                    let mut depth = 0;
                    loop {
                        match (chars.get(i), chars.get(i + 1)) {
                            (None, _) => return text.to_string(),
                            (Some('/'), Some('*')) => (depth, i) = (depth + 1, i + 2),
                            (Some('*'), Some('/')) => (depth, i) = (depth - 1, i + 2),
                            _ => i += 1,
                        }
                        if depth == 0 {
                            break;
                        }
                    }
                }
                _ => break,
            }
        }
        if chars.get(i) != Some(&'#') || chars.get(i + 1) != Some(&'!') || chars.get(i + 2) != Some(&'[') {
            break;
        }
        let Some(len) = chars[i..].iter().position(|&c| c == ']') else { break };
        for c in &mut out[i..=i + len] {
            if *c != '\n' {
                *c = ' ';
            }
        }
        i += len + 1;
    }
    out.into_iter().collect()
}

// -------------------------------------------------------------------------------------------------
// Generated texts
// -------------------------------------------------------------------------------------------------

/// A RON value in the shared subset; literals are generated as text.
#[derive(Clone, Debug)]
enum G {
    Lit(String),
    Ident(&'static str),
    Tuple(Option<&'static str>, Vec<G>),
    /// Unnamed structs have at least one field.
    Struct(Option<&'static str>, Vec<(&'static str, G)>),
    List(Vec<G>),
    Map(Vec<(G, G)>),
    Some(Box<G>),
}

/// Unit values, raw identifiers and near-keywords included (`None` is an `Option` to ron).
const UNIT_IDENTS: &[&str] = &[
    "A", "Rec709", "Seed", "x", "_", "_a1", "b", "r", "br", "e", "E", "infinity", "nan", "NaNa", "inf_", "True",
    "none", "Some_", "None", "r#type", "r#Some", "r#None", "r#true", "r#false", "r#inf", "r#NaN", "r#r", "r#b",
];
/// Struct and tuple names.
const NAMES: &[&str] = &[
    "Op", "LoadHdr", "Save", "A", "x", "_", "b", "r", "br", "e", "infinity", "r#type", "r#Some", "r#None", "r#true",
    "r#inf",
];
/// Field names, keywords included: `(true: 1)` is a struct to both.
const FIELDS: &[&str] = &[
    "a", "path", "image", "x_1", "_", "r#type", "r#true", "true", "false", "None", "Some", "inf", "NaN", "e", "b", "r",
];
/// Keys likely to repeat, some equal under different spellings (`"a"`, `r"a"`, `"\u{61}"`;
/// `1`, `0x1`; `A`, `()`, both `Unit` to ron).
const KEYS: &[&str] = &["\"a\"", "\"b\"", "r\"a\"", "\"\\u{61}\"", "1", "0x1", "A", "()", "true", "\"env\""];
/// Whitespace that RON allows besides space, tab and line breaks.
const EXOTIC_WS: &[&str] = &["\u{b}", "\u{c}", "\u{85}", "\u{200e}", "\u{200f}", "\u{2028}", "\u{2029}"];

fn int_lit() -> impl Strategy<Value = String> {
    let magnitude = prop_oneof![Just(0u64), 0u64..300, (any::<u64>(), 1u32..64).prop_map(|(x, s)| x >> s)];
    let general = (
        prop::sample::select(vec!["", "", "", "-", "+"]),
        magnitude,
        0usize..4,
        any::<u64>(),
        0usize..3,
        any::<bool>(),
    )
        .prop_map(|(sign, m, radix, mask, zeros, upper)| {
            let (prefix, digits) = match radix {
                0 => ("", m.to_string()),
                1 if upper => ("0x", format!("{m:X}")),
                1 => ("0x", format!("{m:x}")),
                2 => ("0o", format!("{m:o}")),
                _ => ("0b", format!("{m:b}")),
            };
            format!("{sign}{prefix}{}", with_underscores(&("0".repeat(zeros) + &digits), mask))
        });
    prop_oneof![
        8 => general,
        1 => prop::sample::select(vec!["-9223372036854775808", "9223372036854775807", "-0x8000000000000000", "+0", "-0"])
            .prop_map(String::from),
    ]
}

/// `_` after some digits (never first; RON allows trailing and repeated ones).
fn with_underscores(digits: &str, mask: u64) -> String {
    let mut s = String::new();
    for (i, c) in digits.chars().enumerate() {
        s.push(c);
        if (mask >> (i % 64)) & 1 == 1 && (mask >> ((i + 17) % 64)) & 1 == 1 {
            s.push('_');
        }
    }
    s
}

fn float_lit() -> impl Strategy<Value = String> {
    let sign = prop::sample::select(vec!["", "", "-", "+"]);
    let exponent =
        (prop::sample::select(vec!["e", "E"]), prop::sample::select(vec!["", "+", "-", "_", "-_"]), 0u32..400)
            .prop_map(|(e, s, x)| format!("{e}{s}{x}"));
    (sign, 0usize..7, "[0-9]{1,6}", "[0-9]{0,6}", exponent, any::<u64>()).prop_map(|(sign, kind, a, b, exp, mask)| {
        let (a, b2) = (with_underscores(&a, mask), with_underscores(&b, mask.rotate_left(32)));
        let body = match kind {
            0 => format!("{a}.{b2}"),
            1 => format!(".{a}"),
            2 => format!("{a}{exp}"),
            3 => format!("{a}.{b2}{exp}"),
            4 => format!(".{a}{exp}"),
            5 => "inf".to_string(),
            _ => "NaN".to_string(),
        };
        format!("{sign}{body}")
    })
}

/// Characters for strings: the ones that need escaping, non-ASCII ones, RON punctuation.
fn text_char() -> impl Strategy<Value = char> {
    prop_oneof![
        3 => prop::sample::select(vec![
            'a', 'Z', '0', ' ', '"', '\\', '\'', '\n', '\t', '\r', '\0', 'é', '😀', '\u{7f}', '\u{85}', '{', '(', ')',
            '/', '*', '#', ',', ':', '\u{2028}', '\u{feff}', '\u{a0}',
        ]),
        1 => any::<char>(),
    ]
}

fn unicode_escape(c: char, style: u8) -> String {
    match style % 3 {
        0 => format!("\\u{{{:x}}}", c as u32),
        1 => format!("\\u{{{:06X}}}", c as u32),
        _ => format!("\\u{{{:04x}}}", c as u32),
    }
}

fn string_lit() -> impl Strategy<Value = String> {
    prop::collection::vec((text_char(), any::<u8>()), 0..12).prop_map(|chars| {
        let mut s = String::from("\"");
        for (c, k) in chars {
            match (c, k % 4) {
                ('"', _) => s.push_str("\\\""),
                ('\\', _) => s.push_str("\\\\"),
                ('\n', 0) => s.push_str("\\n"),
                ('\t', 0) => s.push_str("\\t"),
                ('\r', 0) => s.push_str("\\r"),
                ('\0', 0) => s.push_str("\\0"),
                ('\'', 0) => s.push_str("\\'"),
                (c, 1) => s.push_str(&unicode_escape(c, k / 4)),
                (c, _) => s.push(c),
            }
        }
        s.push('"');
        s
    })
}

fn raw_string_lit() -> impl Strategy<Value = String> {
    (0usize..3, prop::collection::vec(text_char(), 0..10)).prop_map(|(hashes, chars)| {
        // No `#` in the content, so `"` can only end the string when there are no hashes.
        let content: String = chars.into_iter().filter(|&c| c != '#' && (hashes > 0 || c != '"')).collect();
        let h = "#".repeat(hashes);
        format!("r{h}\"{content}\"{h}")
    })
}

fn char_lit() -> impl Strategy<Value = String> {
    (text_char(), any::<u8>()).prop_map(|(c, k)| {
        let inner = match (c, k % 3) {
            ('\'', _) => "\\'".to_string(),
            ('\\', _) => "\\\\".to_string(),
            ('\n', _) => "\\n".to_string(),
            ('\t', 0) => "\\t".to_string(),
            ('"', 0) => "\\\"".to_string(),
            ('\0', 0) => "\\0".to_string(),
            (c, 1) => unicode_escape(c, k / 3),
            (c, _) => c.to_string(),
        };
        format!("'{inner}'")
    })
}

fn leaf() -> impl Strategy<Value = G> {
    prop_oneof![
        2 => int_lit().prop_map(G::Lit),
        2 => float_lit().prop_map(G::Lit),
        2 => string_lit().prop_map(G::Lit),
        1 => raw_string_lit().prop_map(G::Lit),
        1 => char_lit().prop_map(G::Lit),
        1 => prop::sample::select(vec!["true", "false"]).prop_map(|b| G::Lit(b.to_string())),
        2 => prop::sample::select(UNIT_IDENTS).prop_map(G::Ident),
    ]
}

/// Keys without `NaN`, `-0` or chars anywhere (see the module documentation).
fn sanitize_key(g: G) -> G {
    let risky = |t: &str| {
        let unsigned =
            t.strip_prefix('-').map(|t| t.trim_start_matches("0x").trim_start_matches("0o").trim_start_matches("0b"));
        t.contains("NaN") || t.starts_with('\'') || unsigned.is_some_and(|u| u.chars().all(|c| c == '0' || c == '_'))
    };
    match g {
        G::Lit(t) if risky(&t) => G::Lit("0".into()),
        G::Tuple(n, items) => G::Tuple(n, items.into_iter().map(sanitize_key).collect()),
        G::Struct(n, fields) => G::Struct(n, fields.into_iter().map(|(k, v)| (k, sanitize_key(v))).collect()),
        G::List(items) => G::List(items.into_iter().map(sanitize_key).collect()),
        G::Map(entries) => G::Map(entries.into_iter().map(|(k, v)| (sanitize_key(k), sanitize_key(v))).collect()),
        G::Some(x) => G::Some(Box::new(sanitize_key(*x))),
        other => other,
    }
}

fn key(inner: impl Strategy<Value = G> + 'static) -> impl Strategy<Value = G> {
    prop_oneof![
        2 => prop::sample::select(KEYS).prop_map(|k| G::Lit(k.to_string())),
        1 => inner.prop_map(sanitize_key),
    ]
}

fn value() -> impl Strategy<Value = G> {
    leaf().prop_recursive(4, 40, 5, |inner| {
        let name = prop::option::of(prop::sample::select(NAMES));
        prop_oneof![
            (name.clone(), prop::collection::vec(inner.clone(), 0..5)).prop_map(|(n, items)| G::Tuple(n, items)),
            (name, prop::collection::vec((prop::sample::select(FIELDS), inner.clone()), 0..5)).prop_map(
                |(n, fields)| if n.is_none() && fields.is_empty() {
                    G::Tuple(None, vec![])
                } else {
                    G::Struct(n, fields)
                }
            ),
            prop::collection::vec(inner.clone(), 0..5).prop_map(G::List),
            prop::collection::vec((key(inner.clone()), inner.clone()), 0..5).prop_map(G::Map),
            inner.prop_map(|x| G::Some(Box::new(x))),
        ]
    })
}

/// `( nodes: { "name": Op(field: value, ...), ... } )`, with realistic operator arguments.
fn pipeline() -> impl Strategy<Value = G> {
    let node_name = prop::sample::select(vec![
        "\"env\"",
        "\"lum\"",
        "\"save\"",
        "\"cdf\"",
        "\"samples_64\"",
        "\"a b\"",
        "\"é\"",
        "r\"raw\"",
        "\"\\u{65}nv\"",
        "\"with \\\"quotes\\\"\"",
    ]);
    let op = prop::sample::select(vec![
        "LoadHdr",
        "Luminance",
        "Save",
        "BuildCdf",
        "Sample",
        "Overlay",
        "Constant",
        "Fresnel",
        "Exposure",
        "r#Op",
    ]);
    let field = prop::sample::select(vec![
        "path",
        "image",
        "input",
        "count",
        "seed",
        "size",
        "exponent",
        "flip_vertical",
        "weights",
        "color",
        "auto_exposure",
        "eta_i",
        "r#type",
        "_",
        "x1",
    ]);
    let float3 =
        prop::collection::vec(float_lit(), 3).prop_map(|v| G::Tuple(None, v.into_iter().map(G::Lit).collect()));
    let arg = prop_oneof![
        3 => string_lit().prop_map(G::Lit),
        2 => int_lit().prop_map(G::Lit),
        2 => float_lit().prop_map(G::Lit),
        1 => prop::sample::select(vec!["true", "false"]).prop_map(|b| G::Lit(b.to_string())),
        1 => prop::sample::select(vec!["Rec709", "Seed", "None"]).prop_map(G::Ident),
        1 => float3,
        1 => int_lit().prop_map(|i| G::Some(Box::new(G::Lit(i)))),
        1 => prop::collection::vec(int_lit().prop_map(G::Lit), 0..4).prop_map(G::List),
        1 => value(),
    ];
    let node = (node_name, op, prop::collection::vec((field, arg), 0..5))
        .prop_map(|(n, op, fields)| (G::Lit(n.to_string()), G::Struct(Some(op), fields)));
    let extra = prop::option::of(prop::collection::vec(string_lit().prop_map(G::Lit), 0..3));
    (
        prop::collection::vec(node, 0..8),
        extra,
        prop::sample::select(vec![None, None, Some("Pipeline"), Some("r#Pipeline")]),
    )
        .prop_map(|(nodes, extra, name)| {
            let mut fields = vec![("nodes", G::Map(nodes))];
            if let Some(outputs) = extra {
                fields.push(("outputs", G::List(outputs)));
            }
            G::Struct(name, fields)
        })
}

/// Writes a value, with whitespace, comments and trailing commas chosen by `noise`.
struct Out<'a> {
    text: String,
    noise: &'a [u8],
    at: usize,
}

impl Out<'_> {
    fn pick(&mut self, n: usize) -> usize {
        if self.noise.is_empty() {
            return 0;
        }
        let b = self.noise[self.at % self.noise.len()];
        self.at += 1;
        usize::from(b) % n
    }

    /// Nothing, or whitespace or comments, between two tokens.
    fn gap(&mut self) {
        let s = match self.pick(24) {
            0..=9 => "",
            10..=13 => " ",
            14 => "\n        ",
            15 => "\t",
            16 => "\r\n",
            17 => EXOTIC_WS[self.pick(EXOTIC_WS.len())],
            18 => "/* c */",
            19 => "/* a /* nested */ comment */",
            20 => "// line comment \" ( [\n",
            21 => "/**/",
            22 => "/*/ ) ] } , : \" ' */",
            _ => "\n    // a comment\n    ",
        };
        self.text.push_str(s);
    }

    fn seq<T>(&mut self, open: char, close: char, items: &[T], mut item: impl FnMut(&mut Self, &T)) {
        self.text.push(open);
        for (i, it) in items.iter().enumerate() {
            self.gap();
            item(self, it);
            self.gap();
            if i + 1 < items.len() || self.pick(3) == 0 {
                self.text.push(',');
            }
        }
        self.gap();
        self.text.push(close);
    }

    fn value(&mut self, g: &G) {
        match g {
            G::Lit(t) => self.text.push_str(t),
            G::Ident(name) => self.text.push_str(name),
            G::Tuple(name, items) => {
                if let Some(n) = name {
                    self.text.push_str(n);
                    self.gap();
                }
                self.seq('(', ')', items, |o, i| o.value(i));
            }
            G::Struct(name, fields) => {
                if let Some(n) = name {
                    self.text.push_str(n);
                    self.gap();
                }
                self.seq('(', ')', fields, |o, (k, v)| {
                    o.text.push_str(k);
                    o.gap();
                    o.text.push(':');
                    o.gap();
                    o.value(v);
                });
            }
            G::List(items) => self.seq('[', ']', items, |o, i| o.value(i)),
            G::Map(entries) => self.seq('{', '}', entries, |o, (k, v)| {
                o.value(k);
                o.gap();
                o.text.push(':');
                o.gap();
                o.value(v);
            }),
            G::Some(x) => {
                self.text.push_str("Some");
                self.gap();
                self.seq('(', ')', std::slice::from_ref(x.as_ref()), |o, i| o.value(i));
            }
        }
    }
}

/// A whole file: optional header (comments, attributes), the value, optional trailing comment.
fn document(g: &G, noise: &[u8]) -> String {
    let mut out = Out { text: String::new(), noise, at: 0 };
    let header = [
        "",
        "",
        "",
        "// a pipeline\n",
        "/* header */\n",
        "#![enable(implicit_some)]\n",
        "#![enable(unwrap_newtypes, implicit_some,)]\n",
        "#![type = \"hdrflow::Pipeline\"]\n// after\n",
    ];
    let h = header[out.pick(header.len())];
    out.text.push_str(h);
    out.gap();
    out.value(g);
    out.gap();
    let trailer = ["", "\n", "\n// end", "// end\n", "/* end */"];
    let t = trailer[out.pick(trailer.len())];
    out.text.push_str(t);
    out.text
}

fn documents() -> impl Strategy<Value = String> {
    let g = prop_oneof![2 => value(), 1 => pipeline()];
    (g, prop::collection::vec(any::<u8>(), 0..64)).prop_map(|(g, noise)| document(&g, &noise))
}

// -------------------------------------------------------------------------------------------------
// Near misses
// -------------------------------------------------------------------------------------------------

/// Characters inserted by mutations: syntax, number and string parts, non-RON whitespace.
const MUTATION_CHARS: &[char] = &[
    '(', ')', '[', ']', '{', '}', ',', ':', '"', '\'', '\\', '/', '*', '#', '!', 'r', 'b', '.', '-', '+', 'e', 'E',
    '_', '0', '1', '9', 'x', 'u', 'i', 'f', 'a', 'S', ' ', '\n', '\t', '\r', '\u{a0}', '\u{3000}', '\u{feff}', 'é',
    '\u{200e}', '\u{2028}', '\u{b}',
];

#[derive(Clone, Copy, Debug)]
enum Edit {
    Delete(usize),
    Insert(usize, char),
    Replace(usize, char),
    Duplicate(usize),
    Swap(usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    let c = prop::sample::select(MUTATION_CHARS);
    prop_oneof![
        3 => any::<usize>().prop_map(Edit::Delete),
        3 => (any::<usize>(), c.clone()).prop_map(|(i, c)| Edit::Insert(i, c)),
        2 => (any::<usize>(), c).prop_map(|(i, c)| Edit::Replace(i, c)),
        1 => any::<usize>().prop_map(Edit::Duplicate),
        1 => any::<usize>().prop_map(Edit::Swap),
    ]
}

fn mutate(text: &str, e: Edit) -> String {
    let mut chars: Vec<char> = text.chars().collect();
    let n = chars.len();
    match e {
        Edit::Insert(i, c) => chars.insert(i % (n + 1), c),
        _ if n == 0 => {}
        Edit::Delete(i) => {
            chars.remove(i % n);
        }
        Edit::Replace(i, c) => chars[i % n] = c,
        Edit::Duplicate(i) => chars.insert(i % n, chars[i % n]),
        Edit::Swap(i) if n >= 2 => chars.swap(i % (n - 1), i % (n - 1) + 1),
        Edit::Swap(_) => {}
    }
    chars.into_iter().collect()
}

// -------------------------------------------------------------------------------------------------
// ron's own output
// -------------------------------------------------------------------------------------------------

/// A `ron::Value` our subset can hold: no bytes, no u64 past i64, no `'\n'` (ron writes that
/// char literally between quotes, see [`Known::CharLiteral`]); keys without `NaN`, `-0`, chars.
fn ron_value() -> impl Strategy<Value = Value> {
    let key = prop_oneof![
        any::<String>().prop_map(Value::String),
        any::<u32>().prop_map(|x| Value::Number(Number::U32(x))),
        any::<bool>().prop_map(Value::Bool),
        Just(Value::Unit),
    ];
    let leaf = prop_oneof![
        any::<bool>().prop_map(Value::Bool),
        any::<char>().prop_filter("a line break in a char literal", |&c| c != '\n').prop_map(Value::Char),
        any::<i64>().prop_map(|x| Value::Number(Number::I64(x))),
        any::<i8>().prop_map(|x| Value::Number(Number::I8(x))),
        any::<u16>().prop_map(|x| Value::Number(Number::U16(x))),
        any::<f32>().prop_map(|x| Value::Number(Number::F32(x.into()))),
        any::<f64>().prop_map(|x| Value::Number(Number::F64(x.into()))),
        any::<String>().prop_map(Value::String),
        Just(Value::Unit),
        Just(Value::Option(None)),
    ];
    leaf.prop_recursive(4, 32, 4, move |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..4).prop_map(Value::Seq),
            prop::collection::vec((key.clone(), inner.clone()), 0..4).prop_map(|e| Value::Map(e.into_iter().collect())),
            inner.prop_map(|v| Value::Option(Some(Box::new(v)))),
        ]
    })
}

fn pretty_config(k: u16) -> PrettyConfig {
    let bit = |i: u16| (k >> i) & 1 == 1;
    let mut c = PrettyConfig::new()
        .struct_names(bit(0))
        .separate_tuple_members(bit(1))
        .enumerate_arrays(bit(2))
        .compact_arrays(bit(3))
        .compact_maps(bit(4))
        .compact_structs(bit(5))
        .escape_strings(!bit(6));
    if bit(7) {
        c = c.new_line("\r\n").indentor("\t");
    }
    if bit(8) {
        c = c.separator("");
    }
    if bit(9) {
        c = c.extensions(ron::extensions::Extensions::IMPLICIT_SOME);
    }
    if bit(10) {
        c = c.depth_limit(1);
    }
    c
}

// -------------------------------------------------------------------------------------------------
// Harness
// -------------------------------------------------------------------------------------------------

/// Cases per property: `HDRFLOW_ORACLE_CASES` if set (and a positive integer), else `ci`.
fn cases(ci: u32) -> u32 {
    std::env::var("HDRFLOW_ORACLE_CASES").ok().and_then(|s| s.trim().parse().ok()).filter(|&n| n > 0).unwrap_or(ci)
}

fn runner(ci: u32) -> TestRunner {
    TestRunner::new(ProptestConfig { cases: cases(ci), failure_persistence: None, ..ProptestConfig::default() })
}

/// Verdicts counted by kind, printed by each test (run with `--nocapture` to see them).
#[derive(Default)]
struct Tally(RefCell<BTreeMap<Verdict, usize>>);

impl Tally {
    fn check(&self, text: &str) -> Result<Verdict, TestCaseError> {
        let v = verdict(text).map_err(|e| TestCaseError::fail(format!("{e}\n  text: {text:?}")))?;
        *self.0.borrow_mut().entry(v).or_default() += 1;
        Ok(v)
    }

    fn count(&self, v: Verdict) -> usize {
        self.0.borrow().get(&v).copied().unwrap_or(0)
    }

    fn print(&self, what: &str) {
        eprintln!("{what}: {:?}", self.0.borrow());
    }
}

fn run<S: Strategy>(ci: u32, strategy: S, test: impl Fn(S::Value) -> Result<(), TestCaseError>) {
    if let Err(e) = runner(ci).run(&strategy, test) {
        panic!("{e}");
    }
}

// -------------------------------------------------------------------------------------------------
// Properties
// -------------------------------------------------------------------------------------------------

/// Generated texts in the shared subset: both accept and read the same (names, positions and
/// all), or differ only by a leading attribute that ron's extensions read differently.
#[test]
fn generated_texts_agree() {
    let tally = Tally::default();
    run(5000, documents(), |text| {
        let v = tally.check(&text)?;
        prop_assert_eq!(v, Verdict::Agree, "a generated text: {:?}", text);
        Ok(())
    });
    tally.print("generated texts");
}

/// Near misses of generated texts: the parsers accept the same texts and read them the same,
/// except for the documented differences.
#[test]
fn near_misses_agree_or_differ_for_a_documented_reason() {
    let tally = Tally::default();
    run(2000, (documents(), prop::collection::vec(edit(), 16)), |(text, edits)| {
        for e in edits {
            tally.check(&mutate(&text, e))?;
        }
        // Two edits at once reach texts one edit cannot (e.g. `b` then `'`).
        tally.check(&mutate(&mutate(&text, Edit::Delete(text.len() / 2)), Edit::Insert(text.len() / 3, '\'')))?;
        Ok(())
    });
    tally.print("near misses");
    assert!(tally.count(Verdict::Agree) > 1000, "too few near misses are valid to both");
    assert!(tally.count(Verdict::BothReject) > 1000, "too few near misses are invalid to both");
}

/// ron's own output, compact and pretty in many settings, reads the same with our parser.
#[test]
fn ron_output_agrees() {
    let tally = Tally::default();
    run(3000, (ron_value(), any::<u16>()), |(value, k)| {
        for text in [ron::to_string(&value), ron::ser::to_string_pretty(&value, pretty_config(k))] {
            let text = text.map_err(|e| TestCaseError::fail(format!("ron cannot write {value:?}: {e}")))?;
            let v = tally.check(&text)?;
            prop_assert_eq!(v, Verdict::Agree, "ron wrote {:?}", text);
        }
        Ok(())
    });
    tally.print("ron output");
}

// -------------------------------------------------------------------------------------------------
// Files
// -------------------------------------------------------------------------------------------------

fn files(dir: &str) -> Vec<(String, String)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut out: Vec<(String, String)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.is_file())
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            (p.file_name().unwrap().to_string_lossy().into_owned(), String::from_utf8_lossy(&bytes).into_owned())
        })
        .collect();
    out.sort();
    out
}

/// The pipelines in the repository: every one but the deliberate syntax error is valid RON and
/// reads the same.
#[test]
fn repository_pipelines_agree() {
    let mut seen = 0;
    for dir in ["graphs", "tests/bad"] {
        for (name, text) in files(dir).into_iter().filter(|(n, _)| n.ends_with(".ron")) {
            let v = verdict(&text).unwrap_or_else(|e| panic!("{dir}/{name}: {e}"));
            let expected = if name == "syntax_error.ron" { Verdict::BothReject } else { Verdict::Agree };
            assert_eq!(v, expected, "{dir}/{name}");
            seen += 1;
        }
    }
    assert!(seen >= 16, "only {seen} pipeline files found");
}

/// The minimised fuzz corpus (hostile near-pipelines): every difference is a documented one.
#[test]
fn fuzz_corpus_differences_are_documented() {
    let tally = Tally::default();
    let corpus = files("fuzz/regressions/pipeline");
    assert!(!corpus.is_empty());
    for (name, text) in &corpus {
        if let Err(e) = tally.check(text) {
            panic!("fuzz/regressions/pipeline/{name}: {e}");
        }
    }
    tally.print("fuzz corpus");
}

/// One-character deletions of the repository's pipelines, and every insertion of a
/// [`MUTATION_CHARS`] character into `graphs/example.ron`.
#[test]
fn repository_pipeline_near_misses() {
    let tally = Tally::default();
    for (name, text) in files("graphs").into_iter().filter(|(n, _)| n.ends_with(".ron")) {
        let n = text.chars().count();
        // Every deletion in the small file, every fifth in the large one (6000 characters).
        let step = if n > 1000 { 5 } else { 1 };
        let mut edits: Vec<Edit> = (0..n).step_by(step).map(Edit::Delete).collect();
        if name == "example.ron" {
            edits.extend((0..=n).flat_map(|i| MUTATION_CHARS.iter().map(move |&c| Edit::Insert(i, c))));
        }
        for e in edits {
            let mutated = mutate(&text, e);
            if let Err(err) = tally.check(&mutated) {
                panic!("graphs/{name} with {e:?}: {err}");
            }
        }
    }
    tally.print("repository near misses");
}

// -------------------------------------------------------------------------------------------------
// The documented differences, one example each (and the normalisation's corner cases)
// -------------------------------------------------------------------------------------------------

#[test]
fn each_documented_difference() {
    use Known::*;
    let deep_list = format!("{}1{}", "[".repeat(100), "]".repeat(100));
    let deep_some = format!("{}1{}", "Some(".repeat(128), ")".repeat(128));
    let cases: &[(&str, Known)] = &[
        ("Some(1, 2)", ValueCannotHold),
        ("Some()", ValueCannotHold),
        ("Some(path: \"a\")", ValueCannotHold),
        ("[Some, None(1)]", ValueCannotHold),
        ("\u{feff}(a: 1)", ByteOrderMark),
        ("#![enable(no_such_extension)]\n1", Attribute),
        ("#![anything at all]\n1", Attribute),
        ("# ! [enable(implicit_some)] 1", Attribute),
        ("#![enable(unwrap_variant_newtypes)]\nSome(a: 1)", Attribute),
        ("1..2", Range),
        ("(a: ..=5)", Range),
        ("[..]", Range),
        ("1u8", NumberSuffix),
        ("[2.5f32]", NumberSuffix),
        ("-inff64", NumberSuffix),
        ("[inff32]", NumberSuffix),
        ("b'a'", Bytes),
        ("[b\"ab\"]", Bytes),
        ("br#\"x\"#", Bytes),
        ("9223372036854775808", IntegerRange),
        ("-9223372036854775809", IntegerRange),
        ("(seed: 18446744073709551615)", IntegerRange),
        ("Größe", Identifier),
        ("(größe: 1)", Identifier),
        ("r#a.b", Identifier),
        ("r#1", Identifier),
        ("\"\\x41\"", Escape),
        ("\"a long \\\n     string\"", Escape),
        ("[1e_-5, 2.5E__+3]", ExponentUnderscore),
        ("'''", CharLiteral),
        ("'\n'", CharLiteral),
        ("{0: 1, -0: 2}", KeysRonKeepsApart),
        ("[{-0x0: (), 0: nan}]", KeysRonKeepsApart),
        ("{'a': 1, \"a\": 2}", KeysRonKeepsApart),
        (&deep_list, Depth),
        (&deep_some, Depth),
    ];
    for &(text, known) in cases {
        assert_eq!(verdict(text), Ok(Verdict::Known(known)), "{text:?}");
    }
}

/// Corner cases of the normalisation, and texts that once were read differently.
#[test]
fn corner_cases_agree() {
    for text in [
        "()",
        "( )",
        "(/**/)",
        "Name()",
        "Name ( )",
        "[(), ( ), A, None, r#None, Some(()), r#Some(1), r#Some(1, 2)]",
        "{A: 1, (): 2, B: 3}",
        "{\"a\": 1, r\"a\": 2, \"\\u{61}\": 3}",
        "(a: 1, a: 2)",
        "Op(a: 1, b: 2, a: 3)",
        "(true: 1, None: 2, Some: 3, r#type: 4)",
        "[r#true, r#false, r#inf, r#NaN]",
        "[-0, +0, -0.0, 0.0, -0x8000000000000000, 0b1_0, 0o7_, 1_000_, 1e_5, 1_.5, 1.5_e3]",
        "[1., .5, -.5e-3, 1e400, -inf, +inf, NaN, -NaN, 'a', '\\u{1F600}']",
        "[1,\u{200e}2,\u{200f}3,\u{85}4,\u{2028}5,\u{2029}6,\u{b}7,\u{c}8]",
    ] {
        assert_eq!(verdict(text), Ok(Verdict::Agree), "{text:?}");
    }
    for text in
        ["\"\\/\"", "\"C:\\folder\"", "\"\\b\"", "[1,\u{a0}2]", "[1,\u{3000}2]", "1._5", "0x_1", "-0b_1", "(a: 1, 2)"]
    {
        assert_eq!(verdict(text), Ok(Verdict::BothReject), "{text:?}");
    }
}
