#!/usr/bin/python3
"""Independent peer for the virtual CAN bus test: python-can's own udp_multicast
interface. Announces itself with 0x100 until it hears 0x123 (or extended
0x1ABCDE0) from the C++ side, then answers each with id + 1 and every data
byte + 1. Exit 0 when both were answered, 1 on timeout."""
import sys
import time

import can

port = int(sys.argv[1])
bus = can.Bus(interface="udp_multicast", channel="239.74.163.2", port=port, hop_limit=0)  # this host only
deadline = time.monotonic() + 15.0
answered = set()
try:
    while time.monotonic() < deadline and len(answered) < 2:
        bus.send(can.Message(arbitration_id=0x100, is_extended_id=False, data=[0xAA, 0x55, 0x01]))
        msg = bus.recv(timeout=0.05)
        while msg is not None:
            if msg.arbitration_id in (0x123, 0x1ABCDE0):
                reply = can.Message(arbitration_id=msg.arbitration_id + 1, is_extended_id=msg.is_extended_id,
                                    data=[(b + 1) & 0xFF for b in msg.data])
                bus.send(reply)
                answered.add(msg.arbitration_id)
            msg = bus.recv(timeout=0.0)
finally:
    bus.shutdown()
sys.exit(0 if len(answered) == 2 else 1)
