#!/usr/bin/python3
"""ROS 2's own interface tools on capsule_msgs: rosidl_adapter, rosidl_parser, and the C
generators with their introspection type support, compiled and run.

Usage: rosidl_check.py MSGS_DIR DEPS_DIR WORK_DIR

MSGS_DIR is capsule_msgs/ (its msg/, srv/ and action/); DEPS_DIR holds the dependency
interfaces Debian does not package (std_msgs/msg/Header.msg, builtin_interfaces/msg/Time.msg,
unique_identifier_msgs/msg/UUID.msg, which an action's derived types use), written by the caller. Every step is ROS 2's code (Debian bookworm: python3-rosidl, rosidl-core,
librosidl-*): .msg/.srv/.action -> .idl (rosidl_adapter), .idl -> parse tree (rosidl_parser),
.idl -> C structs, functions and introspection type support (rosidl_generator_c,
rosidl_typesupport_introspection_c), compiled with cc and run: the program walks the
introspection tables and prints every member. Writes WORK_DIR/rosidl.json:
{"idl": {...parser view...}, "introspection": {...C view...}} (stdout is the tools' narration). Exits non-zero, with the
step that failed on stderr, if any tool refuses the files.
"""

import json
import pathlib
import shutil
import subprocess
import sys

from rosidl_adapter.action import convert_action_to_idl
from rosidl_adapter.msg import convert_msg_to_idl
from rosidl_adapter.srv import convert_srv_to_idl
from rosidl_generator_c import generate_c
from rosidl_parser.definition import (
    AbstractNestedType,
    Action,
    BasicType,
    Constant,
    Message,
    NamespacedType,
    Service,
    UnboundedString,
)
from rosidl_parser.parser import parse_idl_file
from rosidl_pycommon import convert_camel_case_to_lower_case_underscore as snake
from rosidl_typesupport_introspection_c import generate_c as generate_introspection_c
from rosidl_parser.definition import IdlLocator

C_TEMPLATES = pathlib.Path("/usr/share/rosidl_generator_c/resource")
TS_TEMPLATES = pathlib.Path("/usr/share/rosidl_typesupport_introspection_c/resource")


def fail(step, err):
    print(f"rosidl_check: {step}: {err}", file=sys.stderr)
    sys.exit(1)


def to_idl(package, pkg_dir, rel, out_root):
    """rosidl_adapter: one .msg/.srv/.action -> <out_root>/<package>/<kind>/<Name>.idl."""
    kind = rel.parent.name
    out = out_root / package / kind
    out.mkdir(parents=True, exist_ok=True)
    convert = {"msg": convert_msg_to_idl, "srv": convert_srv_to_idl,
               "action": convert_action_to_idl}[kind]
    try:
        return convert(pkg_dir, package, rel, out)
    except Exception as e:  # the adapter raises plain exceptions on bad syntax
        fail(f"rosidl_adapter {package}/{rel}", e)


def type_text(t):
    if isinstance(t, BasicType):
        return t.typename
    if isinstance(t, UnboundedString):
        return "string"
    if isinstance(t, NamespacedType):
        return "/".join(t.namespaced_name())
    if isinstance(t, AbstractNestedType):
        return type_text(t.value_type) + "[]"
    return type(t).__name__


def message_view(msg):
    s = msg.structure
    return {
        "members": [[m.name, type_text(m.type)] for m in s.members],
        "constants": [[c.name, type_text(c.type), c.value] for c in msg.constants],
    }


