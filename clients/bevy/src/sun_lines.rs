//! The Bevy README's sun lines (`hdrflow bake --for bevy --sun extract`, src/ibl_presets/bevy.rs,
//! `sun_code`) are Rust, which this program cannot compile at run time, so it reads them with a
//! strict reader of exactly the Rust they use and spawns what they spawn (tests/bevy_render.rs,
//! issue 36). A token, name, field or construct it does not know is an error naming the README's
//! line and column, so that what runs is the lines users read and not a rewrite of them. It knows:
//!
//! ```text
//! commands.spawn((COMPONENT, COMPONENT));        one or more statements, the tuple's comma optional
//! DirectionalLight { FIELD: VALUE, ..., ..default() }
//!     illuminance: EXPR
//!     color: Color::linear_rgb(EXPR, EXPR, EXPR)
//!     shadow_maps_enabled: true | false           (`shadows_enabled` before Bevy 0.19: an error)
//! Transform::default().looking_to(VEC, VEC)      VEC: Vec3::new(EXPR, EXPR, EXPR) | Vec3::Y
//! EXPR: [-]LITERAL (* [-]LITERAL)*               f32 literals with a decimal point, as rustc reads
//!                                                them (each rounded to f32, products in f32)
//! // comments
//! ```
//!
//! Each statement needs exactly one `DirectionalLight` and one `Transform` (a light whose
//! direction is zero or not finite is an error: Bevy's `looking_to` would silently shine along -Z).
//! No Bevy types here: the file is also compiled into hdrflow's test (tests/bevy_render.rs) so its
//! tests run without Bevy.

/// One `commands.spawn` of the lines: the fields given (`None`: `..default()`'s) and the transform.
#[derive(Debug, Clone, PartialEq)]
pub struct SunLight {
    pub illuminance: Option<f32>,
    /// `Color::linear_rgb(r, g, b)`
    pub color: Option<[f32; 3]>,
    pub shadow_maps_enabled: Option<bool>,
    /// `looking_to`'s direction (the light shines along it) and up
    pub forward: [f32; 3],
    pub up: [f32; 3],
}

/// What follows "The sun:" in a README, with the README line its first line is.
pub fn sun_section(readme: &str) -> Result<(&str, usize), String> {
    const HEAD: &str = "\nThe sun:\n";
    let at = readme.find(HEAD).ok_or("the README has no \"The sun:\" section")?;
    if readme[at + 1..].contains(HEAD) {
        return Err("the README has more than one \"The sun:\" section".into());
    }
    let first_line = readme[..at + HEAD.len()].matches('\n').count() + 1;
    Ok((&readme[at + HEAD.len()..], first_line))
}

/// The lights of a README's sun section.
pub fn read_readme(readme: &str) -> Result<Vec<SunLight>, String> {
    let (lines, first_line) = sun_section(readme)?;
    parse(lines, first_line)
}

#[derive(Debug, Clone, PartialEq)]
enum Kind {
    Ident(String),
    Number(String),
    Punct(&'static str),
    End,
}

#[derive(Debug, Clone)]
struct Token {
    kind: Kind,
    line: usize,
    column: usize,
}

/// The punctuation the lines use, longest first.
const PUNCT: [&str; 12] = ["..", "::", "(", ")", "{", "}", ",", ":", ";", ".", "*", "-"];

fn describe(kind: &Kind) -> String {
    match kind {
        Kind::Ident(s) => format!("`{s}`"),
        Kind::Number(s) => format!("the number {s}"),
        Kind::Punct(p) => format!("`{p}`"),
        Kind::End => "the end of the lines".into(),
    }
}

/// The tokens of `src` (line numbers from `first_line`), comments dropped.
fn tokenize(src: &str, first_line: usize) -> Result<Vec<Token>, String> {
    let mut out = Vec::new();
    let mut last_line = first_line;
    for (n, line) in src.lines().enumerate() {
        let line_no = first_line + n;
        last_line = line_no;
        let mut rest = line;
        while !rest.is_empty() {
            let column = line.len() - rest.len() + 1;
            let fail = |why: &str| format!("README line {line_no}, column {column}: {why} in {line:?}");
            let c = rest.chars().next().unwrap_or(' ');
            if c.is_whitespace() {
                rest = &rest[c.len_utf8()..];
                continue;
            }
            if rest.starts_with("//") {
                break;
            }
            let token = |kind| Token { kind, line: line_no, column };
            if c.is_ascii_alphabetic() || c == '_' {
                let end = rest.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(rest.len());
                out.push(token(Kind::Ident(rest[..end].to_string())));
                rest = &rest[end..];
            } else if c.is_ascii_digit() {
                let end =
                    rest.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '.')).unwrap_or(rest.len());
                let text = &rest[..end];
                let (whole, fraction) = text.split_once('.').unwrap_or((text, ""));
                let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
                if !text.contains('.') && digits(whole) {
                    return Err(fail(&format!("the integer literal {text} where Rust needs an f32 (write {text}.0)")));
                }
                if !(digits(whole) && digits(fraction)) {
                    return Err(fail(&format!("{text:?} is not a literal these lines use (digits.digits)")));
                }
                out.push(token(Kind::Number(text.to_string())));
                rest = &rest[end..];
            } else if let Some(p) = PUNCT.iter().find(|p| rest.starts_with(**p)) {
                out.push(token(Kind::Punct(p)));
                rest = &rest[p.len()..];
            } else {
                return Err(fail(&format!("unknown character {c:?}")));
            }
        }
    }
    out.push(Token { kind: Kind::End, line: last_line, column: 0 });
    Ok(out)
}

