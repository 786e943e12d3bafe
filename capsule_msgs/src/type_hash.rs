//! REP-2016 type hashes (`RIHS01_` + SHA-256) of interface files, computed the way ROS 2's
//! `rosidl_generator_type_description` computes them, from `.msg`, `.srv` and `.action` texts.
//!
//! Each type becomes an individual description: its full name (`pkg/msg/Name`) and its fields,
//! each with a type id (REP-2016's `FieldType` constants), an array capacity, a string capacity
//! and the full name of a nested type. Constants and default values are not part of it. The hash
//! of a type is the SHA-256 of the JSON of its description followed by the descriptions of every
//! type it references, directly or not, sorted by name, written with `", "` and `": "` as
//! separators. A service `pkg/srv/S` is a type of three fields (`request_message`,
//! `response_message`, `event_message`), an action `pkg/action/A` one of six; their parts are
//! types of their own (`S_Request`, `S_Event`, `A_SendGoal`, ...), as rosidl defines them.
//!
//! No I/O and no dependency but SHA-256: `build.rs` includes this file to compute the table of
//! hashes that [`crate::hashes`] serves, and the crate's tests include it to check it.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use sha2::{Digest, Sha256};

/// REP-2016's prefix of a version-1 hash.
pub const RIHS01_PREFIX: &str = "RIHS01_";

/// A field of an individual type description.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    /// The field's name.
    pub name: String,
    /// REP-2016 `FieldType.type_id`: the element type, plus 48 (array), 96 (bounded sequence) or
    /// 144 (unbounded sequence).
    pub type_id: u8,
    /// The array's size, or the bounded sequence's bound (0 otherwise).
    pub capacity: u64,
    /// The bound of a bounded string (0 otherwise).
    pub string_capacity: u64,
    /// The full name of a nested type (`std_msgs/msg/Header`), empty for a primitive.
    pub nested_type_name: String,
}

/// Individual type descriptions by full type name: everything a hash needs.
#[derive(Debug, Clone, Default)]
pub struct Interfaces {
    types: BTreeMap<String, Vec<Field>>,
}

/// Why an interface text or a hash request was refused.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HashError(pub String);

impl std::fmt::Display for HashError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for HashError {}

fn err<T>(message: String) -> Result<T, HashError> {
    Err(HashError(message))
}

// REP-2016 FieldType ids of the element types.
const NESTED: u8 = 1;
const BOUNDED_STRING: u8 = 21;
const BOUNDED_WSTRING: u8 = 22;
const ARRAY: u8 = 48;
const BOUNDED_SEQUENCE: u8 = 96;
const UNBOUNDED_SEQUENCE: u8 = 144;

/// The FieldType id of a `.msg` primitive (rosidl maps `char` to `uint8`, `byte` to `octet`).
fn primitive_id(name: &str) -> Option<u8> {
    Some(match name {
        "int8" => 2,
        "uint8" | "char" => 3,
        "int16" => 4,
        "uint16" => 5,
        "int32" => 6,
        "uint32" => 7,
        "int64" => 8,
        "uint64" => 9,
        "float32" => 10,
        "float64" => 11,
        "bool" => 15,
        "byte" => 16,
        "string" => 17,
        "wstring" => 18,
        _ => return None,
    })
}

impl Interfaces {
    /// No types yet.
    pub fn new() -> Interfaces {
        Interfaces::default()
    }

    /// Adds one interface file's text: `kind` is `msg`, `srv` or `action`.
    pub fn add(
        &mut self,
        package: &str,
        kind: &str,
        name: &str,
        text: &str,
    ) -> Result<(), HashError> {
        let full = format!("{package}/{kind}/{name}");
        match kind {
            "msg" => self.add_message(&full, package, text),
            "srv" => {
                let parts = split_parts(text);
                let [request, response] = parts.as_slice() else {
                    return err(format!(
                        "{full}: a service has 2 parts, found {}",
                        parts.len()
                    ));
                };
                self.add_service(&full, package, request, response)
            }
            "action" => {
                let parts = split_parts(text);
                let [goal, result, feedback] = parts.as_slice() else {
                    return err(format!(
                        "{full}: an action has 3 parts, found {}",
                        parts.len()
                    ));
                };
                self.add_action(&full, package, goal, result, feedback)
            }
            _ => err(format!("{full}: unknown interface kind `{kind}`")),
        }
    }

