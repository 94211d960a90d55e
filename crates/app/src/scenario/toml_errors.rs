//! Where in a scenario file a problem is: byte offsets to line and column, the span of a dotted
//! key path (`rod[1].base.kind`), and one-line explanations of toml/serde errors with the nearest
//! valid name for a typo (strsim). Knows the TOML text only, not what a scenario means.

use std::ops::Range;

/// 1-based line and column of byte offset `at`.
pub fn line_col(source: &str, at: usize) -> (usize, usize) {
    let at = at.min(source.len());
    let before = &source[..at];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// Byte span of the key named by a dotted path with optional `[i]` indices, e.g.
/// `load[1].value`, found by re-parsing the text with spans. Falls back to the nearest enclosing
/// table that exists (a missing key is reported at its table).
pub fn key_span(source: &str, path: &str) -> Option<Range<usize>> {
    use toml_edit::TableLike;
    let doc = toml_edit::ImDocument::parse(source).ok()?;
    let mut best = None;
    let mut table: &dyn TableLike = doc.as_table();
    for part in path.split('.') {
        let (name, index) = match part.split_once('[') {
            Some((n, rest)) => (n, rest.trim_end_matches(']').parse::<usize>().ok()),
            None => (part, None),
        };
        let Some((key, item)) = table.get_key_value(name) else {
            return best;
        };
        best = key.span().or_else(|| item.span()).or(best);
        let next: Option<&dyn TableLike> = match index {
            Some(i) => {
                if let Some(t) = item.as_array_of_tables().and_then(|a| a.get(i)) {
                    best = t.span().or(best);
                    Some(t)
                } else {
                    // `load = [{ ... }, { ... }]`: an inline array of inline tables.
                    item.as_array()
                        .and_then(|a| a.get(i))
                        .and_then(|v| v.as_inline_table())
                        .map(|t| {
                            best = t.span().or(best.clone());
                            t as &dyn TableLike
                        })
                }
            }
            None => item.as_table_like(),
        };
        match next {
            Some(t) => table = t,
            None => return best,
        }
    }
    best
}

/// Turn a toml/serde error into one line: what is wrong and, for an unknown key or kind, the
/// nearest valid name and the full list.
pub(crate) fn explain_toml_error(source: &str, e: &toml::de::Error) -> String {
    let msg = e.message().trim().replace('\n', ": ");
    let found_at = e
        .span()
        .map(|s| source.get(s).unwrap_or("").to_string())
        .unwrap_or_default();
    if let Some(rest) = msg.strip_prefix("unknown field `") {
        let (name, expected) = split_unknown(rest);
        let section = e
            .span()
            .and_then(|s| section_of(source, s.start))
            .unwrap_or_default();
        let head = if section == name {
            format!("unknown section [{name}]")
        } else if section.is_empty() {
            format!("unknown key `{name}` at the top level")
        } else {
            format!("unknown key `{name}` in [{section}]")
        };
        return with_suggestion(head, &name, &expected);
    }
    if let Some(rest) = msg.strip_prefix("unknown variant `") {
        let (name, expected) = split_unknown(rest);
        // Name the key the value was given to (the text before `=` on the value's line).
        let key = e
            .span()
            .and_then(|sp| {
                let line_start = source[..sp.start].rfind('\n').map_or(0, |i| i + 1);
                // The last `name =` before the value (inline tables hold several).
                let (before, _) = source[line_start..sp.start].rsplit_once('=')?;
                let k = before
                    .trim_end()
                    .rsplit(|c: char| c.is_whitespace() || c == '{' || c == ',')
                    .next()?;
                let section = section_of(source, sp.start).unwrap_or_default();
                (!k.is_empty() && k != "kind").then(|| {
                    if section.is_empty() {
                        format!("unknown value \"{name}\" for `{k}`")
                    } else {
                        format!("unknown value \"{name}\" for `{k}` in [{section}]")
                    }
                })
            })
            .unwrap_or_else(|| format!("unknown kind \"{name}\""));
        return with_suggestion(key, &name, &expected);
    }
    if let Some(rest) = msg.strip_prefix("missing field `") {
        let name = rest.trim_end_matches('`');
        let section = e
            .span()
            .and_then(|s| section_of(source, s.start))
            .unwrap_or_default();
        let where_ = if section.is_empty() {
            String::new()
        } else {
            format!(" in [{section}]")
        };
        if found_at.is_empty() || section.is_empty() {
            // Missing whole sections are reported at the top level.
            return format!(
                "missing required {} `{name}`{where_}",
                if section.is_empty() {
                    "section or key"
                } else {
                    "key"
                }
            );
        }
        return format!("missing required key `{name}`{where_}");
    }
    if let Some(header) = e.span().and_then(|s| header_message(source, s.start)) {
        return header;
    }
    let key = e
        .span()
        .and_then(|s| key_at(source, s.start).or_else(|| key_on_line(source, s.start)))
        .map(|k| format!("{k}: "))
        .unwrap_or_default();
    if let Some(found) = float_for_integer(&msg) {
        return format!(
            "{key}expected a whole number (an integer such as 100, without a decimal point or \
             exponent), found {found}"
        );
    }
    if msg.contains("number too large to fit in target type") {
        return format!(
            "{key}the number is too large to fit in an integer (at most 9223372036854775807; \
             the allowed range of this key is far smaller)"
        );
    }
    if let Some(rest) = msg
        .split("did not match any variant of untagged enum ")
        .nth(1)
    {
        let name = rest.split_whitespace().next().unwrap_or("");
        let found = found_at.trim();
        let what = match name {
            "Profile" => {
                "expected a 3-vector [x, y, z], an array of 3-vectors (one per element for \
                          rest_sigma, one per interior node for rest_kappa) or a table \
                          { s = [...], value = [[x, y, z], ...] }"
                    .to_string()
            }
            "EndConfig" => {
                let kinds: Vec<String> = ["free", "pinned", "clamped", "driven"]
                    .map(String::from)
                    .to_vec();
                let hint = nearest(found.trim_matches('"'), &kinds)
                    .map(|k| format!("; did you mean \"{k}\"?"))
                    .unwrap_or_default();
                format!(
                    "expected \"free\", \"pinned\", \"clamped\" or a table {{ kind = \"driven\", times = [...], \
                     displacement = [...], rotation = [...] }}, found {found}{hint}"
                )
            }
            _ => msg.clone(),
        };
        return format!("{key}{what}");
    }
    format!("{key}{msg}")
}

/// Sections that are arrays of tables (`[[load]]`) and sections that are single tables.
const ARRAY_SECTIONS: [&str; 8] = [
    "rod",
    "load",
    "obstacle",
    "plane",
    "cylinder",
    "joint",
    "target",
    "acceptance",
];
const SINGLE_SECTIONS: [&str; 9] = [
    "time",
    "damping",
    "numerics",
    "contact",
    "initial_state",
    "controller",
    "solver",
    "via_path",
    "grasp",
];

/// An error reported at a table header that uses the wrong brackets: `[load]` for the array
/// `[[load]]`, `[[time]]` for the single table `[time]`.
fn header_message(source: &str, at: usize) -> Option<String> {
    let at = at.min(source.len());
    let start = source[..at].rfind('\n').map_or(0, |i| i + 1);
    let end = source[at..].find('\n').map_or(source.len(), |i| at + i);
    let line = source[start..end].split('#').next().unwrap_or("").trim();
    if let Some(inner) = line.strip_prefix("[[") {
        let name = inner.trim_end_matches("]]").trim();
        if SINGLE_SECTIONS.contains(&name) {
            return Some(format!(
                "[[{name}]] must be written [{name}]: a scenario has one [{name}] table, not an \
                 array of them"
            ));
        }
    } else if let Some(inner) = line.strip_prefix('[') {
        let name = inner.trim_end_matches(']').trim();
        if ARRAY_SECTIONS.contains(&name) && name != "rod" {
            return Some(format!(
                "[{name}] must be written [[{name}]]: {name} is an array of tables, one \
                 [[{name}]] table per {name}"
            ));
        }
    }
    None
}

/// `section.key` from the text of the line holding byte `at` (when the file does not parse
/// with spans, e.g. an integer too large for 64 bits).
fn key_on_line(source: &str, at: usize) -> Option<String> {
    let at = at.min(source.len());
    let start = source[..at].rfind('\n').map_or(0, |i| i + 1);
    let end = source[at..].find('\n').map_or(source.len(), |i| at + i);
    let line = source[start..end].trim();
    if line.starts_with('[') {
        return None;
    }
    let (key, _) = line.split_once('=')?;
    let key = key.trim().trim_matches('"');
    if key.is_empty() {
        return None;
    }
    match section_of(source, start) {
        Some(section) if !section.is_empty() => Some(format!("{section}.{key}")),
        _ => Some(key.to_string()),
    }
}

/// The float of "invalid type: floating point `1000000000000000000.0`, expected usize", shown
/// with at most 6 significant digits.
fn float_for_integer(msg: &str) -> Option<String> {
    let rest = msg.split("invalid type: floating point `").nth(1)?;
    let (number, tail) = rest.split_once('`')?;
    let integer = ["usize", "u64", "u32", "u16", "u8", "i64", "i32"]
        .iter()
        .any(|t| tail.trim_start_matches(", expected ").starts_with(t));
    if !integer {
        return None;
    }
    Some(
        number
            .parse::<f64>()
            .map(super::fmt_num)
            .unwrap_or_else(|_| number.to_string()),
    )
}

/// From "name`, expected one of `a`, `b`" get ("name", ["a", "b"]).
pub(crate) fn split_unknown(rest: &str) -> (String, Vec<String>) {
    let (name, tail) = rest.split_once('`').unwrap_or((rest, ""));
    let expected = tail
        .split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect();
    (name.to_string(), expected)
}

fn with_suggestion(head: String, name: &str, expected: &[String]) -> String {
    let list = expected.join(", ");
    match nearest(name, expected) {
        Some(best) => format!("{head}; did you mean `{best}`? (allowed: {list})"),
        None => format!("{head} (allowed: {list})"),
    }
}

/// The candidate closest to `name` by edit distance (strsim's Levenshtein), if it is close
/// enough to be a typo (distance at most a third of the longer name, or one is a prefix of the
/// other).
pub fn nearest<'a>(name: &str, candidates: &'a [String]) -> Option<&'a str> {
    let lower = name.to_lowercase();
    candidates
        .iter()
        .map(|c| (strsim::levenshtein(&lower, &c.to_lowercase()), c))
        .filter(|(d, c)| {
            let longest = lower.chars().count().max(c.chars().count());
            *d * 3 <= longest.max(3) || c.starts_with(&lower) || lower.starts_with(c.as_str())
        })
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c.as_str())
}

