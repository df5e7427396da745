//! Job files of `tests/data/jobs`, shared with the scripts of `tools/`:
//! templates whose `@KEY@` placeholders stand for the paths and sizes a
//! test chooses.

/// The text of `tests/data/jobs/NAME` with each `@KEY@` of `values`
/// replaced by its value. Panics if a key does not occur or a placeholder is
/// left unfilled, so a template and its callers cannot drift apart.
pub fn job_fixture(name: &str, values: &[(&str, &str)]) -> String {
    let path = super::cli::data("jobs").join(name);
    let mut text =
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    for (key, value) in values {
        let key = format!("@{key}@");
        assert!(text.contains(&key), "{name} has no {key}");
        text = text.replace(&key, value);
    }
    if let Some(left) = placeholder(&text) {
        panic!("{name}: {left} is not filled in");
    }
    text
}

/// The first `@KEY@` (capitals, digits and `_`) of `text`. A step reference
/// such as `"@filled"` is none: it is lower case and not closed by `@`.
fn placeholder(text: &str) -> Option<&str> {
    let b = text.as_bytes();
    let mut i = 0;
    while let Some(at) = text[i..].find('@') {
        let start = i + at;
        let mut end = start + 1;
        while end < b.len()
            && (b[end].is_ascii_uppercase() || b[end].is_ascii_digit() || b[end] == b'_')
        {
            end += 1;
        }
        if end > start + 1 && end < b.len() && b[end] == b'@' {
            return Some(&text[start..=end]);
        }
        i = start + 1;
    }
    None
}
