# Network faults on a namespace's loopback with iptables (this kernel has no sch_netem), for
# bash scripts already inside a network namespace of their own (tests/peers/netns_run.sh):
#   . tests/peers/net_faults.sh        (needs $ROOT, the workspace, and $TMP, a scratch directory)
#   lossy P                 drop a fraction P of UDP packets on INPUT (on OUTPUT the sender's
#                           sendto would fail with EPERM, which a network never does)
#   dupes P                 duplicate a fraction P of UDP packets (TEE on mangle OUTPUT)
#   delayed MS JITTER REORDER   pass every UDP packet through tests/peers/nfqueue_delay.py
#                           (NFQUEUE): MS +- JITTER ms, a fraction REORDER held 3 ms more
#   partition / heal        drop every packet / stop dropping
#   unfault                 remove every rule (and stop the queue's program: its counts, one
#                           JSON line, are in $TMP/nfq.json)
#   wait_log FILE TEXT      wait (at most 30 s) until TEXT is in FILE
lossy() { iptables -A INPUT -p udp -m statistic --mode random --probability "$1" -j DROP || exit 1; }
dupes() { iptables -t mangle -A OUTPUT -p udp -m statistic --mode random --probability "$1" -j TEE --gateway 127.0.0.1 || exit 1; }
delayed() {
    rm -f "$TMP/nfq.ready"
    python3 "$ROOT/tests/peers/nfqueue_delay.py" --queue 0 --delay-ms "$1" --jitter-ms "$2" --reorder "$3" \
        --ready "$TMP/nfq.ready" > "$TMP/nfq.json" & Q=$!
    for _ in $(seq 100); do [ -e "$TMP/nfq.ready" ] && break; sleep 0.1; done
    [ -e "$TMP/nfq.ready" ] || { echo "nfqueue_delay.py did not bind its queue" >&2; exit 1; }
    iptables -A INPUT -p udp -j NFQUEUE --queue-num 0 --queue-bypass || exit 1
}
partition() { iptables -I INPUT -j DROP; }
heal() { iptables -D INPUT -j DROP; }
unfault() {
    iptables -F INPUT; iptables -t mangle -F OUTPUT
    if [ -n "${Q:-}" ]; then kill -TERM "$Q"; wait "$Q"; Q=; fi
}
wait_log() { for _ in $(seq 300); do grep -q "$2" "$1" 2>/dev/null && return 0; sleep 0.1; done; return 1; }