    /// The full names of every type known, sorted.
    pub fn type_names(&self) -> impl Iterator<Item = &str> {
        self.types.keys().map(String::as_str)
    }

    /// The fields of a type, if known.
    pub fn fields(&self, type_name: &str) -> Option<&[Field]> {
        self.types.get(type_name).map(Vec::as_slice)
    }

    fn add_message(&mut self, full: &str, package: &str, text: &str) -> Result<(), HashError> {
        let fields = parse_fields(text, package).map_err(|e| HashError(format!("{full}: {e}")))?;
        self.insert(full, fields);
        Ok(())
    }

    fn insert(&mut self, full: &str, mut fields: Vec<Field>) {
        if fields.is_empty() {
            // rosidl gives an empty structure one member
            fields.push(primitive_field("structure_needs_at_least_one_member", 3));
        }
        self.types.insert(full.to_string(), fields);
    }

    fn add_service(
        &mut self,
        full: &str,
        package: &str,
        request: &str,
        response: &str,
    ) -> Result<(), HashError> {
        self.add_message(&format!("{full}_Request"), package, request)?;
        self.add_message(&format!("{full}_Response"), package, response)?;
        self.add_service_of(full)
    }

    /// The service type and its event message, over `{full}_Request` and `{full}_Response`.
    fn add_service_of(&mut self, full: &str) -> Result<(), HashError> {
        let (request, response) = (format!("{full}_Request"), format!("{full}_Response"));
        let event = format!("{full}_Event");
        self.insert(
            &event,
            vec![
                nested_field("info", "service_msgs/msg/ServiceEventInfo"),
                Field {
                    capacity: 1,
                    type_id: BOUNDED_SEQUENCE + NESTED,
                    ..nested_field("request", &request)
                },
                Field {
                    capacity: 1,
                    type_id: BOUNDED_SEQUENCE + NESTED,
                    ..nested_field("response", &response)
                },
            ],
        );
        self.insert(
            full,
            vec![
                nested_field("request_message", &request),
                nested_field("response_message", &response),
                nested_field("event_message", &event),
            ],
        );
        Ok(())
    }

    fn add_action(
        &mut self,
        full: &str,
        package: &str,
        goal: &str,
        result: &str,
        feedback: &str,
    ) -> Result<(), HashError> {
        let part = |suffix: &str| format!("{full}_{suffix}");
        self.add_message(&part("Goal"), package, goal)?;
        self.add_message(&part("Result"), package, result)?;
        self.add_message(&part("Feedback"), package, feedback)?;
        let uuid = "unique_identifier_msgs/msg/UUID";
        let send_goal = part("SendGoal");
        self.insert(
            &format!("{send_goal}_Request"),
            vec![
                nested_field("goal_id", uuid),
                nested_field("goal", &part("Goal")),
            ],
        );
        self.insert(
            &format!("{send_goal}_Response"),
            vec![
                primitive_field("accepted", 15),
                nested_field("stamp", "builtin_interfaces/msg/Time"),
            ],
        );
        self.add_service_of(&send_goal)?;
        let get_result = part("GetResult");
        self.insert(
            &format!("{get_result}_Request"),
            vec![nested_field("goal_id", uuid)],
        );
        self.insert(
            &format!("{get_result}_Response"),
            vec![
                primitive_field("status", 2),
                nested_field("result", &part("Result")),
            ],
        );
        self.add_service_of(&get_result)?;
        self.insert(
            &part("FeedbackMessage"),
            vec![
                nested_field("goal_id", uuid),
                nested_field("feedback", &part("Feedback")),
            ],
        );
        self.insert(
            full,
            vec![
                nested_field("goal", &part("Goal")),
                nested_field("result", &part("Result")),
                nested_field("feedback", &part("Feedback")),
                nested_field("send_goal_service", &send_goal),
                nested_field("get_result_service", &get_result),
                nested_field("feedback_message", &part("FeedbackMessage")),
            ],
        );
        Ok(())
    }

