//! The TOML reader: syntax errors with their line, shape errors with the dotted path of the key.

use super::error::{Fault, Invalid};

/// Reads a scene text into `T` (the scene's tables, or another reader's, such as the nodes'
/// `[node]`): a syntax error first, then a key the format does not have or a value of the wrong
/// type, with the dotted path of the key and the line.
pub fn read_toml<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, Invalid> {
    let line = |span: Option<std::ops::Range<usize>>| {
        span.map(|r| text[..r.start.min(text.len())].matches('\n').count() + 1)
    };
    // Syntax first (a key given twice is a syntax error of TOML), then the shape with the path
    // of the offending key. The text is parsed as a plain table only when reading it into `T`
    // fails: both parse with the same parser, so a text that reads has no syntax error (and a
    // scene is read without parsing it twice).
    let read = serde_path_to_error::deserialize(toml::Deserializer::new(text));
    if read.is_err() {
        text.parse::<toml::Table>().map_err(|e| {
            Invalid::new(
                "(syntax)",
                Fault::Syntax {
                    message: e.message().trim().to_string(),
                    line: line(e.span()),
                },
            )
        })?;
    }
    read.map_err(|e: serde_path_to_error::Error<toml::de::Error>| {
        let path = e.path().to_string();
        let inner = e.inner();
        // serde names the reader's own types: a user wrote a table
        let mut message = inner.message().trim().to_string();
        // (the readers' table types are all named `...Spec`, the file's `Raw...`)
        while let Some(at) = message.find("struct ") {
            let name_len = message[at + 7..]
                .find(|c: char| !c.is_alphanumeric() && c != '_')
                .unwrap_or(message.len() - at - 7);
            let name = &message[at + 7..at + 7 + name_len];
            if !(name.ends_with("Spec") || name.starts_with("Raw")) {
                break;
            }
            message.replace_range(at..at + 7 + name_len, "a table");
        }
        Invalid::new(
            if path == "." {
                "(top level)".to_string()
            } else {
                path
            },
            Fault::Shape {
                message,
                line: line(inner.span()),
            },
        )
    })
}
