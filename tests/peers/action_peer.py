#!/usr/bin/env python3
"""An action client of the capsule controller in the rcl_action protocol, over Eclipse Cyclone
DDS (Python binding), as rclpy's ActionClient on rmw_cyclonedds speaks it: the services
<action>/_action/send_goal, get_result and cancel_goal (rmw_cyclonedds' request/reply mapping,
see cyclone_peer.py), the topics <action>/_action/feedback and /status (transient local), the
types rosidl derives from capsule_msgs/action/*.action (Move_SendGoal_Request, ...,
capsule_msgs::action::dds_::..._) and action_msgs' (GoalStatusArray, CancelGoal).

Usage (inside a loopback-only network namespace, see tests/peers/netns_run.sh):
  action_peer.py move DIST [--tolerance M] [--timeout S] [--cancel-after S]
                 [--preempt DIST2 --preempt-after S] [--drift-s S [--drift-after W] [--period-s T]]
        send a Move goal, read its feedback and statuses, cancel it or send a second goal
        after a while if asked, wait for the result(s); with --drift-s, the capsule's travel
        over that long from W s after the end, on the section (drive period T, the control point's by
        default). One JSON line per goal. With --retry-refused S a refused goal is sent again
        (a new id) every 0.2 s for up to S s; with --resume SERVICE, once the goal is accepted,
        SERVICE (a lock-step plant's ~/pause, std_srvs/srv/SetBool) is called with false.
  action_peer.py refuse [--estop] DIST...
        send each goal; one JSON line each: accepted or not; with --estop, the plant's
        emergency stop engaged first (std_srvs/srv/SetBool on --estop-service) and released after
  action_peer.py switch --gain K --pulse-periods N --target-period P --max-tries T
                 [--cancel-after S]
        a SwitchAttractor goal, its feedback and result, cancelled after S s if asked, and the
        controller's mode on its status after the end; one JSON line
  action_peer.py unknown-result    get_result for a goal id never sent: answered at once

Exit status 0 = the protocol held (answers came, statuses in order); 1 = a check failed.
"""
import argparse
import json
import math
import os
import sys
import threading
import time
import uuid

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cyclone_peer as cp  # noqa: E402
from cyclonedds.core import Policy  # noqa: E402

STATUS = {0: "UNKNOWN", 1: "ACCEPTED", 2: "EXECUTING", 3: "CANCELING", 4: "SUCCEEDED",
          5: "CANCELED", 6: "ABORTED"}
TERMINAL = (4, 5, 6)


def action_types(name):
    """The types of capsule_msgs/action/NAME, and action_msgs', by short name."""
    known = dict(cp.TYPES)
    std = [
        ("unique_identifier_msgs/msg/UUID", "uint8[16] uuid"),
        ("action_msgs/msg/GoalInfo", "unique_identifier_msgs/UUID goal_id; builtin_interfaces/Time stamp"),
        ("action_msgs/msg/GoalStatus", "GoalInfo goal_info; int8 status"),
        ("action_msgs/msg/GoalStatusArray", "GoalStatus[] status_list"),
    ]
    for full, text in std:
        pkg, _, short = full.split("/")
        known[f"{pkg}/{short}"] = cp.idl_type(full, text, known)
    H = cp.SERVICE_HEADER
    known["action_msgs/CancelGoal_Request"] = cp.idl_type(
        "action_msgs/srv/CancelGoal_Request", "GoalInfo goal_info", known, H)
    known["action_msgs/CancelGoal_Response"] = cp.idl_type(
        "action_msgs/srv/CancelGoal_Response", "int8 return_code; GoalInfo[] goals_canceling",
        known, H)
    with open(os.path.join(cp.CAPSULE_MSGS, "action", f"{name}.action")) as f:
        text = ";".join(line.split("#")[0] for line in f)
    goal, result, feedback = text.split("---")
    a = f"capsule_msgs/action/{name}"
    for part, fields in (("Goal", goal), ("Result", result), ("Feedback", feedback)):
        known[f"capsule_msgs/{name}_{part}"] = cp.idl_type(f"{a}_{part}", fields, known)
    uid = "unique_identifier_msgs/UUID goal_id"
    derived = [
        ("SendGoal_Request", f"{uid}; {name}_Goal goal", H),
        ("SendGoal_Response", "bool accepted; builtin_interfaces/Time stamp", H),
        ("GetResult_Request", uid, H),
        ("GetResult_Response", f"int8 status; {name}_Result result", H),
        ("FeedbackMessage", f"{uid}; {name}_Feedback feedback", None),
    ]
    for part, fields, header in derived:
        known[f"capsule_msgs/{name}_{part}"] = cp.idl_type(f"{a}_{part}", fields, known, header)
    return {k.split("/")[1]: v for k, v in known.items()}


