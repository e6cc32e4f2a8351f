//! Dotted keys on the TOML tree: `--set key=value` overrides, reading a number back by its key, and
//! turning toml errors into one-line messages.

use super::{Scene, SceneError};

impl Scene {
    /// Its numbers, to be read by dotted key (the scene is written as TOML once, here).
    pub fn numbers(&self) -> SceneNumbers {
        SceneNumbers(toml::Value::try_from(self).ok())
    }
}

/// A scene's values as a TOML tree, read number by number ([`Scene::numbers`]).
#[derive(Debug, Clone)]
pub struct SceneNumbers(Option<toml::Value>);

impl SceneNumbers {
    /// The number at the dotted `key` (`material.k_bend`, `gravity[1]`), or `None` where the scene
    /// leaves it out (an absent optional value) or holds no number there.
    pub fn get(&self, key: &str) -> Option<f64> {
        let mut node = self.0.as_ref()?;
        for part in key.split('.') {
            match part.split_once('[') {
                Some((name, index)) => {
                    let index: usize = index.strip_suffix(']')?.parse().ok()?;
                    node = node.get(name)?.get(index)?;
                }
                None => node = node.get(part)?,
            }
        }
        match node {
            toml::Value::Integer(i) => Some(*i as f64),
            toml::Value::Float(x) => Some(*x),
            _ => None,
        }
    }
}

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

/// A deserialisation error of the overridden scene: blame the `--set` argument whose key it concerns,
/// or else the file (with its line, found by parsing the file alone, when the file itself is wrong).
pub(crate) fn typed_error(
    file: &str,
    text: &str,
    overrides: &[String],
    e: serde_path_to_error::Error<toml::de::Error>,
) -> SceneError {
    let path = e.path().to_string();
    let message = e.inner().message().trim().replace('\n', " ");
    let related = |key: &str| {
        let within = |outer: &str, inner: &str| {
            inner == outer || inner.strip_prefix(outer).is_some_and(|rest| rest.starts_with(['.', '[']))
        };
        path != "." && (within(key, &path) || within(&path, key))
    };
    if let Some(arg) = overrides.iter().find(|a| related(a.split_once('=').map_or(a.as_str(), |(k, _)| k.trim()))) {
        return SceneError::Override { arg: arg.clone(), reason: format!("`{path}`: {message}") };
    }
    match toml::from_str::<super::Scene>(text) {
        Err(e) => parse_error(file, text, &e),
        Ok(_) => SceneError::Invalid { file: file.to_string(), key: path, reason: message },
    }
}

/// Set the dotted `key` (e.g. `material.k_bend`) to `value` parsed as a TOML value. A bare word is a
/// string; something that looks like TOML but does not parse (`[1`, `"abc`) is refused.
pub(crate) fn apply(table: &mut toml::Table, arg: &str) -> Result<(), SceneError> {
    let fail = |reason: &str| SceneError::Override { arg: arg.to_string(), reason: reason.to_string() };
    let (key, raw) = arg.split_once('=').ok_or_else(|| fail("expected key=value"))?;
    let (key, raw) = (key.trim(), raw.trim());
    if key.is_empty() || key.split('.').any(str::is_empty) {
        return Err(fail("empty key"));
    }
    if raw.is_empty() {
        return Err(fail("no value (write key=\"\" for an empty string)"));
    }
    let value = match toml::from_str::<toml::Table>(&format!("v = {raw}")) {
        Ok(mut t) if t.len() == 1 => t.remove("v").ok_or_else(|| fail("no value"))?,
        Ok(_) => return Err(fail("expected one value")),
        Err(e) if raw.contains(['[', ']', '{', '}', '"', '\'', '=', '\n']) => {
            let why = e.message().trim().replace('\n', " ");
            return Err(fail(&format!("not a TOML value ({why}); quote strings, e.g. key=\"text\"")));
        }
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

    #[test]
    fn numbers_are_read_back_by_their_dotted_keys() {
        let text = "name = \"t\"\ngravity = [0, -2.5, 0]\n[mesh.grid]\nsize = [1.0, 0.1]\nsegments = [4, 1]\n\
                    [material]\nk_bend = 3.0\n[solver]\nmethod = \"rigid\"\nmodes = 5\n";
        let numbers = toml::from_str::<Scene>(text).unwrap().numbers();
        assert_eq!(numbers.get("material.k_bend"), Some(3.0));
        assert_eq!(numbers.get("solver.modes"), Some(5.0), "integers too");
        assert_eq!(numbers.get("gravity[1]"), Some(-2.5));
        assert_eq!(numbers.get("solver.step"), None, "left out: the method's default");
        assert_eq!(numbers.get("solver.method"), None, "not a number");
        assert_eq!((numbers.get("gravity[3]"), numbers.get("material.nothing")), (None, None));
    }

    #[test]
    fn malformed_values_are_refused_not_taken_as_strings() {
        let mut t = toml::Table::new();
        for arg in ["name=[1", "name=1]", "name=\"abc", "name={a = 1", "name=a=b", "name=", "name=1\nx = 2"] {
            match apply(&mut t, arg) {
                Err(SceneError::Override { arg: a, .. }) => assert_eq!(a, arg),
                other => panic!("{arg:?}: {other:?}"),
            }
        }
        assert!(t.is_empty(), "nothing was set: {t:?}");
        apply(&mut t, "name=\"[1\"").unwrap();
        apply(&mut t, "description=two words").unwrap();
        assert_eq!(t["name"].as_str(), Some("[1"));
        assert_eq!(t["description"].as_str(), Some("two words"));
    }
}