    /// The JSON that is hashed: the type's description, then those it references, sorted.
    pub fn hashable_json(&self, type_name: &str) -> Result<String, HashError> {
        let Some(top) = self.types.get(type_name) else {
            return err(format!("unknown type `{type_name}`"));
        };
        let mut referenced = BTreeSet::new();
        let mut queue: Vec<&str> = nested_names(top).collect();
        while let Some(name) = queue.pop() {
            if referenced.insert(name) {
                let Some(fields) = self.types.get(name) else {
                    return err(format!(
                        "`{type_name}` references `{name}`, whose definition is missing"
                    ));
                };
                queue.extend(nested_names(fields));
            }
        }
        let mut out = String::from("{\"type_description\": ");
        write_individual(&mut out, type_name, top);
        out.push_str(", \"referenced_type_descriptions\": [");
        for (i, name) in referenced.iter().enumerate() {
            if i > 0 {
                out.push_str(", ");
            }
            write_individual(&mut out, name, &self.types[*name]);
        }
        out.push_str("]}");
        Ok(out)
    }

    /// The `RIHS01_...` hash of a type by its full name.
    pub fn hash(&self, type_name: &str) -> Result<String, HashError> {
        let json = self.hashable_json(type_name)?;
        let digest = Sha256::digest(json.as_bytes());
        let mut out = String::from(RIHS01_PREFIX);
        for byte in digest {
            let _ = write!(out, "{byte:02x}");
        }
        Ok(out)
    }
}

fn nested_names(fields: &[Field]) -> impl Iterator<Item = &str> {
    fields
        .iter()
        .map(|f| f.nested_type_name.as_str())
        .filter(|n| !n.is_empty())
}

fn primitive_field(name: &str, type_id: u8) -> Field {
    Field {
        name: name.to_string(),
        type_id,
        capacity: 0,
        string_capacity: 0,
        nested_type_name: String::new(),
    }
}

fn nested_field(name: &str, type_name: &str) -> Field {
    Field {
        nested_type_name: type_name.to_string(),
        ..primitive_field(name, NESTED)
    }
}

fn write_json_string(out: &mut String, s: &str) {
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 || !c.is_ascii() => {
                let mut buf = [0u16; 2];
                for unit in c.encode_utf16(&mut buf) {
                    let _ = write!(out, "\\u{unit:04x}");
                }
            }
            c => out.push(c),
        }
    }
    out.push('"');
}

fn write_individual(out: &mut String, name: &str, fields: &[Field]) {
    out.push_str("{\"type_name\": ");
    write_json_string(out, name);
    out.push_str(", \"fields\": [");
    for (i, f) in fields.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        out.push_str("{\"name\": ");
        write_json_string(out, &f.name);
        let _ = write!(
            out,
            ", \"type\": {{\"type_id\": {}, \"capacity\": {}, \"string_capacity\": {}, \"nested_type_name\": ",
            f.type_id, f.capacity, f.string_capacity
        );
        write_json_string(out, &f.nested_type_name);
        out.push_str("}}");
    }
    out.push_str("]}");
}

/// The parts of a `.srv` (2) or `.action` (3) text, split at its `---` lines.
pub fn split_parts(text: &str) -> Vec<String> {
    let mut parts = vec![String::new()];
    for line in text.lines() {
        if line.trim() == "---" {
            parts.push(String::new());
        } else if let Some(last) = parts.last_mut() {
            last.push_str(line);
            last.push('\n');
        }
    }
    parts
}