/// The `[section]` or `[[section]]` header in force at byte offset `at` (by scanning the text).
fn section_of(source: &str, at: usize) -> Option<String> {
    // Include the line holding `at`: a missing-key error points at its table's header.
    let at = at.min(source.len());
    let end = source[at..].find('\n').map_or(source.len(), |i| at + i);
    let before = &source[..end];
    before.lines().rev().find_map(|line| {
        let t = line.trim();
        if t.starts_with('[') {
            Some(
                t.trim_start_matches('[')
                    .split(']')
                    .next()
                    .unwrap_or("")
                    .trim()
                    .to_string(),
            )
        } else {
            None
        }
    })
}

/// The dotted key whose value contains byte offset `at`, e.g. `rod.length`.
fn key_at(source: &str, at: usize) -> Option<String> {
    let doc = toml_edit::ImDocument::parse(source).ok()?;
    let mut path = Vec::new();
    find_key(doc.as_item(), at, &mut path).then(|| path.join("."))
}

fn find_key(item: &toml_edit::Item, at: usize, path: &mut Vec<String>) -> bool {
    if let Some(aot) = item.as_array_of_tables() {
        for (i, t) in aot.iter().enumerate() {
            let last = path.pop().unwrap_or_default();
            path.push(format!("{last}[{i}]"));
            for (k, v) in t.iter() {
                path.push(k.to_string());
                if leaf_or_inner(v, at, path) {
                    return true;
                }
                path.pop();
            }
            path.pop();
            path.push(last);
        }
        return false;
    }
    if let Some(table) = item.as_table_like() {
        for (k, v) in table.iter() {
            path.push(k.to_string());
            if leaf_or_inner(v, at, path) {
                return true;
            }
            path.pop();
        }
    }
    false
}

/// Tables and arrays of tables are searched inside; any other value matches by its span.
fn leaf_or_inner(v: &toml_edit::Item, at: usize, path: &mut Vec<String>) -> bool {
    if v.is_table_like() || v.is_array_of_tables() {
        find_key(v, at, path)
    } else {
        contains(v.span(), at)
    }
}

fn contains(span: Option<Range<usize>>, at: usize) -> bool {
    span.is_some_and(|s| s.start <= at && at < s.end.max(s.start + 1))
}
