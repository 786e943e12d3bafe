//! Checks every Rust type against its interface file: same fields, same order, same types,
//! and the same constants. The Rust side is observed through serde (what goes on the wire),
//! so a field renamed, reordered, retyped, added or dropped on either side fails here.

use super::*;
use serde::ser::{self, Serialize};
use std::fmt;

/// What a value looks like on the wire, as serde reports it.
#[derive(Debug, Clone, PartialEq)]
enum Shape {
    Prim(&'static str),
    Struct(&'static str, Vec<(&'static str, Shape)>),
}

#[derive(Debug)]
struct Unsupported(String);
impl fmt::Display for Unsupported {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for Unsupported {}
impl ser::Error for Unsupported {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        Unsupported(msg.to_string())
    }
}

struct Recorder;
struct StructRec(&'static str, Vec<(&'static str, Shape)>);

fn unsupported<T>(what: &str) -> Result<T, Unsupported> {
    Err(Unsupported(format!("{what} is not used by capsule_msgs")))
}

macro_rules! prim {
    ($($f:ident: $t:ty => $n:literal),*) => {
        $(fn $f(self, _v: $t) -> Result<Shape, Unsupported> { Ok(Shape::Prim($n)) })*
    };
}

impl ser::Serializer for Recorder {
    type Ok = Shape;
    type Error = Unsupported;
    type SerializeSeq = ser::Impossible<Shape, Unsupported>;
    type SerializeTuple = ser::Impossible<Shape, Unsupported>;
    type SerializeTupleStruct = ser::Impossible<Shape, Unsupported>;
    type SerializeTupleVariant = ser::Impossible<Shape, Unsupported>;
    type SerializeMap = ser::Impossible<Shape, Unsupported>;
    type SerializeStruct = StructRec;
    type SerializeStructVariant = ser::Impossible<Shape, Unsupported>;

    prim!(serialize_bool: bool => "bool", serialize_i8: i8 => "int8", serialize_i16: i16 => "int16",
          serialize_i32: i32 => "int32", serialize_i64: i64 => "int64", serialize_u8: u8 => "uint8",
          serialize_u16: u16 => "uint16", serialize_u32: u32 => "uint32", serialize_u64: u64 => "uint64",
          serialize_f32: f32 => "float32", serialize_f64: f64 => "float64", serialize_str: &str => "string");

    fn serialize_char(self, _v: char) -> Result<Shape, Unsupported> {
        unsupported("char")
    }
    fn serialize_bytes(self, _v: &[u8]) -> Result<Shape, Unsupported> {
        unsupported("bytes")
    }
    fn serialize_none(self) -> Result<Shape, Unsupported> {
        unsupported("Option")
    }
    fn serialize_some<T: ?Sized + Serialize>(self, _v: &T) -> Result<Shape, Unsupported> {
        unsupported("Option")
    }
    fn serialize_unit(self) -> Result<Shape, Unsupported> {
        unsupported("unit")
    }
    fn serialize_unit_struct(self, _n: &'static str) -> Result<Shape, Unsupported> {
        unsupported("unit struct")
    }
    fn serialize_unit_variant(
        self,
        _n: &'static str,
        _i: u32,
        _v: &'static str,
    ) -> Result<Shape, Unsupported> {
        unsupported("enum")
    }
    fn serialize_newtype_struct<T: ?Sized + Serialize>(
        self,
        _n: &'static str,
        _v: &T,
    ) -> Result<Shape, Unsupported> {
        unsupported("newtype")
    }
    fn serialize_newtype_variant<T: ?Sized + Serialize>(
        self,
        _n: &'static str,
        _i: u32,
        _va: &'static str,
        _v: &T,
    ) -> Result<Shape, Unsupported> {
        unsupported("enum")
    }
    fn serialize_seq(self, _l: Option<usize>) -> Result<Self::SerializeSeq, Unsupported> {
        unsupported("sequence")
    }
    fn serialize_tuple(self, _l: usize) -> Result<Self::SerializeTuple, Unsupported> {
        unsupported("tuple")
    }
    fn serialize_tuple_struct(
        self,
        _n: &'static str,
        _l: usize,
    ) -> Result<Self::SerializeTupleStruct, Unsupported> {
        unsupported("tuple struct")
    }
    fn serialize_tuple_variant(
        self,
        _n: &'static str,
        _i: u32,
        _v: &'static str,
        _l: usize,
    ) -> Result<Self::SerializeTupleVariant, Unsupported> {
        unsupported("enum")
    }
    fn serialize_map(self, _l: Option<usize>) -> Result<Self::SerializeMap, Unsupported> {
        unsupported("map")
    }
    fn serialize_struct(self, name: &'static str, _l: usize) -> Result<StructRec, Unsupported> {
        Ok(StructRec(name, Vec::new()))
    }
    fn serialize_struct_variant(
        self,
        _n: &'static str,
        _i: u32,
        _v: &'static str,
        _l: usize,
    ) -> Result<Self::SerializeStructVariant, Unsupported> {
        unsupported("enum")
    }
}

