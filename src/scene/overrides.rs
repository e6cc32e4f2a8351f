//! `--set key=value` overrides on the TOML tree, and turning toml errors into one-line messages.

use super::SceneError;

/// Turn a toml error into `file:line:column: message` (line 0 when the error has no position).
pub(crate) fn parse_error(file: &str, text: &str, e: &toml::de::Error) -> SceneError {
    let mut message = e.message().trim().replace('\n', " ");
    let (line, column) = match e.span() {
        Some(span) if !text.is_empty() => {
            let start = span.start.min(text.len());
            let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
            // Name the key when the error points at a `key = value` line's value.
            let key = text[line_start..start].split_once('=').map(|(k, _)| k.trim()).filter(|k| !k.is_empty());
            if let Some(key) = key.filter(|k| !message.contains(*k)) {
                message = format!("`{key}`: {message}");
            }
            (text[..start].matches('\n').count() + 1, start - line_start + 1)
        }
        _ => (0, 0),
    };
    SceneError::Parse { file: file.to_string(), line, column, message }
}

/// Set the dotted `key` (e.g. `material.k_bend`) to `value` parsed as a TOML value (a bare word is a string).
pub(crate) fn apply(table: &mut toml::Table, arg: &str) -> Result<(), SceneError> {
    let fail = |reason: &str| SceneError::Override { arg: arg.to_string(), reason: reason.to_string() };
    let (key, raw) = arg.split_once('=').ok_or_else(|| fail("expected key=value"))?;
    let (key, raw) = (key.trim(), raw.trim());
    if key.is_empty() || key.split('.').any(str::is_empty) {
        return Err(fail("empty key"));
    }
    let value = match toml::from_str::<toml::Table>(&format!("v = {raw}")) {
        Ok(mut t) => t.remove("v").ok_or_else(|| fail("no value"))?,
        Err(_) => toml::Value::String(raw.to_string()),
    };
    let mut parts: Vec<&str> = key.split('.').collect();
    let last = parts.pop().ok_or_else(|| fail("empty key"))?;
    let mut node = table;
    for p in parts {
        let entry = node.entry(p.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
        node = entry.as_table_mut().ok_or_else(|| fail(&format!("`{p}` is not a table")))?;
    }
    node.insert(last.to_string(), value);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sets_numbers_strings_and_new_tables() {
        let mut t: toml::Table = toml::from_str("a = 1\n[material]\nk_bend = 1.0\n").unwrap();
        apply(&mut t, "material.k_bend=2.5").unwrap();
        apply(&mut t, "solver.method=ds").unwrap();
        apply(&mut t, "gravity=[0, -1, 0]").unwrap();
        assert_eq!(t["material"]["k_bend"].as_float(), Some(2.5));
        assert_eq!(t["solver"]["method"].as_str(), Some("ds"));
        assert_eq!(t["gravity"].as_array().map(Vec::len), Some(3));
        assert!(apply(&mut t, "a.b=1").is_err(), "a is a number, not a table");
        assert!(apply(&mut t, "novalue").is_err());
        assert!(apply(&mut t, ".x=1").is_err());
    }
}