/// The fields of a `.msg` text (constants and comments left out) in package `package`.
fn parse_fields(text: &str, package: &str) -> Result<Vec<Field>, String> {
    let mut fields = Vec::new();
    for (number, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let (ty, rest) = line
            .split_once(char::is_whitespace)
            .ok_or_else(|| format!("line {}: `{line}` has no field name", number + 1))?;
        let rest = rest.trim();
        // `TYPE NAME=VALUE` (spaces allowed around `=`) is a constant; `TYPE name "a=b"` is a
        // field with a default value
        if let Some((before, _)) = rest.split_once('=') {
            if !before.trim().contains(char::is_whitespace) {
                continue;
            }
        }
        let name = rest.split_whitespace().next().unwrap_or("");
        let field = parse_field(name, ty, package)
            .map_err(|e| format!("line {}: `{line}`: {e}", number + 1))?;
        fields.push(field);
    }
    Ok(fields)
}

/// One field from its name and its type as a `.msg` file spells it.
fn parse_field(name: &str, ty: &str, package: &str) -> Result<Field, String> {
    let (element, offset, capacity) = match ty.split_once('[') {
        None => (ty, 0, 0),
        Some((element, bracket)) => {
            let inner = bracket
                .strip_suffix(']')
                .ok_or_else(|| format!("unclosed `[` in `{ty}`"))?;
            if inner.is_empty() {
                (element, UNBOUNDED_SEQUENCE, 0)
            } else if let Some(bound) = inner.strip_prefix("<=") {
                (element, BOUNDED_SEQUENCE, parse_bound(bound)?)
            } else {
                (element, ARRAY, parse_bound(inner)?)
            }
        }
    };
    let mut field = primitive_field(name, 0);
    field.capacity = capacity;
    if let Some((base, bound)) = element.split_once("<=") {
        field.type_id = match base {
            "string" => BOUNDED_STRING,
            "wstring" => BOUNDED_WSTRING,
            _ => return Err(format!("only strings take a bound, not `{base}`")),
        };
        field.string_capacity = parse_bound(bound)?;
    } else if let Some(id) = primitive_id(element) {
        field.type_id = id;
    } else {
        field.type_id = NESTED;
        field.nested_type_name = full_type_name(element, package)?;
    }
    field.type_id += offset;
    Ok(field)
}

fn parse_bound(text: &str) -> Result<u64, String> {
    text.parse().map_err(|_| format!("`{text}` is not a size"))
}