class ActionClient:
    """The client side of action ACTION (e.g. /capsule_controller/move) of type NAME."""

    def __init__(self, dp, action, name, timeout):
        self.t = action_types(name)
        self.name, self.action, self.dp, self.timeout = name, action.strip("/"), dp, timeout
        base = f"/{self.action}/_action"
        self.send = cp.ServiceClient(dp, f"{base}/send_goal", self.t[f"{name}_SendGoal_Request"],
                                     self.t[f"{name}_SendGoal_Response"], timeout)
        self.cancel_client = cp.ServiceClient(dp, f"{base}/cancel_goal",
                                              self.t["CancelGoal_Request"],
                                              self.t["CancelGoal_Response"], timeout)
        self.feedback = cp.reader(dp, f"{self.action}/_action/feedback",
                                  self.t[f"{name}_FeedbackMessage"], cp.reliable(depth=64))
        self.status = cp.reader(dp, f"{self.action}/_action/status", self.t["GoalStatusArray"],
                                cp.reliable(Policy.Durability.TransientLocal, depth=16))
        self.statuses = {}  # goal id bytes -> statuses seen, in order, repeats collapsed
        self.feedbacks = {}  # goal id bytes -> (time received, feedback)
        self.lock = threading.Lock()

    def uuid(self):
        return self.t["UUID"](uuid=list(uuid.uuid4().bytes))

    def pump(self):
        """Takes the feedback and status samples that came."""
        with self.lock:
            now = time.time()
            for m in cp.valid(self.feedback.take(N=256)):
                self.feedbacks.setdefault(bytes(m.goal_id.uuid), []).append((now, m.feedback))
            for arr in cp.valid(self.status.take(N=16)):
                for st in arr.status_list:
                    seen = self.statuses.setdefault(bytes(st.goal_info.goal_id.uuid), [])
                    if not seen or seen[-1] != st.status:
                        seen.append(st.status)

    def send_goal(self, **goal):
        gid = self.uuid()
        r = self.send.call(goal_id=gid, goal=self.t[f"{self.name}_Goal"](**goal))
        return gid, r.accepted

    def result(self, gid, box):
        """get_result of GID into BOX (a dict), as rclpy asks for it right after acceptance."""
        client = cp.ServiceClient(self.dp, f"/{self.action}/_action/get_result",
                                  self.t[f"{self.name}_GetResult_Request"],
                                  self.t[f"{self.name}_GetResult_Response"], self.timeout)
        r = client.call(goal_id=gid)
        box["status"], box["result"], box["at"] = r.status, r.result, time.time()

    def cancel(self, gid):
        info = self.t["GoalInfo"](goal_id=gid, stamp=cp.T.Time(sec=0, nanosec=0))
        r = self.cancel_client.call(goal_info=info)
        return r.return_code, [bytes(g.goal_id.uuid) for g in r.goals_canceling]


def wait_results(client, boxes, timeout):
    deadline = time.time() + timeout
    while time.time() < deadline and not all("status" in b for b in boxes):
        client.pump()
        time.sleep(0.01)
    client.pump()
    if not all("status" in b for b in boxes):
        cp.fail(f"no result within {timeout} s")


def goal_report(client, gid, box, sent_at, extra=None):
    key = bytes(gid.uuid)
    fb = client.feedbacks.get(key, [])
    span = fb[-1][0] - fb[0][0] if len(fb) > 1 else 0.0
    res = box["result"]
    out = {"status": STATUS.get(box["status"], str(box["status"])),
           "statuses": [STATUS.get(s, str(s)) for s in client.statuses.get(key, [])],
           "feedback": len(fb),
           "feedback_hz": (len(fb) - 1) / span if span > 0 else 0.0,
           "seconds": box["at"] - sent_at}
    out.update({f: getattr(res, f) for f in res.__annotations__})
    if fb:
        last = fb[-1][1]
        out["last_feedback"] = {f: getattr(last, f) for f in last.__annotations__}
    out.update(extra or {})
    return out


