//! Tests of the RON subset parser: positions, every literal form, and the errors.

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
    let v =
        ok("[-2, +3, 1.5, -1.5e-3, 1e10, 1., .5, 0xff, 0b1010, 0o17, 1_000, -inf, inf, -9223372036854775808, true]");
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
