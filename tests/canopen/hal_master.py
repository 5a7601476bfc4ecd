"""The hal as CANopen master against python-canopen's CiA 301 slave, over cannelloni UDP.

Each drive of the first bus is a python-canopen LocalNode built from the emulated drive's data
sheet: python-canopen's SDO server answers the hal's reads and stores its writes, its NMT slave
takes the hal's commands and produces the heartbeat at the period the hal writes to 0x1017. What
python-canopen's LocalNode does not do by itself is the test's own code here: the boot-up and the
step to pre-operational after an NMT reset (CiA 301 7.3.2.2), which its NMT slave leaves to the
application. Each check prints one JSON line {"check", "ok", "detail"}; after the checks one
drive's heartbeat stops ({"heartbeat_stopped": node}) so the test can see the hal notice.

    PYTHONPATH=<python-canopen>:tests/canopen /usr/bin/python3 tests/canopen/hal_master.py \
        --port 22000 --buses 10 --nodes 1,2,3 --eds emulated_drive.eds --heartbeat-ms 20
"""

import socket
import sys
import threading
import time

import canopen
from canopen.objectdictionary import ODVariable

from cannelloni_bus import CannelloniBus
from report import announce, arguments, check, log_warnings, summary

class Wire:
    """What the hal sends to the drives: NMT commands and SDO requests, with the drives' answers."""

    def __init__(self, network, nodes):
        self.lock = threading.Lock()
        self.nmt = []  # (command, node)
        self.requests = {n: [] for n in nodes}  # SDO request payloads, in order
        self.aborts = {n: 0 for n in nodes}
        network.subscribe(0x000, self.on_nmt)
        for n in nodes:
            network.subscribe(0x600 + n, lambda can_id, data, ts, n=n: self.on_request(n, data))
            network.subscribe(0x580 + n, lambda can_id, data, ts, n=n: self.on_answer(n, data))

    def on_nmt(self, can_id, data, timestamp):
        with self.lock:
            self.nmt.append((data[0], data[1]))

    def on_request(self, node, data):
        with self.lock:
            self.requests[node].append(bytes(data))

    def on_answer(self, node, data):
        if data[0] == 0x80:
            with self.lock:
                self.aborts[node] += 1


def boot_on_reset(network, local):
    """CiA 301's reset: the boot-up message, then pre-operational (the heartbeat producer starts
    with 0x1017). python-canopen's NmtSlave takes the command's state but sends nothing."""

    def on_nmt(can_id, data, timestamp):
        if data[0] in (0x81, 0x82) and data[1] in (0, local.id):
            local.nmt.send_command(0x82)  # boot-up
            local.nmt.send_command(0x80)  # pre-operational

    network.subscribe(0x000, on_nmt)


def expedited_write(payload):
    """(index, subindex, value) of an expedited SDO download request, else None."""
    if payload[0] & 0xE0 != 0x20 or not payload[0] & 0x02:
        return None
    size = 4 - ((payload[0] >> 2) & 0x03) if payload[0] & 0x01 else 4
    return (int.from_bytes(payload[1:3], "little"), payload[3], int.from_bytes(payload[4:4 + size], "little"))


def upload_request(payload):
    """(index, subindex) of an SDO upload request, else None."""
    if payload[0] & 0xE0 != 0x40:
        return None
    return (int.from_bytes(payload[1:3], "little"), payload[3])


def documented(node, heartbeat_ms):
    """The objects docs/CAN.md says the hal configures (cyclic synchronous torque)."""
    return {
        (0x1400, 1): 0x200 + node, (0x1400, 2): 1, (0x1600, 0): 2, (0x1600, 1): 0x60400010, (0x1600, 2): 0x60710010,
        (0x1800, 1): 0x180 + node, (0x1800, 2): 1, (0x1A00, 0): 3, (0x1A00, 1): 0x60410010, (0x1A00, 2): 0x60770010,
        (0x1A00, 3): 0x60640020,
        (0x1801, 1): 0x280 + node, (0x1801, 2): 1, (0x1A01, 0): 1, (0x1A01, 1): 0x606C0020,
        (0x6060, 0): 10, (0x1017, 0): heartbeat_ms,
    }