def parse(idl_root, package, kind, name):
    """rosidl_parser: the parse tree of one .idl, as {type name: view}."""
    try:
        content = parse_idl_file(IdlLocator(idl_root / package, f"{kind}/{name}.idl")).content
    except Exception as e:
        fail(f"rosidl_parser {package}/{kind}/{name}.idl", e)
    views = {}
    for el in content.elements:
        if isinstance(el, Message):
            views[el.structure.namespaced_type.name] = message_view(el)
        elif isinstance(el, Service):
            add_service(views, el)
        elif isinstance(el, Action):
            # the three parts and the types rosidl derives from them (A_SendGoal, ...)
            for msg in (el.goal, el.result, el.feedback, el.feedback_message):
                views[msg.structure.namespaced_type.name] = message_view(msg)
            add_service(views, el.send_goal_service)
            add_service(views, el.get_result_service)
    return views


def add_service(views, service):
    for msg in (service.request_message, service.response_message):
        views[msg.structure.namespaced_type.name] = message_view(msg)


def configure(template, out, package):
    text = template.read_text()
    text = text.replace("@PROJECT_NAME_UPPER@", package.upper()).replace("@PROJECT_NAME@", package)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)


def generate(work, idl_root, package, idls):
    """rosidl_generator_c and rosidl_typesupport_introspection_c for one package."""
    inc = work / "include"
    for gen, templates, sub, vis in (
        (generate_c, C_TEMPLATES, "", "rosidl_generator_c__visibility_control.h"),
        (generate_introspection_c, TS_TEMPLATES, "",
         "rosidl_typesupport_introspection_c__visibility_control.h"),
    ):
        args = work / f"args_{package}_{gen.__module__}.json"
        args.write_text(json.dumps({
            "package_name": package,
            "output_dir": str(inc / package),
            "template_dir": str(templates),
            "idl_tuples": [f"{idl_root / package}:{i}" for i in idls],
            "target_dependencies": [],
        }))
        try:
            gen(str(args))
        except Exception as e:
            fail(f"{gen.__module__} {package}", e)
        configure(templates / (vis + ".in"), inc / package / "msg" / vis, package)
    return sorted((inc / package).rglob("*.c"))


C_MAIN = r"""
#include <stdio.h>
#include <string.h>
#include "rosidl_typesupport_introspection_c/message_introspection.h"
#include "rosidl_typesupport_introspection_c/field_types.h"
%(includes)s

static const char *type_name(uint8_t id) {
  switch (id) {
    case rosidl_typesupport_introspection_c__ROS_TYPE_DOUBLE: return "double";
    case rosidl_typesupport_introspection_c__ROS_TYPE_FLOAT: return "float";
    case rosidl_typesupport_introspection_c__ROS_TYPE_BOOLEAN: return "boolean";
    case rosidl_typesupport_introspection_c__ROS_TYPE_UINT8: return "uint8";
    case rosidl_typesupport_introspection_c__ROS_TYPE_INT8: return "int8";
    case rosidl_typesupport_introspection_c__ROS_TYPE_INT32: return "int32";
    case rosidl_typesupport_introspection_c__ROS_TYPE_UINT32: return "uint32";
    case rosidl_typesupport_introspection_c__ROS_TYPE_INT64: return "int64";
    case rosidl_typesupport_introspection_c__ROS_TYPE_UINT64: return "uint64";
    case rosidl_typesupport_introspection_c__ROS_TYPE_STRING: return "string";
    case rosidl_typesupport_introspection_c__ROS_TYPE_MESSAGE: return "message";
    default: return "other";
  }
}

static void dump(const char *name, const rosidl_message_type_support_t *ts, int last) {
  const rosidl_typesupport_introspection_c__MessageMembers *m = ts->data;
  printf("\"%%s\": {\"namespace\": \"%%s\", \"size\": %%zu, \"members\": [", name,
         m->message_namespace_, m->size_of_);
  for (uint32_t i = 0; i < m->member_count_; i++) {
    const rosidl_typesupport_introspection_c__MessageMember *f = &m->members_[i];
    printf("%%s[\"%%s\", \"%%s\", %%u]", i ? ", " : "", f->name_, type_name(f->type_id_),
           (unsigned)f->offset_);
  }
  printf("]}%%s\n", last ? "" : ",");
}

int main(void) {
  /* init/fini of every generated message: the generated functions link and run */
%(init)s
  printf("{\n");
%(dumps)s
  printf("}\n");
  return 0;
}
"""


