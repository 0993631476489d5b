//! "Did you mean" hints for names that are close to a known one.

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
    if let Some(&(_, best)) = close.first() {
        let more: Vec<&str> = close.iter().skip(1).take(2).map(|(_, c)| *c).collect();
        if more.is_empty() {
            format!("; did you mean {best:?}?")
        } else {
            format!(
                "; did you mean {best:?} (or {})?",
                more.iter().map(|c| format!("{c:?}")).collect::<Vec<_>>().join(", ")
            )
        }
    } else {
        String::new()
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
    use super::{edit_distance, suggest, suggest_close};

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
}
