//! Map a field path such as `bodies[0].mass_kg` back to a line and column of the scene text, so
//! that validation errors (which run on the typed scene) can still point into the file.

use toml::Spanned;
use toml::de::{DeTable, DeValue};

use super::error::{SceneError, SceneOrigin};

/// 1-based line and column of a byte offset.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// Turn a toml/serde error into a [`SceneError`] at the span it reports.
pub fn from_toml_error(err: &toml::de::Error, text: &str, origin: &SceneOrigin) -> SceneError {
    let position = err.span().map(|s| line_col(text, s.start));
    // serde's messages are already specific ("unknown field `x`, expected one of …",
    // "invalid type: string \"a\", expected f32"); keep them on one line and add the field.
    let message = err.message().trim().replace('\n', " ");
    let field = err
        .span()
        .and_then(|s| path_at(text, s.start))
        .unwrap_or_default();
    SceneError {
        origin: origin.clone(),
        position,
        field,
        message,
    }
}

/// The field path of the deepest key or value whose text contains byte `offset`.
pub fn path_at(text: &str, offset: usize) -> Option<String> {
    let root: Spanned<DeTable<'_>> = DeTable::parse(text).ok()?;
    let mut best = None;
    walk_table(root.get_ref(), "", offset, &mut best);
    best
}

fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_owned()
    } else {
        format!("{prefix}.{key}")
    }
}

fn walk_table(t: &DeTable<'_>, prefix: &str, offset: usize, best: &mut Option<String>) {
    for (k, v) in t.iter() {
        let path = join(prefix, k.get_ref());
        if k.span().contains(&offset) {
            *best = Some(path.clone());
        }
        walk_value(v, &path, offset, best);
    }
}

fn walk_value(v: &Spanned<DeValue<'_>>, path: &str, offset: usize, best: &mut Option<String>) {
    if v.span().contains(&offset) {
        *best = Some(path.to_owned());
    }
    match v.get_ref() {
        DeValue::Table(t) => walk_table(t, path, offset, best),
        DeValue::Array(a) => {
            for (i, item) in a.iter().enumerate() {
                walk_value(item, &format!("{path}[{i}]"), offset, best);
            }
        }
        _ => {}
    }
}

enum Segment<'a> {
    Key(&'a str),
    Index(usize),
}

fn segments(path: &str) -> Vec<Segment<'_>> {
    let mut out = Vec::new();
    for part in path.split('.') {
        let (key, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        if !key.is_empty() {
            out.push(Segment::Key(key));
        }
        while let Some(close) = rest.find(']') {
            if let Ok(i) = rest[1..close].parse() {
                out.push(Segment::Index(i));
            }
            rest = &rest[close + 1..];
        }
    }
    out
}

/// Position of the value at `path`, or of its deepest ancestor present in the text (a defaulted
/// field has no text of its own, so the table that omits it is the best place to point at).
pub fn position_of(text: &str, path: &str) -> Option<(usize, usize)> {
    let root: Spanned<DeTable<'_>> = DeTable::parse(text).ok()?;
    let mut span = None::<std::ops::Range<usize>>;
    let mut table: Option<&DeTable<'_>> = Some(root.get_ref());
    let mut value: Option<&DeValue<'_>> = None;
    for seg in segments(path) {
        let next: Option<&Spanned<DeValue<'_>>> = match (seg, table, value) {
            (Segment::Key(k), Some(t), _) => t.get(k),
            (Segment::Index(i), _, Some(DeValue::Array(a))) => a.get(i),
            _ => None,
        };
        let Some(next) = next else { break };
        span = Some(next.span());
        value = Some(next.get_ref());
        table = match next.get_ref() {
            DeValue::Table(t) => Some(t),
            _ => None,
        };
    }
    span.map(|s| line_col(text, s.start))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_nested_array_values() {
        let text =
            "name = \"x\"\n[[bodies]]\nname = \"a\"\n[[bodies]]\nname = \"b\"\nmass_kg = -1\n";
        assert_eq!(position_of(text, "bodies[1].mass_kg"), Some((6, 11)));
        // A missing field points at its table.
        assert_eq!(position_of(text, "bodies[0].mass_kg").map(|p| p.0), Some(2));
        let at = text.find("-1").unwrap_or(0);
        assert_eq!(path_at(text, at).as_deref(), Some("bodies[1].mass_kg"));
    }
}
