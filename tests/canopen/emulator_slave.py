"""python-canopen's master against the drive emulator's CiA 402 slave, over cannelloni UDP.

python-canopen (a CANopen stack written by other people: RemoteNode, BaseNode402) drives one of
the emulator's drives through NMT, SDO, PDO mapping, the CiA 402 state machine, cyclic synchronous
torque and position with SYNC, a fault and its reset, and the heartbeat. Each check prints one
JSON line {"check", "ok", "detail"}; the exit code is 0 when every check passed. The test
CanopenReference.* runs it against a drive emulator it started and reads those lines.

    PYTHONPATH=<python-canopen>:tests/canopen /usr/bin/python3 tests/canopen/emulator_slave.py \
        --port 22000 --node 3 --eds emulated_drive.eds
"""

import statistics
import sys
import threading
import time

import canopen
from canopen.objectdictionary import ODVariable
from canopen.profiles.p402 import BaseNode402
from canopen.sdo.exceptions import SdoAbortedError

from cannelloni_bus import CannelloniBus
from report import arguments, check, log_warnings, summary

# The actual values a drive reports as they are (not its data sheet's defaults).
PROCESS_VALUES = {0x6041, 0x6061, 0x6064, 0x606C, 0x6077}
CONTROLWORD, STATUSWORD, MODE, MODE_DISPLAY = 0x6040, 0x6041, 0x6060, 0x6061
POSITION_ACTUAL, VELOCITY_ACTUAL, TARGET_TORQUE, TORQUE_ACTUAL, TARGET_POSITION = 0x6064, 0x606C, 0x6071, 0x6077, 0x607A

class Heartbeats:
    """Every heartbeat of the node, with its arrival time (a boot-up is state 0)."""

    def __init__(self, node):
        self.lock = threading.Lock()
        self.seen = []
        node.nmt.add_heartbeat_callback(self.on)

    def on(self, state):
        with self.lock:
            self.seen.append((time.monotonic(), state))

    def since(self, t0):
        with self.lock:
            return [(t, s) for t, s in self.seen if t >= t0]

    def wait_for(self, state, t0, timeout):
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if any(s == state for _, s in self.since(t0)):
                return True
            time.sleep(0.005)
        return False


def abort_code(action):
    try:
        action()
    except SdoAbortedError as e:
        return e.code
    return None


def readable_defaults(od):
    """(index, subindex, name, default) of every readable object of the data sheet with a default."""
    for entry in od.values():
        subs = [entry] if isinstance(entry, ODVariable) else list(entry.values())
        for var in subs:
            if "r" not in var.access_type and var.access_type != "const":
                continue
            if var.index in PROCESS_VALUES or var.default is None:
                continue
            yield var.index, var.subindex, var.name, var.default


def wait_until(predicate, timeout):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.005)
    return predicate()


def main():
    ap = arguments(__doc__, "the bus's hal-side port (the emulator listens on port + 1)")
    ap.add_argument("--node", type=int, required=True, help="the drive's node id on that bus")
    ap.add_argument("--period", type=float, default=0.01, help="[s] SYNC and RPDO period")
    ap.add_argument("--rpdo-timeout", type=float, default=1.0, help="[s] the emulator's drive_timeout")
    ap.add_argument("--counts-per-rad", type=float, required=True, help="position increments per joint radian")
    a = ap.parse_args()
    log_warnings()

    bus = CannelloniBus((a.host, a.port), (a.host, a.port + 1))
    network = canopen.Network(bus)
    network.connect()
    node = BaseNode402(a.node, a.eds)
    network.add_node(node)
    beats = Heartbeats(node)
    emcys = []
    node.emcy.add_callback(lambda e: emcys.append((time.monotonic(), e.code, e.register)))
    try:
        run(a, network, node, beats, emcys)
    finally:
        network.sync.stop()
        node.pdo.stop()
        network.disconnect()
    return summary(bus)


