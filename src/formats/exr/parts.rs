//! Which part of a multi-part EXR file is read (`DecodeOptions::part`/`layer`), and its colour
//! primaries.

use ::exr::meta::attribute::Chromaticities;
use ::exr::prelude::MetaData;

use crate::formats::{DecodeOptions, FormatError, Primaries};

pub(super) fn has_colour(names: &[String], prefix: &str) -> bool {
    ["R", "G", "B", "Y"].iter().any(|c| {
        names.iter().any(|n| {
            if prefix.is_empty() {
                n == c || n.ends_with(&format!(".{c}"))
            } else {
                *n == format!("{prefix}.{c}")
            }
        })
    })
}

pub(super) fn part_name(header: &::exr::meta::header::Header) -> String {
    header.own_attributes.layer_name.as_ref().map(|t| t.to_string()).unwrap_or_default()
}

/// Chooses the part (and the channel prefix within it) from the options.
pub(super) fn choose_part(meta: &MetaData, options: &DecodeOptions) -> Result<(usize, String), FormatError> {
    let names =
        |i: usize| -> Vec<String> { meta.headers[i].channels.list.iter().map(|c| c.name.to_string()).collect() };
    let describe = || -> String {
        meta.headers
            .iter()
            .enumerate()
            .map(|(i, h)| {
                format!("part {i} {:?}{}: {}", part_name(h), if h.deep { " (deep)" } else { "" }, names(i).join(", "))
            })
            .collect::<Vec<_>>()
            .join("; ")
    };
    let layer = options.layer.as_deref().filter(|l| !l.is_empty());
    let chosen = if let Some(p) = options.part {
        if p >= meta.headers.len() {
            return Err(FormatError::Invalid(format!("EXR file has no part {p} ({})", describe())));
        }
        match layer {
            Some(l) if part_name(&meta.headers[p]) != l => (p, l.to_string()),
            _ => (p, String::new()),
        }
    } else if let Some(l) = layer {
        if let Some(p) = meta.headers.iter().position(|h| part_name(h) == l) {
            (p, String::new())
        } else if let Some(p) = (0..meta.headers.len()).find(|&p| !meta.headers[p].deep && has_colour(&names(p), l)) {
            (p, l.to_string())
        } else {
            return Err(FormatError::Invalid(format!("EXR file has no part or layer {l:?} ({})", describe())));
        }
    } else {
        match (0..meta.headers.len()).find(|&p| !meta.headers[p].deep && has_colour(&names(p), "")) {
            Some(p) => (p, String::new()),
            None => {
                return Err(FormatError::Invalid(format!(
                    "EXR file has no part with a colour channel (R, G, B or Y) that is not deep data ({})",
                    describe()
                )))
            }
        }
    };
    if meta.headers[chosen.0].deep {
        return Err(FormatError::Invalid(format!("EXR part {} is deep data, which is not supported", chosen.0)));
    }
    Ok(chosen)
}

pub(super) fn chromaticities_of(c: Option<&Chromaticities>) -> Primaries {
    match c {
        Some(c) => Primaries {
            red: [c.red.0 as f64, c.red.1 as f64],
            green: [c.green.0 as f64, c.green.1 as f64],
            blue: [c.blue.0 as f64, c.blue.1 as f64],
            white: [c.white.0 as f64, c.white.1 as f64],
        },
        None => Primaries::REC709,
    }
}