struct Parser {
    tokens: Vec<Token>,
    at: usize,
}

impl Parser {
    fn peek(&self) -> &Token {
        &self.tokens[self.at.min(self.tokens.len() - 1)]
    }

    fn next(&mut self) -> Token {
        let t = self.peek().clone();
        self.at += 1;
        t
    }

    fn error(&self, t: &Token, why: &str) -> String {
        format!("README line {}, column {}: {why}, found {}", t.line, t.column, describe(&t.kind))
    }

    fn punct(&mut self, p: &str) -> Result<(), String> {
        let t = self.next();
        if t.kind == Kind::Punct(PUNCT.iter().find(|q| **q == p).copied().unwrap_or("?")) {
            Ok(())
        } else {
            Err(self.error(&t, &format!("expected `{p}`")))
        }
    }

    fn is_punct(&self, p: &str) -> bool {
        matches!(&self.peek().kind, Kind::Punct(q) if *q == p)
    }

    fn ident(&mut self, wanted: &[&str]) -> Result<(String, Token), String> {
        let t = self.next();
        match &t.kind {
            Kind::Ident(s) if wanted.contains(&s.as_str()) => Ok((s.clone(), t)),
            _ => Err(self.error(
                &t,
                &format!("expected {}", wanted.iter().map(|w| format!("`{w}`")).collect::<Vec<_>>().join(" or ")),
            )),
        }
    }

    /// `ident :: ident :: ...`, each from its list.
    fn path(&mut self, parts: &[&[&str]]) -> Result<Vec<String>, String> {
        let mut out = Vec::new();
        for (k, wanted) in parts.iter().enumerate() {
            if k > 0 {
                self.punct("::")?;
            }
            out.push(self.ident(wanted)?.0);
        }
        Ok(out)
    }

    /// `[-]LITERAL (* [-]LITERAL)*` in f32, as rustc evaluates it.
    fn expr(&mut self) -> Result<f32, String> {
        let mut value = self.factor()?;
        while self.is_punct("*") {
            let at = self.next();
            value *= self.factor()?;
            if !value.is_finite() {
                return Err(self.error(&at, "a product beyond f32's range"));
            }
        }
        Ok(value)
    }

    fn factor(&mut self) -> Result<f32, String> {
        let negative = self.is_punct("-");
        if negative {
            self.next();
        }
        let t = self.next();
        let Kind::Number(text) = &t.kind else { return Err(self.error(&t, "expected a number")) };
        let v: f32 = text.parse().map_err(|_| self.error(&t, "not an f32"))?;
        if !v.is_finite() {
            return Err(self.error(&t, "a number beyond f32's range"));
        }
        Ok(if negative { -v } else { v })
    }

    /// `(EXPR, EXPR, EXPR)` with Rust's optional trailing comma.
    fn three(&mut self) -> Result<[f32; 3], String> {
        self.punct("(")?;
        let mut v = [0.0; 3];
        for (k, c) in v.iter_mut().enumerate() {
            if k > 0 {
                self.punct(",")?;
            }
            *c = self.expr()?;
        }
        if self.is_punct(",") {
            self.next();
        }
        self.punct(")")?;
        Ok(v)
    }