impl ser::SerializeStruct for StructRec {
    type Ok = Shape;
    type Error = Unsupported;
    fn serialize_field<T: ?Sized + Serialize>(
        &mut self,
        key: &'static str,
        value: &T,
    ) -> Result<(), Unsupported> {
        self.1.push((key, value.serialize(Recorder)?));
        Ok(())
    }
    fn end(self) -> Result<Shape, Unsupported> {
        Ok(Shape::Struct(self.0, self.1))
    }
}

fn shape_of<T: Serialize + Default>() -> Shape {
    match T::default().serialize(Recorder) {
        Ok(s) => s,
        Err(e) => panic!("{} cannot be described: {e}", std::any::type_name::<T>()),
    }
}

/// Compares a recorded Rust shape with an interface text, recursing into nested types.
fn check(shape: &Shape, text: &str, path: &str) -> Result<(), String> {
    let Shape::Struct(_, rust_fields) = shape else {
        return Err(format!("{path}: Rust side is not a struct"));
    };
    let def = parse_definition(text);
    if def.fields.len() != rust_fields.len() {
        return Err(format!(
            "{path}: interface has {} fields {:?}, Rust has {} {:?}",
            def.fields.len(),
            def.fields.iter().map(|f| &f.name).collect::<Vec<_>>(),
            rust_fields.len(),
            rust_fields.iter().map(|f| f.0).collect::<Vec<_>>()
        ));
    }
    for (field, (rname, rshape)) in def.fields.iter().zip(rust_fields) {
        let here = format!("{path}.{}", field.name);
        if field.name != *rname {
            return Err(format!("{here}: Rust field at this position is `{rname}`"));
        }
        if field.type_name.contains('[') {
            return Err(format!("{here}: arrays are not used by capsule_msgs"));
        }
        match (nested_definition(&field.type_name), rshape) {
            (Some((_, nested)), s @ Shape::Struct(..)) => check(s, nested, &here)?,
            (None, Shape::Prim(p)) if *p == field.type_name => {}
            (_, other) => {
                return Err(format!(
                    "{here}: interface type `{}`, Rust {other:?}",
                    field.type_name
                ))
            }
        }
    }
    Ok(())
}

#[test]
fn every_rust_type_matches_its_interface_file_field_for_field() {
    /// Every type's name, serde shape and interface text.
    struct Cases(Vec<(&'static str, Shape, &'static str)>);
    impl InterfaceVisitor for Cases {
        fn visit<T: RosInterface>(&mut self) {
            self.0.push((T::NAME, shape_of::<T>(), T::definition()));
        }
    }
    let mut cases = Cases(Vec::new());
    for_each_interface(&mut cases);
    assert_eq!(cases.0.len(), 13);
    for (name, shape, text) in cases.0 {
        assert!(
            !parse_definition(text).fields.is_empty(),
            "{name}: no fields parsed"
        );
        if let Err(e) = check(&shape, text, name) {
            panic!("{e}");
        }
    }
}

#[test]
fn the_checker_catches_drift() {
    // the same Rust type against altered texts must fail: renamed, retyped, reordered, extra
    let good = ActuatorForce::definition();
    let shape = shape_of::<ActuatorForce>();
    assert!(check(&shape, good, "ok").is_ok());
    for bad in [
        good.replace("float64 force", "float64 forze"),
        good.replace("float64 force", "float32 force"),
        good.replace("uint64 state_seq\n", "")
            .replace("float64 force", "float64 force\nuint64 state_seq"),
        format!("{good}\nbool extra\n"),
        good.replace("std_msgs/Header header", "builtin_interfaces/Time header"),
    ] {
        assert!(check(&shape, &bad, "bad").is_err(), "not caught:\n{bad}");
    }
}

/// The constants of an interface text, as (name, value as written).
fn constants_of(text: &str) -> Vec<(String, String)> {
    parse_definition(text)
        .constants
        .into_iter()
        .map(|c| (c.name, c.value))
        .collect()
}

