#!/usr/bin/env python3
"""REP-2016 type hashes as ROS 2 itself computes them: rosidl_adapter turns each .msg/.srv/.action
file into IDL, rosidl_parser parses it, rosidl_generator_type_description hashes it (PyPI's
ros-rosidl-* 4.6.6 wheels, ROS 2 Jazzy's rosidl), package by package as colcon would build them
(each package's JSON descriptions are the next one's includes).

Usage: rosidl_type_hashes.py CAPSULE_MSGS_DIR TYPE [TYPE...]
Prints one JSON object: each TYPE (`pkg/msg/Name`, `pkg/srv/Name`, `pkg/action/Name`) -> its
`RIHS01_...` hash, or `error: ...` where rosidl gave none. The packages are capsule_msgs and the
standard ones under capsule_msgs/std_interfaces/ (the same files capsule_msgs' build.rs reads).
"""

import contextlib
import json
import pathlib
import sys
import tempfile

from rosidl_adapter.action import convert_action_to_idl
from rosidl_adapter.msg import convert_msg_to_idl
from rosidl_adapter.srv import convert_srv_to_idl
from rosidl_generator_type_description import generate_type_hash

CONVERT = {"msg": convert_msg_to_idl, "srv": convert_srv_to_idl, "action": convert_action_to_idl}


def packages(capsule_msgs):
    """Package name -> its directory (with msg/, srv/, action/)."""
    found = {p.name: p for p in sorted((capsule_msgs / "std_interfaces").iterdir()) if p.is_dir()}
    found["capsule_msgs"] = capsule_msgs
    return found


def to_idl(name, pkg_dir, out):
    """The package's interface files as IDL under out/NAME; their `NAME:kind/File.idl` tuples."""
    tuples = []
    for kind, convert in CONVERT.items():
        for f in sorted((pkg_dir / kind).glob(f"*.{kind}")):
            idl = convert(pkg_dir, name, f.relative_to(pkg_dir), out / name / kind)
            tuples.append(f"{out / name}:{kind}/{idl.name}")
    return tuples


def hash_all(capsule_msgs, work):
    """Every package hashed, in an order where its includes exist: a package whose includes are
    missing is tried again after the others."""
    pkgs = packages(capsule_msgs)
    pending = {n: to_idl(n, d, work / "idl") for n, d in pkgs.items()}
    done, hashes = [], {}
    while pending:
        progress = False
        for name in sorted(pending):
            args = {
                "package_name": name,
                "output_dir": str(work / "json" / name),
                "idl_tuples": pending[name],
                "include_paths": [f"{d}:{work / 'json' / d}" for d in done],
            }
            args_file = work / f"{name}.json"
            args_file.write_text(json.dumps(args))
            try:
                outputs = generate_type_hash(str(args_file))
            except (FileNotFoundError, KeyError):
                continue  # an include not hashed yet
            for out in outputs:
                for t in json.loads(pathlib.Path(out).read_text())["type_hashes"]:
                    hashes[t["type_name"]] = t["hash_string"]
            done.append(name)
            del pending[name]
            progress = True
        if not progress:
            raise SystemExit(f"rosidl_type_hashes: cannot hash {sorted(pending)}")
    return hashes


def main():
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    # rosidl_adapter and the generator say what they read and write on stdout: to stderr here
    with tempfile.TemporaryDirectory() as tmp, contextlib.redirect_stdout(sys.stderr):
        hashes = hash_all(pathlib.Path(sys.argv[1]).resolve(), pathlib.Path(tmp))
    print(json.dumps({t: hashes.get(t, "error: rosidl gave no hash") for t in sys.argv[2:]}))


if __name__ == "__main__":
    main()
