//! Repair of `ros2msg` schema texts written before the dependency blocks were named as rosbag2
//! names them: `MSG: std_msgs/msg/Header` for a field `std_msgs/Header header`. Foxglove's
//! readers resolve a field's type only against a block of exactly its spelling, so such files
//! do not open there; `capsule record recover` rewrites them with [`respell_dependencies`].

use capsule_msgs::interface::field_dependencies;

const SEPARATOR_LEN: usize = 80;

fn is_separator(line: &str) -> bool {
    let line = line.trim_end_matches(['\n', '\r']);
    line.len() == SEPARATOR_LEN && line.bytes().all(|b| b == b'=')
}

/// `pkg/msg/Type` and `pkg/Type` name the same type.
fn normalise(name: &str) -> String {
    match name.split('/').collect::<Vec<_>>()[..] {
        [pkg, "msg", ty] => format!("{pkg}/{ty}"),
        _ => name.to_string(),
    }
}

/// One part of a schema text: the root (no name) or a `MSG:` block.
struct Block<'a> {
    name: Option<&'a str>,
    /// The block's lines after its `MSG:` line (the root: all its lines).
    body: String,
}

fn blocks(text: &str) -> Vec<Block<'_>> {
    let lines: Vec<&str> = text.split_inclusive('\n').collect();
    let mut out = vec![Block {
        name: None,
        body: String::new(),
    }];
    let mut k = 0;
    while k < lines.len() {
        let name = lines
            .get(k + 1)
            .and_then(|l| l.strip_prefix("MSG: "))
            .map(|n| n.trim_end_matches(['\n', '\r']).trim());
        match name {
            Some(name) if is_separator(lines[k]) => {
                out.push(Block {
                    name: Some(name),
                    body: String::new(),
                });
                k += 2;
            }
            _ => {
                if let Some(b) = out.last_mut() {
                    b.body.push_str(lines[k]);
                }
                k += 1;
            }
        }
    }
    out
}

/// Renames the `MSG:` blocks of a `ros2msg` schema text to the spelling the fields use
/// (a block named `pkg/msg/Type` that no field spells so becomes `pkg/Type`; when fields spell
/// one type several ways, the block is repeated under each). `schema_name` is the schema's
/// type (`pkg/msg/Type`), whose package is the root text's. Returns `None` when every
/// referenced block already has its field's spelling (nothing to change).
pub fn respell_dependencies(schema_name: &str, text: &str) -> Option<String> {
    let parts = blocks(text);
    let root_package = schema_name.split('/').next().unwrap_or("");
    // every spelling a field uses, in order of first use
    let mut spelled: Vec<String> = Vec::new();
    for b in &parts {
        let package = b
            .name
            .map(|n| n.split('/').next().unwrap_or(""))
            .unwrap_or(root_package);
        for dep in field_dependencies(&b.body, package) {
            if !spelled.contains(&dep) {
                spelled.push(dep);
            }
        }
    }
    let names: Vec<&str> = parts.iter().filter_map(|b| b.name).collect();
    let mut assigned: Vec<&str> = Vec::new();
    let mut out = String::with_capacity(text.len() + 64);
    let mut extra: Vec<(&str, &str)> = Vec::new();
    for b in &parts {
        let Some(name) = b.name else {
            out.push_str(&b.body);
            continue;
        };
        // spellings of this block's type that fields use and no block has yet
        let missing: Vec<&str> = spelled
            .iter()
            .map(String::as_str)
            .filter(|s| {
                normalise(s) == normalise(name) && !names.contains(s) && !assigned.contains(s)
            })
            .collect();
        assigned.extend(&missing);
        let mut rest = missing.as_slice();
        let mut here = name;
        if !spelled.iter().any(|s| s == name) {
            if let Some((first, more)) = missing.split_first() {
                here = first;
                rest = more;
            }
        }
        push_block(&mut out, here, &b.body);
        extra.extend(rest.iter().map(|s| (*s, b.body.trim_end_matches('\n'))));
    }
    if out == text && extra.is_empty() {
        return None;
    }
    // further spellings after the last block, so the original blocks keep their places
    for (name, body) in extra {
        if !out.ends_with('\n') {
            out.push('\n');
        }
        out.push('\n');
        push_block(&mut out, name, body);
        out.push('\n');
    }
    Some(out)
}

fn push_block(out: &mut String, name: &str, body: &str) {
    out.push_str(&"=".repeat(SEPARATOR_LEN));
    out.push_str("\nMSG: ");
    out.push_str(name);
    out.push('\n');
    out.push_str(body);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::{ros2msg_schema, KNOWN_TYPES};

    /// The schema text as capsule wrote it before: `MSG: pkg/msg/Type` blocks.
    fn old_spelling(text: &str) -> String {
        text.replace("MSG: std_msgs/Header", "MSG: std_msgs/msg/Header")
            .replace(
                "MSG: builtin_interfaces/Time",
                "MSG: builtin_interfaces/msg/Time",
            )
            .replace(
                "MSG: service_msgs/ServiceEventInfo",
                "MSG: service_msgs/msg/ServiceEventInfo",
            )
            .replace("MSG: capsule_msgs/SetMode", "MSG: capsule_msgs/msg/SetMode")
    }

    #[test]
    fn old_texts_get_the_current_spelling_and_current_texts_stay() {
        for t in KNOWN_TYPES {
            let now = ros2msg_schema(t).unwrap_or_default();
            assert_eq!(respell_dependencies(t, &now), None, "{t}");
            let old = old_spelling(&now);
            assert_ne!(old, now, "{t}");
            assert_eq!(respell_dependencies(t, &old).as_deref(), Some(now.as_str()));
        }
    }

    #[test]
    fn two_spellings_of_one_type_get_one_block_each() {
        let sep = "=".repeat(80);
        let text = format!(
            "pkg/msg/Thing a\nThing b\n\n{sep}\nMSG: pkg/msg/Thing\nint8 x\n\n{sep}\nMSG: other/msg/Unused\nint8 y\n"
        );
        assert_eq!(
            respell_dependencies("pkg/msg/Two", &text),
            Some(format!("{text}\n{sep}\nMSG: pkg/Thing\nint8 x\n"))
        );
        // a block no field names keeps its name; text without blocks is left alone
        assert_eq!(respell_dependencies("pkg/msg/One", "int8 z\n"), None);
    }
}