def drift(dp, seconds, period_s):
    """The capsule's net travel over SECONDS, read on the Poincare section: the position at the
    first sample of each drive period (PERIOD_S, by the samples' stamps), last minus first (the
    orbit's swing within a period, 1.5 mm at the control point, cancels out)."""
    states = cp.reader(dp, "capsule/state", cp.T.CapsuleState, cp.reliable(depth=256))
    first = {}  # period index -> (phase, position)
    deadline = time.time() + seconds
    while time.time() < deadline:
        for x in cp.valid(states.take(N=256)):
            t = x.header.stamp.sec + 1e-9 * x.header.stamp.nanosec
            k, phase = divmod(t, period_s)
            if k not in first or phase < first[k][0]:
                first[k] = (phase, x.capsule_position)
        time.sleep(0.01)
    # periods whose first sample came within 3 ms of the period's start (a lost sample there
    # would read the swing, up to 1.5 mm, as travel)
    ks = [k for k in sorted(first) if first[k][0] < 0.003]
    if len(ks) < 2:
        cp.fail(f"only {len(ks)} drive periods seen from their start in {seconds} s")
    return first[ks[-1]][1] - first[ks[0]][1]


def cmd_move(args):
    dp = cp.participant()
    c = ActionClient(dp, args.action, "Move", args.timeout)
    goal = dict(distance_m=args.distance, tolerance_m=args.tolerance, timeout_s=args.goal_timeout)
    t0 = time.time()
    gid, accepted = c.send_goal(**goal)
    while not accepted and time.time() < t0 + args.retry_refused:
        time.sleep(0.2)
        gid, accepted = c.send_goal(**goal)
    if not accepted:
        cp.fail(f"goal {goal} refused")
    print("action_peer: goal accepted", file=sys.stderr, flush=True)
    if args.resume:
        r = cp.ServiceClient(dp, args.resume, cp.T.SetBool_Request, cp.T.SetBool_Response,
                             args.timeout).call(data=False)
        print(f"action_peer: {args.resume}: {r.message}", file=sys.stderr, flush=True)
    boxes = [{}]
    threading.Thread(target=c.result, args=(gid, boxes[0]), daemon=True).start()
    extra = {}
    second = None
    if args.cancel_after is not None or args.preempt is not None:
        wait = args.cancel_after if args.cancel_after is not None else args.preempt_after
        end = time.time() + wait
        while time.time() < end:
            c.pump()
            time.sleep(0.01)
        if args.cancel_after is not None:
            code, canceling = c.cancel(gid)
            extra = {"cancel_code": code, "canceling_ours": canceling == [bytes(gid.uuid)]}
        else:
            t1 = time.time()
            gid2, accepted2 = c.send_goal(distance_m=args.preempt, tolerance_m=0.0, timeout_s=0.0)
            if not accepted2:
                cp.fail("the preempting goal was refused")
            boxes.append({})
            second = (gid2, t1)
            threading.Thread(target=c.result, args=(gid2, boxes[1]), daemon=True).start()
    wait_results(c, boxes, args.timeout)
    # the statuses published after the end
    end = time.time() + 0.3
    while time.time() < end:
        c.pump()
        time.sleep(0.02)
    if args.drift_s:
        time.sleep(args.drift_after)
        extra["drift_m"] = drift(dp, args.drift_s, args.period_s)
    print(json.dumps(goal_report(c, gid, boxes[0], t0, extra)), flush=True)
    if second:
        print(json.dumps(goal_report(c, second[0], boxes[1], second[1])), flush=True)


def set_estop(dp, service, engaged, timeout):
    """Engages or releases the plant's emergency stop and waits until its latched topic says
    so, then 0.3 s for the controller's reader of it."""
    r = cp.ServiceClient(dp, service, cp.T.SetBool_Request, cp.T.SetBool_Response,
                         timeout).call(data=engaged)
    if not r.success:
        cp.fail(f"emergency stop {engaged}: {r.message}")
    latched = cp.reader(dp, "capsule/emergency_stop", cp.T.Bool,
                        cp.reliable(Policy.Durability.TransientLocal, depth=1))
    deadline = time.time() + timeout
    while not any(b.data == engaged for b in cp.valid(latched.take(N=4))):
        if time.time() > deadline:
            cp.fail(f"capsule/emergency_stop never said {engaged}")
        time.sleep(0.01)
    time.sleep(0.3)