/// A `CONSTANTS` table, as (name, value).
fn table<T: fmt::Display>(constants: &[(&str, T)]) -> Vec<(String, String)> {
    constants
        .iter()
        .map(|(n, v)| (n.to_string(), v.to_string()))
        .collect()
}

#[test]
fn service_constants_match_the_rust_constants() {
    assert!(parse_definition(SetModeRequest::definition())
        .constants
        .iter()
        .all(|c| c.type_name == "uint8"));
    for (text, rust) in [
        (
            SetModeRequest::definition(),
            table(SetModeRequest::CONSTANTS),
        ),
        (
            ControllerStatus::definition(),
            table(ControllerStatus::CONSTANTS),
        ),
        (
            GOAL_STATUS_MSG,
            table(crate::actions::GoalStatus::CONSTANTS),
        ),
    ] {
        assert_eq!(constants_of(text), rust);
    }
    assert!(constants_of(SetModeResponse::definition()).is_empty());
    assert_eq!(crate::mode_name(SetModeRequest::CUSTOM), Some("CUSTOM"));
    assert_eq!(crate::mode_name(9), None);
    use crate::actions::GoalStatus;
    assert_eq!(GoalStatus::name(GoalStatus::STATUS_CANCELING), "CANCELING");
    assert_eq!(GoalStatus::name(GoalStatus::STATUS_UNKNOWN), "UNKNOWN");
    assert_eq!(GoalStatus::name(42), "UNKNOWN");
}

#[test]
fn package_files_list_every_interface_and_dependency() {
    let cmake = include_str!("../../CMakeLists.txt");
    let package = include_str!("../../package.xml");
    for file in [
        "msg/CapsuleState.msg",
        "msg/ActuatorForce.msg",
        "msg/ControllerStatus.msg",
        "srv/SetMode.srv",
        "action/Move.action",
        "action/SwitchAttractor.action",
    ] {
        assert!(
            cmake.contains(&format!("\"{file}\"")),
            "CMakeLists.txt misses {file}"
        );
    }
    for dep in ["std_msgs", "builtin_interfaces", "action_msgs"] {
        assert!(
            package.contains(&format!("<depend>{dep}</depend>")),
            "package.xml misses {dep}"
        );
        assert!(
            cmake.contains(&format!("find_package({dep} REQUIRED)")),
            "CMakeLists.txt misses {dep}"
        );
    }
    assert!(package.contains("<member_of_group>rosidl_interface_packages</member_of_group>"));
}

#[test]
fn names_and_schemas_follow_ros2_conventions() {
    assert_eq!(
        CapsuleState::dds_type_name(),
        "capsule_msgs::msg::dds_::CapsuleState_"
    );
    assert_eq!(
        SetModeRequest::dds_type_name(),
        "capsule_msgs::srv::dds_::SetMode_Request_"
    );
    assert_eq!(
        CapsuleState::ros_type_name(),
        "capsule_msgs/msg/CapsuleState"
    );
    let schema = CapsuleState::ros2msg_schema();
    let sep = "=".repeat(80);
    assert!(schema.starts_with(CapsuleState::definition()));
    // each dependency named as its field spells it (rosbag2; Foxglove resolves only that)
    assert_eq!(
        schema,
        format!(
            "{}\n{sep}\nMSG: std_msgs/Header\n{HEADER_MSG}\n{sep}\nMSG: builtin_interfaces/Time\n{TIME_MSG}",
            CapsuleState::definition()
        )
    );
}

#[test]
fn schema_text_follows_rosbag2_order_and_spelling() {
    // sorted dependencies, depth first, each once; a type without a package gets the
    // enclosing package; unknown types are left out
    let lookup = |t: &str| match t {
        "pkg/B" => Some("pkg/C c\nstring[<=3] s\n"),
        "pkg/C" => Some("int8 x\n"),
        "other/A" => Some("C c\n"),
        "other/C" => Some("uint8 y\n"),
        _ => None,
    };
    let sep = "=".repeat(80);
    let text = ros2msg_text(
        "pkg/B[] b\nother/A a\nB again\nfoo/Unknown u\n",
        "pkg",
        &lookup,
    );
    assert_eq!(
        text,
        format!(
            "pkg/B[] b\nother/A a\nB again\nfoo/Unknown u\n\n{sep}\nMSG: other/A\nC c\n\n{sep}\nMSG: other/C\nuint8 y\n\n{sep}\nMSG: pkg/B\npkg/C c\nstring[<=3] s\n\n{sep}\nMSG: pkg/C\nint8 x\n"
        )
    );
    assert!(is_primitive("string<=10") && !is_primitive("std_msgs/Header"));
}