def main():
    if len(sys.argv) != 4:
        fail("usage", "rosidl_check.py MSGS_DIR DEPS_DIR WORK_DIR")
    msgs, deps, work = (pathlib.Path(a).resolve() for a in sys.argv[1:])
    shutil.rmtree(work, ignore_errors=True)
    idl_root = work / "idl"
    packages = {
        "builtin_interfaces": (deps / "builtin_interfaces", ["msg/Time.msg"]),
        "std_msgs": (deps / "std_msgs", ["msg/Header.msg"]),
        "unique_identifier_msgs": (deps / "unique_identifier_msgs", ["msg/UUID.msg"]),
        "capsule_msgs": (msgs, sorted(
            [f"msg/{p.name}" for p in (msgs / "msg").glob("*.msg")]
            + [f"srv/{p.name}" for p in (msgs / "srv").glob("*.srv")]
            + [f"action/{p.name}" for p in (msgs / "action").glob("*.action")])),
    }
    views, sources, messages = {}, [], []
    for package, (pkg_dir, files) in packages.items():
        idls = []
        for f in files:
            rel = pathlib.Path(f)
            to_idl(package, pkg_dir, rel, idl_root)
            idls.append(f"{rel.parent}/{rel.stem}.idl")
            for name, view in parse(idl_root, package, rel.parent.name, rel.stem).items():
                views[f"{package}/{name}"] = view
                messages.append((package, rel.parent.name, rel.stem, name))
        sources += generate(work, idl_root, package, idls)

    includes, init, dumps = [], [], []
    for i, (package, kind, stem, name) in enumerate(messages):
        header = f"{package}/{kind}/{snake(stem)}.h"
        ts_header = (f"{package}/{kind}/detail/"
                     f"{snake(stem)}__rosidl_typesupport_introspection_c.h")
        for h in (header, ts_header):
            if f'#include "{h}"' not in includes:
                includes.append(f'#include "{h}"')
        c_name = f"{package}__{kind}__{name}"
        init.append(f"  {{ {c_name} m; if (!{c_name}__init(&m)) return 2; "
                    f"{c_name}__fini(&m); }}")
        ts = (f"ROSIDL_TYPESUPPORT_INTERFACE__MESSAGE_SYMBOL_NAME("
              f"rosidl_typesupport_introspection_c, {package}, {kind}, {name})()")
        dumps.append(f'  dump("{package}/{name}", {ts}, {int(i == len(messages) - 1)});')
    main_c = work / "main.c"
    main_c.write_text(C_MAIN % {
        "includes": "\n".join(includes), "init": "\n".join(init), "dumps": "\n".join(dumps)})
    exe = work / "introspect"
    cmd = ["cc", "-std=c11", "-Wall", "-o", str(exe), str(main_c)] + [str(s) for s in sources] + [
        "-I", str(work / "include"),
        "-I", "/usr/include/rosidl_runtime_c",
        "-I", "/usr/include/rosidl_typesupport_interface",
        "-I", "/usr/include/rosidl_typesupport_introspection_c",
        "-I", "/usr/include/rcutils",
        "-lrosidl_typesupport_introspection_c", "-lrosidl_runtime_c", "-lrcutils"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        fail("cc (the generated C type support)", r.stderr[-4000:])
    r = subprocess.run([str(exe)], capture_output=True, text=True)
    if r.returncode != 0:
        fail("running the generated C type support", f"exit {r.returncode} {r.stderr}")
    try:
        introspection = json.loads(r.stdout)
    except json.JSONDecodeError as e:
        fail("reading the introspection dump", f"{e}: {r.stdout[:2000]}")
    report = {"idl": views, "introspection": introspection, "generated_c_files": len(sources)}
    (work / "rosidl.json").write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