    fn vec3(&mut self) -> Result<[f32; 3], String> {
        let path = self.path(&[&["Vec3"], &["new", "Y"]])?;
        match path[1].as_str() {
            "Y" => Ok([0.0, 1.0, 0.0]),
            _ => self.three(),
        }
    }

    /// `DirectionalLight { ... }` after its name.
    fn directional_light(&mut self, light: &mut SunLight) -> Result<(), String> {
        self.punct("{")?;
        let mut seen: Vec<String> = Vec::new();
        loop {
            if self.is_punct("..") {
                self.next();
                self.ident(&["default"])?;
                self.punct("(")?;
                self.punct(")")?;
                return self.punct("}");
            }
            let t = self.next();
            let Kind::Ident(field) = &t.kind else {
                return Err(self.error(&t, "expected a field of DirectionalLight or `..default()`"));
            };
            if seen.contains(field) {
                return Err(self.error(&t, &format!("`{field}` given twice")));
            }
            seen.push(field.clone());
            self.punct(":")?;
            match field.as_str() {
                "illuminance" => light.illuminance = Some(self.expr()?),
                "color" => {
                    self.path(&[&["Color"], &["linear_rgb"]])?;
                    light.color = Some(self.three()?);
                }
                "shadow_maps_enabled" => {
                    let value = self.ident(&["true", "false"])?.0;
                    light.shadow_maps_enabled = Some(value == "true");
                }
                "shadows_enabled" => {
                    return Err(self.error(
                        &t,
                        "not a field of Bevy 0.19's DirectionalLight (renamed `shadow_maps_enabled` in 0.19)",
                    ));
                }
                _ => return Err(self.error(&t, "not a field these lines set: illuminance, color, shadow_maps_enabled")),
            }
            self.punct(",")?;
        }
    }

    /// `Transform::default().looking_to(VEC, VEC)` after its name.
    fn transform(&mut self, light: &mut SunLight) -> Result<(), String> {
        self.punct("::")?;
        self.ident(&["default"])?;
        self.punct("(")?;
        self.punct(")")?;
        self.punct(".")?;
        self.ident(&["looking_to"])?;
        self.punct("(")?;
        let at = self.peek().clone();
        light.forward = self.vec3()?;
        let f = light.forward;
        let length = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
        if !(length.is_finite() && length > 1e-6) {
            return Err(self.error(&at, "a light direction of zero length (Bevy would shine along -Z)"));
        }
        self.punct(",")?;
        light.up = self.vec3()?;
        if self.is_punct(",") {
            self.next();
        }
        self.punct(")")
    }

    /// `commands.spawn((COMPONENT, COMPONENT));`
    fn statement(&mut self) -> Result<SunLight, String> {
        self.ident(&["commands"])?;
        self.punct(".")?;
        self.ident(&["spawn"])?;
        self.punct("(")?;
        let open = self.peek().clone();
        self.punct("(")?;
        let mut light =
            SunLight { illuminance: None, color: None, shadow_maps_enabled: None, forward: [0.0; 3], up: [0.0; 3] };
        let (mut has_light, mut has_transform) = (false, false);
        loop {
            let (name, t) = self.ident(&["DirectionalLight", "Transform"])?;
            let seen = if name == "DirectionalLight" { &mut has_light } else { &mut has_transform };
            if *seen {
                return Err(
                    self.error(&t, &format!("a second {name} in one entity (Bevy panics on duplicate components)"))
                );
            }
            *seen = true;
            if name == "DirectionalLight" {
                self.directional_light(&mut light)?
            } else {
                self.transform(&mut light)?
            }
            if self.is_punct(",") {
                self.next();
            }
            if self.is_punct(")") {
                break;
            }
        }
        if !(has_light && has_transform) {
            let missing = if has_light { "Transform" } else { "DirectionalLight" };
            return Err(self.error(&open, &format!("the spawned entity has no {missing}")));
        }
        self.punct(")")?;
        self.punct(")")?;
        self.punct(";")?;
        Ok(light)
    }
}