def run(a, network, node, beats, emcys):
    # NMT: reset communication, then the boot-up message (asked again while the emulator starts).
    booted = False
    end = time.monotonic() + 20.0
    while not booted and time.monotonic() < end:
        t0 = time.monotonic()
        node.nmt.send_command(0x82)
        booted = beats.wait_for(0, t0, 0.5)
    check("nmt_reset_communication_boots_up", booted, f"heartbeats since: {beats.since(t0)[:3]}")

    # SDO: every readable object of the data sheet answers its default value.
    wrong = []
    read = 0
    for index, sub, name, default in readable_defaults(node.object_dictionary):
        try:
            data = node.sdo.upload(index, sub)
            value = int.from_bytes(data, "little")
            expected = default & ((1 << (8 * len(data))) - 1)
            read += 1
            if value != expected:
                wrong.append(f"0x{index:04X}:{sub:02X} {name} = 0x{value:X}, data sheet 0x{expected:X}")
        except SdoAbortedError as e:
            wrong.append(f"0x{index:04X}:{sub:02X} {name}: abort 0x{e.code:08X}")
    check("sdo_reads_match_the_data_sheet", read >= 20 and not wrong, f"{read} objects read; " + "; ".join(wrong[:6]))
    check("sdo_device_type_is_a_cia402_drive", node.sdo[0x1000].raw & 0xFFFF == 402, f"0x{node.sdo[0x1000].raw:08X}")
    modes = node.sdo[0x6502].raw
    check("sdo_supported_modes_csp_and_cst", modes & 0x280 == 0x280, f"0x6502 = 0x{modes:08X}")
    # The aborts of CiA 301 (table 22) for what does not exist or may not be written.
    codes = {
        "missing object": (abort_code(lambda: node.sdo.upload(0x2000, 0)), 0x06020000),
        "missing sub-index": (abort_code(lambda: node.sdo.upload(0x1018, 5)), 0x06090011),
        "read-only object written": (abort_code(lambda: node.sdo.download(STATUSWORD, 0, b"\x00\x00")), 0x06010002),
    }
    bad = [f"{what}: 0x{(got or 0):08X}, expected 0x{want:08X}" for what, (got, want) in codes.items() if got != want]
    check("sdo_aborts_name_the_cia301_reason", not bad, "; ".join(bad))

    # PDO mapping, written through python-canopen's own sequence and read back.
    node.rpdo.read()
    node.tpdo.read()
    layout = {
        ("rpdo", 1): [CONTROLWORD, TARGET_TORQUE, TARGET_POSITION],
        ("tpdo", 1): [STATUSWORD, TORQUE_ACTUAL, POSITION_ACTUAL],
        ("tpdo", 2): [VELOCITY_ACTUAL, MODE_DISPLAY],
    }
    for (kind, number), objects in layout.items():
        pdo = getattr(node, kind)[number]
        pdo.clear()
        for index in objects:
            pdo.add_variable(index)
        pdo.trans_type = 1
        pdo.enabled = True
    node.pdo.save()
    node.rpdo.read()
    node.tpdo.read()
    back = {key: [v.index for v in getattr(node, key[0])[key[1]].map] for key in layout}
    enabled = {key: getattr(node, key[0])[key[1]].enabled and getattr(node, key[0])[key[1]].trans_type == 1 for key in layout}
    check("pdo_mapping_written_and_read_back", back == layout and all(enabled.values()),
          f"read back {dict((f'{k[0]}{k[1]}', [hex(i) for i in v]) for k, v in back.items())}, enabled and synchronous {enabled}")
    raw = [node.sdo.upload(0x1600, s) for s in (1, 2, 3)]
    raw = [int.from_bytes(r, "little") for r in raw]
    check("pdo_mapping_entries_are_index_subindex_bits", raw == [0x60400010, 0x60710010, 0x607A0020],
          " ".join(f"0x{r:08X}" for r in raw))

    # Heartbeat producer: 0x1017 written, the period and the pre-operational state.
    node.sdo[0x1017].raw = 50
    t0 = time.monotonic()
    time.sleep(0.6)
    seen = beats.since(t0)
    gaps = [b[0] - a_[0] for a_, b in zip(seen, seen[1:])]
    gap = statistics.median(gaps) if gaps else 0.0
    check("heartbeat_every_0x1017_in_pre_operational", len(seen) >= 8 and abs(gap - 0.05) < 0.015 and all(s == 127 for _, s in seen),
          f"{len(seen)} heartbeats in 0.6 s, median gap {gap * 1e3:.1f} ms, states {sorted(set(s for _, s in seen))}")

    # NMT start: operational, as the heartbeat says.
    node.setup_402_state_machine(read_pdos=False)
    t0 = time.monotonic()
    node.nmt.state = "OPERATIONAL"
    check("nmt_start_heartbeat_operational", beats.wait_for(5, t0, 1.0), f"states since start {sorted(set(s for _, s in beats.since(t0)))}")

    # SYNC and the cyclic PDOs: a TPDO per SYNC, the RPDO applied at the SYNC.
    node.rpdo[1][CONTROLWORD].raw = 0
    node.rpdo[1][TARGET_TORQUE].raw = 0
    node.rpdo[1][TARGET_POSITION].raw = 0
    node.rpdo[1].start(a.period)
    tpdos = []
    node.tpdo[1].add_callback(lambda m: tpdos.append(time.monotonic()))
    network.sync.start(a.period)
    t0 = time.monotonic()
    time.sleep(1.0)
    n = len([t for t in tpdos if t >= t0])
    expected = 1.0 / a.period
    check("sync_each_answered_by_tpdo1", 0.7 * expected <= n <= 1.2 * expected, f"{n} TPDO1 in 1 s of SYNC every {a.period * 1e3:.0f} ms")

    # The CiA 402 state machine from Switch on disabled to Operation enabled, through the RPDO's
    # controlword and the TPDO's statusword (BaseNode402's own transitions).
    state0 = node.state
    try:
        node.state = "OPERATION ENABLED"
        reached = node.state
    except (RuntimeError, ValueError) as e:
        reached = f"{node.state} ({e})"
    check("cia402_switch_on_disabled_to_operation_enabled", state0 == "SWITCH ON DISABLED" and reached == "OPERATION ENABLED",
          f"from {state0} to {reached}, statusword 0x{node.statusword:04X}")

    # Cyclic synchronous torque: the target torque applied and reported as the actual torque.
    node.op_mode = "CYCLIC SYNCHRONOUS TORQUE"
    mode = node.op_mode
    target = 40  # thousandths of the rated torque
    node.rpdo[1][TARGET_TORQUE].raw = target
    got = wait_until(lambda: node.tpdo_values.get(TORQUE_ACTUAL) is not None and abs(to_signed(node.tpdo_values[TORQUE_ACTUAL], 16) - target) <= 1, 2.0)
    check("cst_target_torque_reported_as_actual", mode == "CYCLIC SYNCHRONOUS TORQUE" and got,
          f"mode {mode}, target {target}, actual {to_signed(node.tpdo_values.get(TORQUE_ACTUAL, 0), 16)} (1/1000 rated)")
    node.rpdo[1][TARGET_TORQUE].raw = 0

    # Cyclic synchronous position: the drive's own loop brings the actual position to the target.
    start = to_signed(node.tpdo_values[POSITION_ACTUAL], 32)
    node.rpdo[1][TARGET_POSITION].raw = start
    node.op_mode = "CYCLIC SYNCHRONOUS POSITION"
    mode = node.op_mode
    goal = start + int(round(0.1 * a.counts_per_rad))
    node.rpdo[1][TARGET_POSITION].raw = goal
    tolerance = int(round(0.01 * a.counts_per_rad))
    still = 0.05 * a.counts_per_rad  # [increments/s]

    def settled():
        return (abs(to_signed(node.tpdo_values[POSITION_ACTUAL], 32) - goal) <= tolerance and
                abs(to_signed(node.tpdo_values[VELOCITY_ACTUAL], 32)) <= still)

    got = wait_until(settled, 3.0)
    actual = to_signed(node.tpdo_values[POSITION_ACTUAL], 32)
    velocity = to_signed(node.tpdo_values[VELOCITY_ACTUAL], 32)
    check("csp_actual_position_reaches_the_target", mode == "CYCLIC SYNCHRONOUS POSITION" and got,
          f"mode {mode}, from {start} to {goal} counts (0.1 rad): {actual} (within {tolerance}), velocity {velocity} (within {still:.0f})")
    moved = wait_until(lambda: to_signed(node.sdo[POSITION_ACTUAL].raw, 32) != start, 0.5)
    check("pdo_and_sdo_report_the_same_position", moved and abs(to_signed(node.sdo[POSITION_ACTUAL].raw, 32) - to_signed(node.tpdo_values[POSITION_ACTUAL], 32)) <= tolerance,
          f"SDO {to_signed(node.sdo[POSITION_ACTUAL].raw, 32)}, TPDO {to_signed(node.tpdo_values[POSITION_ACTUAL], 32)}")

    # A fault (the RPDOs stop: the drive's RPDO timeout, EMCY 0x8250) and its reset.
    node.rpdo[1].stop()
    t0 = time.monotonic()
    faulted = wait_until(lambda: any(t >= t0 and code == 0x8250 for t, code, _ in emcys), a.rpdo_timeout + 2.0)
    wait_until(lambda: node.state == "FAULT", 1.0)  # the next TPDO's statusword
    state = node.state
    check("rpdo_timeout_emcy_and_fault", faulted and state == "FAULT", f"EMCY {[hex(c) for t, c, _ in emcys if t >= t0]}, state {state}")
    node.rpdo[1][CONTROLWORD].raw = 0
    node.rpdo[1].start(a.period)
    t0 = time.monotonic()
    try:
        node.reset_from_fault()
        after = node.state
    except (RuntimeError, ValueError) as e:
        after = f"{node.state} ({e})"
    reset_emcy = any(t >= t0 and code == 0 for t, code, _ in emcys)
    check("fault_reset_back_to_operation_enabled", after == "OPERATION ENABLED" and reset_emcy,
          f"state {after}, error-reset EMCY {'seen' if reset_emcy else 'not seen'}, register 0x{node.sdo[0x1001].raw:02X}")

    # Leaving: torque off, NMT stop, the heartbeat says stopped.
    node.state = "SWITCH ON DISABLED"
    t0 = time.monotonic()
    node.nmt.state = "STOPPED"
    check("nmt_stop_heartbeat_stopped", beats.wait_for(4, t0, 1.0), f"states {sorted(set(s for _, s in beats.since(t0)))}")


def to_signed(value, bits):
    value &= (1 << bits) - 1
    return value - (1 << bits) if value >> (bits - 1) else value


if __name__ == "__main__":
    sys.exit(main())