/// The full name of a nested type as a field in `package` spells it: `pkg/Name` and
/// `pkg/msg/Name` are `pkg/msg/Name`, a bare `Name` is the package's own (`Header` is
/// `std_msgs`', as rosidl reads old files).
fn full_type_name(spelled: &str, package: &str) -> Result<String, String> {
    let parts: Vec<&str> = spelled.split('/').collect();
    match parts.as_slice() {
        ["Header"] => Ok("std_msgs/msg/Header".to_string()),
        [name] => Ok(format!("{package}/msg/{name}")),
        [pkg, name] => Ok(format!("{pkg}/msg/{name}")),
        [pkg, "msg", name] => Ok(format!("{pkg}/msg/{name}")),
        _ => Err(format!("`{spelled}` is not a message type")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn std_interfaces() -> Interfaces {
        let mut i = Interfaces::new();
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/std_interfaces");
        for package in std::fs::read_dir(root).into_iter().flatten().flatten() {
            let pkg = package.file_name().to_string_lossy().to_string();
            for kind in ["msg", "srv", "action"] {
                let dir = package.path().join(kind);
                for file in std::fs::read_dir(dir).into_iter().flatten().flatten() {
                    let path = file.path();
                    let name = path.file_stem().map(|s| s.to_string_lossy().to_string());
                    let text = std::fs::read_to_string(&path).unwrap_or_default();
                    i.add(&pkg, kind, &name.unwrap_or_default(), &text)
                        .unwrap_or_else(|e| panic!("{e}"));
                }
            }
        }
        i
    }

    /// Hashes that ROS 2 Jazzy's rosidl generates for standard types (as ros2-client's tests
    /// lock them, and as rmw_zenoh announces them): a service, an action's parts, a message
    /// with nested arrays of nested types.
    #[test]
    fn standard_services_and_actions_hash_as_rosidl_does() {
        let mut i = std_interfaces();
        i.add(
            "example_interfaces",
            "srv",
            "AddTwoInts",
            "int64 a\nint64 b\n---\nint64 sum\n",
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let fibonacci = "int32 order\n---\nint32[] sequence\n---\nint32[] partial_sequence\n";
        i.add(
            "action_tutorials_interfaces",
            "action",
            "Fibonacci",
            fibonacci,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let cases = [
            (
                "std_msgs/msg/String",
                "df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18",
            ),
            (
                "example_interfaces/srv/AddTwoInts",
                "e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a",
            ),
            (
                "action_msgs/msg/GoalStatusArray",
                "6c1684b00f177d37438febe6e709fc4e2b0d4248dca4854946f9ed8b30cda83e",
            ),
            (
                "action_msgs/srv/CancelGoal",
                "573d8b0a534451d7bc2ac8c5ffde8ac14b8593b7001175d0cd6516dcbeb8689a",
            ),
            (
                "action_tutorials_interfaces/action/Fibonacci_SendGoal",
                "a0603060ed69fe2dfbd1a6f3b982a1749957ef346e4a4d2b311a05e305ec37bb",
            ),
            (
                "action_tutorials_interfaces/action/Fibonacci_GetResult",
                "8b47e383f1e31f6d8df6417ab54957e7d5ea24dad315646ad711ac3fdea81d58",
            ),
            (
                "action_tutorials_interfaces/action/Fibonacci_FeedbackMessage",
                "50fc26b9cac313652ecbeab3adf9b5414d59fd4d4d5f9058ddcc7525169927f1",
            ),
        ];
        for (name, hex) in cases {
            assert_eq!(i.hash(name), Ok(format!("RIHS01_{hex}")), "{name}");
        }
    }

    #[test]
    fn field_types_follow_rep_2016() {
        let text = "uint8 A=1\nuint8 B = 2\nchar c\nstring<=5 s\nstring<=5[3] sa\nfloat64[<=4] b\nbyte[] o\nstring d \"x=y\"\nHeader h\nfoo/Bar f\n";
        let fields = parse_fields(text, "p").unwrap_or_else(|e| panic!("{e}"));
        let got: Vec<(&str, u8, u64, u64, &str)> = fields
            .iter()
            .map(|f| {
                let n = f.nested_type_name.as_str();
                (f.name.as_str(), f.type_id, f.capacity, f.string_capacity, n)
            })
            .collect();
        assert_eq!(
            got,
            [
                ("c", 3, 0, 0, ""),
                ("s", 21, 0, 5, ""),
                ("sa", 69, 3, 5, ""),
                ("b", 107, 4, 0, ""),
                ("o", 160, 0, 0, ""),
                ("d", 17, 0, 0, ""),
                ("h", 1, 0, 0, "std_msgs/msg/Header"),
                ("f", 1, 0, 0, "foo/msg/Bar"),
            ]
        );
    }

    #[test]
    fn bad_texts_and_missing_references_are_named() {
        let mut i = Interfaces::new();
        let e = i.add("p", "msg", "M", "int32[x] a\n").err().map(|e| e.0);
        assert_eq!(
            e.as_deref(),
            Some("p/msg/M: line 1: `int32[x] a`: `x` is not a size")
        );
        let e = i.add("p", "srv", "S", "int32 a\n").err().map(|e| e.0);
        assert_eq!(
            e.as_deref(),
            Some("p/srv/S: a service has 2 parts, found 1")
        );
        assert!(i.add("p", "msg", "N", "q/Missing m\n").is_ok());
        let e = i.hash("p/msg/N").err().map(|e| e.0);
        assert_eq!(
            e.as_deref(),
            Some("`p/msg/N` references `q/msg/Missing`, whose definition is missing")
        );
    }
}