def pdo_order_problems(writes):
    """Where the writes of each PDO do not follow CiA 301's order: the COB-ID invalid (bit 31),
    the mapping count 0, the entries, the count, the COB-ID valid again."""
    problems = []
    for comm, mapping in ((0x1400, 0x1600), (0x1800, 0x1A00), (0x1801, 0x1A01)):
        steps = [(i, w) for i, w in enumerate(writes) if w[0] in (comm, mapping)]
        kinds = []
        for _, (index, sub, value) in steps:
            if index == comm and sub == 1:
                kinds.append("invalid" if value & 0x80000000 else "valid")
            elif index == mapping and sub == 0:
                kinds.append("count0" if value == 0 else "count")
            elif index == mapping:
                kinds.append("entry")
            else:
                kinds.append("type")
        order = [k for k in kinds if k != "type"]
        squeezed = [k for i, k in enumerate(order) if i == 0 or k != order[i - 1]]
        if squeezed != ["invalid", "count0", "entry", "count", "valid"]:
            problems.append(f"0x{comm:04X}/0x{mapping:04X}: {kinds}")
    return problems


def main():
    ap = arguments(__doc__, "the hal's base port (bus b: port + 2b, the drives' side + 2b + 1)")
    ap.add_argument("--buses", type=int, required=True, help="buses the hal has (the others are only listened to)")
    ap.add_argument("--nodes", required=True, help="node ids of the first bus's drives, comma-separated")
    ap.add_argument("--heartbeat-ms", type=int, required=True, help="the producer time the hal writes (hal.canopen.heartbeat_ms)")
    ap.add_argument("--timeout", type=float, default=30.0, help="[s] for the hal to start the drives")
    a = ap.parse_args()
    log_warnings()
    nodes = [int(n) for n in a.nodes.split(",")]

    # The other buses' drive side, so that the hal's datagrams to them land somewhere.
    sinks = []
    for b in range(1, a.buses):
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.bind((a.host, a.port + 2 * b + 1))
        sinks.append(s)
    bus = CannelloniBus((a.host, a.port + 1), (a.host, a.port))
    network = canopen.Network(bus)
    wire = Wire(network, nodes)
    locals_ = {}
    for n in nodes:
        local = canopen.LocalNode(n, a.eds)
        network.add_node(local)
        boot_on_reset(network, local)
        locals_[n] = local
    network.connect()
    announce(ready=True)

    end = time.monotonic() + a.timeout
    while time.monotonic() < end and not all(l.nmt.state == "OPERATIONAL" for l in locals_.values()):
        time.sleep(0.01)
    states = {n: l.nmt.state for n, l in locals_.items()}
    check("nmt_started_every_drive", all(s == "OPERATIONAL" for s in states.values()), f"NMT states {states}")
    time.sleep(0.2)  # the hal's first operational heartbeats

    with wire.lock:
        nmt = list(wire.nmt)
        requests = {n: list(r) for n, r in wire.requests.items()}
        aborts = dict(wire.aborts)
    for n in nodes:
        mine = [c for c, target in nmt if target in (0, n)]
        check(f"node{n}_nmt_reset_communication_then_start", mine == [0x82, 0x01], f"NMT commands {[hex(c) for c in mine]}")
        reads = [upload_request(p) for p in requests[n]]
        writes = [expedited_write(p) for p in requests[n]]
        first_reads = [r for r in reads[:3]]
        check(f"node{n}_sdo_reads_identity_first", first_reads == [(0x1000, 0), (0x6502, 0), (0x6076, 0)],
              f"first requests {[(hex(r[0]), r[1]) if r else None for r in first_reads]}")
        writes = [w for w in writes if w is not None]
        check(f"node{n}_sdo_requests_counted", len(requests[n]) == 26 and len(writes) == 23 and aborts[n] == 0,
              f"{len(requests[n])} requests, {len(writes)} expedited writes, {aborts[n]} aborts from python-canopen")
        store = locals_[n]
        wrong = []
        for (index, sub), want in documented(n, a.heartbeat_ms).items():
            try:
                variable = isinstance(store.object_dictionary[index], ODVariable)
                got = store.sdo[index].raw if variable else store.sdo[index][sub].raw
            except KeyError as e:
                got = f"missing ({e})"
            if got != want:
                wrong.append(f"0x{index:04X}:{sub} = {got if isinstance(got, str) else hex(got)}, docs/CAN.md {hex(want)}")
        check(f"node{n}_sdo_configuration_as_documented", not wrong, "; ".join(wrong))
        order = pdo_order_problems(writes)
        check(f"node{n}_pdo_mapping_in_cia301_order", not order, "; ".join(order))

    # The hal watches the heartbeat: one drive's stops.
    stopped = nodes[-1]
    locals_[stopped].nmt.stop_heartbeat()
    announce(heartbeat_stopped=stopped)
    time.sleep(1.0)
    network.disconnect()
    for s in sinks:
        s.close()
    return summary(bus)


if __name__ == "__main__":
    sys.exit(main())