/// The lights of `src` (the lines under "The sun:", `first_line` their first README line).
pub fn parse(src: &str, first_line: usize) -> Result<Vec<SunLight>, String> {
    let mut p = Parser { tokens: tokenize(src, first_line)?, at: 0 };
    let mut lights = Vec::new();
    while p.peek().kind != Kind::End {
        lights.push(p.statement()?);
    }
    if lights.is_empty() {
        return Err("the sun section spawns no light".into());
    }
    Ok(lights)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lines as src/ibl_presets/bevy.rs writes them, with numbers filled in.
    const LINES: &str = "// The sun taken out of the map (park_sun.json); multiply by the same intensity as above.
commands.spawn((
    DirectionalLight { illuminance: 2.500000 * 998.0957, color: Color::linear_rgb(1.100000, 0.900000, -0.000000), shadow_maps_enabled: true, ..default() },
    // a comment
    Transform::default().looking_to(Vec3::new(-0.500000, -0.200000, 0.800000), Vec3::Y),
));
";

    #[test]
    fn reads_the_readmes_lines() {
        let lights = parse(LINES, 40).expect("the README's lines");
        assert_eq!(lights.len(), 1);
        let l = &lights[0];
        assert_eq!(l.illuminance, Some(2.5f32 * 998.0957f32));
        assert_eq!(l.color, Some([1.1, 0.9, -0.0]));
        assert_eq!(l.shadow_maps_enabled, Some(true));
        assert_eq!((l.forward, l.up), ([-0.5, -0.2, 0.8], [0.0, 1.0, 0.0]));
        let readme = format!("hdrflow bake x --for bevy\n\nloading code\n\nThe sun:\n{LINES}");
        assert_eq!(read_readme(&readme), Ok(lights));
    }

    #[test]
    fn refuses_what_it_does_not_know() {
        let cases = [
            ("shadow_maps_enabled: true", "shadows_enabled: true", "renamed"),
            ("998.0957", "998", "integer literal"),
            ("998.0957", "998.0957f32", "not a literal"),
            ("2.500000 * 998.0957", "2.500000 + 998.0957", "unknown character '+'"),
            ("2.500000 * 998.0957", "(2.500000) * 998.0957", "expected a number"),
            (", ..default() }", " }", "expected `,`"),
            (", ..default() }", ", ..Default::default() }", "expected `default`"),
            ("..default() }", "..default(), }", "expected `}`"),
            ("shadow_maps_enabled: true, ", "shadow_maps_enabled: true, illuminance: 1.0, ", "given twice"),
            ("shadow_maps_enabled: true", "contact_shadows_enabled: true", "not a field"),
            ("Color::linear_rgb", "Color::srgb", "expected `linear_rgb`"),
            ("Vec3::Y", "Vec3::X", "expected `new` or `Y`"),
            ("Vec3::new(-0.500000, -0.200000, 0.800000)", "Vec3::new(0.0, 0.0, 0.0)", "zero length"),
            ("Transform::default()", "Transform::IDENTITY", "expected `default`"),
            ("looking_to", "looking_at", "expected `looking_to`"),
            ("commands.spawn((", "commands.spawn(", "expected `(`"),
            ("));", "))", "expected `;`"),
            ("\n    // a comment\n", "\n    /* a comment */\n", "unknown character '/'"),
            ("DirectionalLight {", "PointLight {", "expected `DirectionalLight` or `Transform`"),
        ];
        for (from, to, why) in cases {
            assert!(LINES.contains(from), "{from}");
            let err = parse(&LINES.replacen(from, to, 1), 40).expect_err(to);
            assert!(err.contains(why) && err.starts_with("README line "), "{to}: {err}");
        }
        let renamed = parse(&LINES.replace("shadow_maps_enabled", "shadows_enabled"), 40).expect_err("renamed");
        assert!(renamed.starts_with("README line 42, column 115:"), "{renamed}");
        let no_transform = LINES
            .replace("    Transform::default().looking_to(Vec3::new(-0.500000, -0.200000, 0.800000), Vec3::Y),\n", "");
        assert!(parse(&no_transform, 1).expect_err("no transform").contains("no Transform"));
        let twice = LINES.replace("    // a comment\n", "    Transform::default().looking_to(Vec3::Y, Vec3::Y),\n");
        assert!(parse(&twice, 1).expect_err("two transforms").contains("a second Transform"));
        assert!(parse("// nothing\n", 1).expect_err("empty").contains("no light"));
        assert!(read_readme("no sun here").is_err());
        assert!(read_readme("a\nThe sun:\nb\nThe sun:\nc").expect_err("two").contains("more than one"));
    }
}