def cmd_refuse(args):
    dp = cp.participant()
    c = ActionClient(dp, args.action, "Move", args.timeout)
    if args.estop:
        set_estop(dp, args.estop_service, True, args.timeout)
    for d in args.distances:
        gid, accepted = c.send_goal(distance_m=float(d), tolerance_m=0.0, timeout_s=0.0)
        print(json.dumps({"distance": d, "accepted": accepted, "estop": args.estop}), flush=True)
        if accepted:
            c.cancel(gid)
    if args.estop:
        set_estop(dp, args.estop_service, False, args.timeout)
    # a refused goal never shows on the status topic
    c.pump()


def mode_after(dp, timeout):
    """The mode on the first controller status published from now on."""
    status = cp.reader(dp, "capsule_controller/status", cp.T.ControllerStatus)
    deadline = time.time() + timeout
    while time.time() < deadline:
        for st in cp.valid(status.take(N=16)):
            return st.mode_name
        time.sleep(0.01)
    cp.fail(f"no controller status within {timeout} s")


def cmd_switch(args):
    dp = cp.participant()
    c = ActionClient(dp, args.action, "SwitchAttractor", args.timeout)
    t0 = time.time()
    gid, accepted = c.send_goal(gain=args.gain, pulse_periods=args.pulse_periods,
                                target_period=args.target_period, max_tries=args.max_tries)
    if not accepted:
        cp.fail("switch goal refused")
    box = {}
    threading.Thread(target=c.result, args=(gid, box), daemon=True).start()
    extra = {}
    if args.cancel_after is not None:
        end = time.time() + args.cancel_after
        while time.time() < end:
            c.pump()
            time.sleep(0.01)
        code, canceling = c.cancel(gid)
        extra = {"cancel_code": code, "canceling_ours": canceling == [bytes(gid.uuid)]}
    wait_results(c, [box], args.timeout)
    # the statuses published after the end
    end = time.time() + 0.3
    while time.time() < end:
        c.pump()
        time.sleep(0.02)
    extra["mode_after"] = mode_after(dp, 10.0)
    print(json.dumps(goal_report(c, gid, box, t0, extra)), flush=True)


def cmd_unknown_result(args):
    dp = cp.participant()
    c = ActionClient(dp, args.action, "Move", args.timeout)
    box = {}
    t0 = time.time()
    c.result(c.uuid(), box)
    print(json.dumps({"status": STATUS.get(box["status"]), "seconds": time.time() - t0}))


def main():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    a = sub.add_parser("move")
    a.add_argument("distance", type=float)
    cp.options(a, float, tolerance=0.0, goal_timeout=0.0, drift_s=0.0, drift_after=0.0)
    # the control point's drive period: 2 pi / (1.1 sqrt(200 / 0.05)) s
    cp.options(a, float, period_s=2 * math.pi / (1.1 * math.sqrt(200 / 0.05)))
    cp.options(a, float, cancel_after=None, preempt=None, preempt_after=0.5, retry_refused=0.0)
    cp.options(a, str, resume=None)
    a = sub.add_parser("refuse")
    a.add_argument("distances", nargs="+")
    a.add_argument("--estop", action="store_true")
    cp.options(a, str, estop_service="/capsule_plant/emergency_stop")
    a = sub.add_parser("switch")
    cp.options(a, float, gain=0.3, cancel_after=None)
    cp.options(a, int, pulse_periods=1, target_period=1, max_tries=3)
    sub.add_parser("unknown-result")
    for a in sub.choices.values():
        cp.options(a, float, timeout=60.0)
        a.add_argument("--action", default=None)
    args = p.parse_args()
    if args.action is None:
        args.action = ("/capsule_controller/switch_attractor" if args.cmd == "switch"
                       else "/capsule_controller/move")
    {"move": cmd_move, "refuse": cmd_refuse, "switch": cmd_switch,
     "unknown-result": cmd_unknown_result}[args.cmd](args)


if __name__ == "__main__":
    main()
