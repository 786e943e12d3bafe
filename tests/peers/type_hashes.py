#!/usr/bin/env python3
"""REP-2016 type hashes as rosbags computes them: an independent check of capsule_msgs' table.

Usage: type_hashes.py CAPSULE_MSGS_DIR TYPE [TYPE...]
Prints one JSON object: each TYPE (`pkg/msg/Name`, `pkg/srv/Name`, `pkg/action/Name_Goal`, ...)
-> its `RIHS01_...` hash, or `error: ...` where rosbags cannot say.

rosbags (PyPI) is a rosbag2 implementation of its own, with its own .msg parser, its own store
of the standard ROS 2 Jazzy message definitions and its own `Typestore.hash_rihs01`. What comes
from where:
- standard messages (std_msgs, sensor_msgs, lifecycle_msgs, ...): rosbags' own definitions, so
  capsule_msgs/std_interfaces/*.msg is checked too;
- capsule_msgs' .msg files and the halves of every .srv/.action file: parsed by rosbags;
- rosidl reads a .msg `char` as IDL `uint8` (rosidl_adapter's MSG_TYPE_TO_IDL), so the hashes
  ROS 2 announces have type id 3 for it; rosbags 0.11.9 keeps it a `char` (type id 13), which
  changes the hash of service_msgs/msg/ServiceEventInfo (`char[16] client_gid`) and with it every
  service's: RIHS01_83f84988... where ROS 2 has RIHS01_41bcbbe0.... The mapping is applied here
  (docs/ros.md, "Type hashes");
- a service's and an action's composed types (`S_Event`, `S` itself, `A_SendGoal_Request`, ...),
  which no .msg text describes: built here from their layout in rosidl's `definition.py`
  (REP-2016 hashes them as structures of nested fields), then hashed by rosbags.
"""

import json
import pathlib
import sys

from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_typestore, get_types_from_msg


def main() -> int:
    root = pathlib.Path(sys.argv[1])
    wanted = sys.argv[2:]
    store = get_typestore(Stores.ROS2_JAZZY)
    defs: dict = {}
    renames: dict = {}

    def message(pkg: str, kind: str, name: str, text: str) -> None:
        # rosbags names every parsed type pkg/msg/Name (relative field types resolve there, as
        # rosidl resolves them); a service's or an action's part is renamed to its kind after
        defs.update(get_types_from_msg(text, f'{pkg}/msg/{name}'))
        if kind != 'msg':
            renames[f'{pkg}/msg/{name}'] = f'{pkg}/{kind}/{name}'

    def nested(type_name: str):
        return (Nodetype.NAME, type_name)

    def struct(full: str, fields) -> None:
        defs[full] = ([], fields)

    def service(full: str) -> None:
        request, response = f'{full}_Request', f'{full}_Response'
        struct(f'{full}_Event', [
            ('info', nested('service_msgs/msg/ServiceEventInfo')),
            ('request', (Nodetype.SEQUENCE, (nested(request), 1))),
            ('response', (Nodetype.SEQUENCE, (nested(response), 1))),
        ])
        struct(full, [
            ('request_message', nested(request)),
            ('response_message', nested(response)),
            ('event_message', nested(f'{full}_Event')),
        ])

    def action(full: str) -> None:
        uuid = nested('unique_identifier_msgs/msg/UUID')
        struct(f'{full}_SendGoal_Request', [('goal_id', uuid), ('goal', nested(f'{full}_Goal'))])
        struct(f'{full}_SendGoal_Response', [
            ('accepted', (Nodetype.BASE, ('bool', 0))),
            ('stamp', nested('builtin_interfaces/msg/Time')),
        ])
        service(f'{full}_SendGoal')
        struct(f'{full}_GetResult_Request', [('goal_id', uuid)])
        struct(f'{full}_GetResult_Response', [
            ('status', (Nodetype.BASE, ('int8', 0))),
            ('result', nested(f'{full}_Result')),
        ])
        service(f'{full}_GetResult')
        struct(f'{full}_FeedbackMessage', [('goal_id', uuid), ('feedback', nested(f'{full}_Feedback'))])
        struct(full, [
            ('goal', nested(f'{full}_Goal')),
            ('result', nested(f'{full}_Result')),
            ('feedback', nested(f'{full}_Feedback')),
            ('send_goal_service', nested(f'{full}_SendGoal')),
            ('get_result_service', nested(f'{full}_GetResult')),
            ('feedback_message', nested(f'{full}_FeedbackMessage')),
        ])

    def parts(text: str):
        out = ['']
        for line in text.splitlines():
            if line.strip() == '---':
                out.append('')
            else:
                out[-1] += line + '\n'
        return out

    def add_file(pkg: str, kind: str, path: pathlib.Path) -> None:
        name, text = path.stem, path.read_text()
        if kind == 'msg':
            message(pkg, 'msg', name, text)
        elif kind == 'srv':
            request, response = parts(text)
            message(pkg, 'srv', f'{name}_Request', request)
            message(pkg, 'srv', f'{name}_Response', response)
            service(f'{pkg}/srv/{name}')
        else:
            goal, result, feedback = parts(text)
            for suffix, half in (('Goal', goal), ('Result', result), ('Feedback', feedback)):
                message(pkg, 'action', f'{name}_{suffix}', half)
            action(f'{pkg}/action/{name}')

    for kind in ('msg', 'srv', 'action'):
        for path in sorted((root / kind).glob(f'*.{kind}')):
            add_file('capsule_msgs', kind, path)
    # standard messages come from rosbags' store; only the services and actions, which it has
    # no definitions of, are read from capsule's files
    for pkg_dir in sorted((root / 'std_interfaces').iterdir()):
        for kind in ('srv', 'action'):
            for path in sorted((pkg_dir / kind).glob(f'*.{kind}')):
                add_file(pkg_dir.name, kind, path)

    def rename(desc):
        kind, rest = desc
        if kind == Nodetype.BASE and rest[0] == 'char':
            return (kind, ('uint8', rest[1]))
        if kind == Nodetype.NAME:
            return (kind, renames.get(rest, rest))
        if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            return (kind, (rename(rest[0]), rest[1]))
        return desc

    # the standard messages with a `char` field, as rosidl reads them
    for name, (consts, fields) in list(store.fielddefs.items()):
        if any('char' in repr(desc) for _, desc in fields):
            store.fielddefs[name] = (consts, [(f, rename(d)) for f, d in fields])
    store.register({
        renames.get(name, name): (consts, [(field, rename(desc)) for field, desc in fields])
        for name, (consts, fields) in defs.items()
    })
    out = {}
    for name in wanted:
        try:
            out[name] = store.hash_rihs01(name)
        except Exception as e:  # a type rosbags does not know: say so, the test fails on it
            out[name] = f'error: {type(e).__name__}: {e}'
    json.dump(out, sys.stdout, indent=1, sort_keys=True)
    print()
    return 0


if __name__ == '__main__':
    sys.exit(main())
