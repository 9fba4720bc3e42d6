#!/usr/bin/python3
"""Independent observer on the virtual CAN bus (python-can's own udp_multicast
interface) while harvest-robot-link drives harvest-sim-drives: decodes the
CANopen traffic it sees with the CiA 301/402 layouts written out here, then
stops one drive with an NMT command of its own.

usage: python_can_canopen_peer.py GROUP PORT NUM_DRIVES STOP_NODE
Prints one line per check; exit 0 when every check passed."""
import struct
import sys
import time

import can

group, port, num, stop_node = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
bus = can.Bus(interface="udp_multicast", channel=group, port=port, hop_limit=0)  # this host only
syncs, rpdo, tpdo1, tpdo2, heartbeat = [], {}, {}, {}, {}
deadline = time.monotonic() + 1.0
try:
    while time.monotonic() < deadline:
        m = bus.recv(timeout=0.05)
        if m is None or m.is_extended_id or m.is_error_frame:
            continue
        cob, node = m.arbitration_id & 0x780, m.arbitration_id & 0x7F
        if m.arbitration_id == 0x080:
            syncs.append((m.timestamp, m.dlc))
        elif cob == 0x200 and m.dlc == 6:  # RPDO1: controlword u16, target velocity i32
            rpdo[node] = struct.unpack("<Hi", bytes(m.data))
        elif cob == 0x180 and m.dlc == 6:  # TPDO1: statusword u16, position actual i32
            tpdo1[node] = struct.unpack("<Hi", bytes(m.data))
        elif cob == 0x280 and m.dlc == 4:  # TPDO2: velocity actual i32
            tpdo2[node] = struct.unpack("<i", bytes(m.data))[0]
        elif cob == 0x700 and m.dlc == 1:  # heartbeat: NMT state
            heartbeat[node] = m.data[0]
    nodes = set(range(1, num + 1))
    checks = {
        # ~100 Hz SYNC, no data
        "sync": len(syncs) >= 50 and all(dlc == 0 for _, dlc in syncs),
        # every drive commanded "enable operation" (0x000F)
        "rpdo1": set(rpdo) == nodes and all(cw == 0x000F for cw, _ in rpdo.values()),
        # every drive reports operation enabled: statusword xxxx xxxx x01x 0111
        "tpdo1": set(tpdo1) == nodes and all(sw & 0x6F == 0x27 for sw, _ in tpdo1.values()),
        "tpdo2": set(tpdo2) == nodes,
        # every drive operational (0x05)
        "heartbeat": nodes <= set(heartbeat) and all(heartbeat[n] == 0x05 for n in nodes),
        # the robot link's own heartbeat (node 127), which the drives consume (0x1016)
        "master heartbeat": heartbeat.get(127) == 0x05,
    }
    for name, ok in checks.items():
        print(f"{name}: {'ok' if ok else 'FAILED'}")
    print(f"seen: {len(syncs)} SYNC, RPDO1 {sorted(rpdo.items())}, TPDO1 {sorted(tpdo1.items())}, "
          f"heartbeat {sorted(heartbeat.items())}")
    # NMT stop (CiA 301: 0x000 [command 0x02, node]) for one drive.
    bus.send(can.Message(arbitration_id=0x000, is_extended_id=False, data=[0x02, stop_node]))
    sys.stdout.flush()
finally:
    bus.shutdown()
sys.exit(0 if all(checks.values()) else 1)
