//! "Did you mean" hints for names that are close to a known one (by edit distance), and for a
//! field named by a common alias of one of the operator's fields (`image` for Project's `env`).

/// "; did you mean X?" for close candidates (case-insensitive, edit distance at most 2, or
/// a third of the name), else " (WHAT: ...)" listing them all, or "" when there are none.
pub fn suggest(name: &str, candidates: &[&str], what: &str) -> String {
    match suggest_close(name, candidates) {
        close if !close.is_empty() => close,
        _ if candidates.is_empty() => String::new(),
        _ if candidates.len() <= 24 => format!(" ({what}: {})", candidates.join(", ")),
        _ => format!(" ({what}: {}, ... {} in all)", candidates[..24].join(", "), candidates.len()),
    }
}

/// `"; did you mean ..."` when a candidate is close to `name` (a few edits, or a prefix),
/// else nothing: for messages that list the candidates themselves.
pub fn suggest_close(name: &str, candidates: &[&str]) -> String {
    let lower = name.to_lowercase();
    let limit = 2.max(name.chars().count() / 3);
    let mut close: Vec<(usize, &str)> = candidates
        .iter()
        .map(|c| {
            let cl = c.to_lowercase();
            // A prefix typed short ("lumi" for "luminance") is as close as one edit.
            let d = if !lower.is_empty() && cl.starts_with(&lower) { 1 } else { edit_distance(&cl, &lower) };
            (d, *c)
        })
        .filter(|(d, _)| *d <= limit)
        .collect();
    close.sort();
    did_you_mean_one_of(&close.iter().map(|&(_, c)| c).collect::<Vec<_>>())
}

/// Names a newcomer writes for the same field: the first group holds what an operator calls
/// the image it reads (`image`, `env`, `input`, ...), the second what a saver calls its file.
const FIELD_ALIASES: &[&[&str]] = &[
    &["image", "env", "input", "map", "envmap", "environment", "img", "src", "source", "in"],
    &["path", "file", "filename", "output", "out"],
];

/// [`suggest`] for an unknown field of an operator with `fields`: fields close by edit distance,
/// else fields that are a common alias of `name` ([`FIELD_ALIASES`]: `image` for `env`, however
/// far apart the spellings), else the list of fields.
pub fn suggest_field(name: &str, fields: &[&str]) -> String {
    let close = suggest_close(name, fields);
    if !close.is_empty() {
        return close;
    }
    let lower = name.to_lowercase();
    let aliases: Vec<&str> = FIELD_ALIASES
        .iter()
        .filter(|group| group.contains(&lower.as_str()))
        .flat_map(|group| fields.iter().copied().filter(|f| group.contains(f)))
        .collect();
    if aliases.is_empty() {
        suggest(name, fields, "fields")
    } else {
        did_you_mean_one_of(&aliases)
    }
}

/// `"; did you mean "a"?"` or `"; did you mean "a" (or "b", "c")?"` for the first three of
/// `names`, best first; "" when there are none.
fn did_you_mean_one_of(names: &[&str]) -> String {
    match names {
        [] => String::new(),
        [best] => format!("; did you mean {best:?}?"),
        [best, more @ ..] => format!(
            "; did you mean {best:?} (or {})?",
            more.iter().take(2).map(|c| format!("{c:?}")).collect::<Vec<_>>().join(", ")
        ),
    }
}

/// Only the "; did you mean X?" part of [`suggest`] (or "" when nothing is close).
pub(super) fn did_you_mean(name: &str, candidates: &[&str]) -> String {
    let hint = suggest(name, candidates, "");
    if hint.starts_with(';') {
        hint
    } else {
        String::new()
    }
}

/// Levenshtein distance in characters, for "did you mean" hints.
fn edit_distance(a: &str, b: &str) -> usize {
    strsim::levenshtein(a, b)
}

#[cfg(test)]
mod tests {
    use super::{edit_distance, suggest, suggest_close, suggest_field};

    #[test]
    fn edit_distance_counts_edits() {
        assert_eq!(edit_distance("loadhdr", "loadhdr"), 0);
        assert_eq!(edit_distance("loadhrd", "loadhdr"), 2);
        assert_eq!(edit_distance("", "abc"), 3);
    }

    #[test]
    fn suggestions_name_the_closest() {
        assert_eq!(suggest("pth", &["path", "flip_vertical"], "fields"), "; did you mean \"path\"?");
        assert_eq!(suggest("zzzzzz", &["path"], "fields"), " (fields: path)");
        // A message that lists the choices itself does not list them twice.
        assert_eq!(suggest_close("Filmic", &["Reinhard", "Aces", "Agx"]), "");
        assert_eq!(suggest_close("Acse", &["Reinhard", "Aces", "Agx"]), "; did you mean \"Aces\"?");
    }

    #[test]
    fn an_unknown_field_suggests_a_common_alias_however_far_its_spelling() {
        let project = ["env", "width", "height", "fov", "yaw", "pitch", "roll", "model", "filter"];
        assert_eq!(suggest_field("image", &project), "; did you mean \"env\"?");
        assert_eq!(suggest_field("Image", &project), "; did you mean \"env\"?");
        assert_eq!(suggest_field("file", &["input", "path", "half"]), "; did you mean \"path\"?");
        assert_eq!(suggest_field("image", &["input", "path", "half"]), "; did you mean \"input\"?");
        // Edit distance first: a close field wins over an alias.
        assert_eq!(suggest_field("envv", &["env", "image"]), "; did you mean \"env\"?");
        // Neither close nor an alias: the fields are listed.
        assert_eq!(suggest_field("zzzzzz", &["path"]), " (fields: path)");
    }
}
