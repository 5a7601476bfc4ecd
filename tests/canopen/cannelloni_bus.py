"""A python-can bus over cannelloni UDP (version 2), the transport the hal and the drive emulator
speak besides SocketCAN (docs/CAN.md, "Transports"): one datagram per frame sent, every frame of
a received datagram delivered in order.

Only the standard library and python-can; used by the CANopen reference checks in this folder.
"""

import collections
import select
import socket
import struct
import time

import can

VERSION = 2
OP_DATA = 0
EFF_FLAG = 0x80000000
RTR_FLAG = 0x40000000
ERR_FLAG = 0x20000000


def encode(frames, sequence):
    """The datagram carrying `frames` (python-can Messages) with sequence number `sequence`."""
    out = bytearray(struct.pack(">BBBH", VERSION, OP_DATA, sequence & 0xFF, len(frames)))
    for m in frames:
        can_id = m.arbitration_id | (EFF_FLAG if m.is_extended_id else 0) | (RTR_FLAG if m.is_remote_frame else 0)
        out += struct.pack(">I", can_id)
        if m.is_fd:
            out += struct.pack(">BB", len(m.data) | 0x80, 0x01 if m.bitrate_switch else 0x00)
        else:
            out += struct.pack(">B", len(m.data))
        out += bytes(m.data)
    return bytes(out)


def decode(datagram, timestamp):
    """The frames of `datagram`; raises ValueError naming what is wrong with it."""
    if len(datagram) < 5:
        raise ValueError(f"datagram of {len(datagram)} bytes is shorter than the 5-byte header")
    version, op, _seq, count = struct.unpack_from(">BBBH", datagram, 0)
    if version != VERSION or op != OP_DATA:
        raise ValueError(f"version {version}, op code {op} (expected 2, DATA = 0)")
    at = 5
    frames = []
    for i in range(count):
        if at + 5 > len(datagram):
            raise ValueError(f"truncated at frame {i} of {count}")
        (can_id,) = struct.unpack_from(">I", datagram, at)
        length = datagram[at + 4]
        at += 5
        fd = bool(length & 0x80)
        length &= 0x7F
        brs = False
        if fd:
            brs = bool(datagram[at] & 0x01)
            at += 1
        if at + length > len(datagram):
            raise ValueError(f"truncated payload of frame {i}")
        frames.append(can.Message(timestamp=timestamp, arbitration_id=can_id & 0x1FFFFFFF,
                                  is_extended_id=bool(can_id & EFF_FLAG), is_remote_frame=bool(can_id & RTR_FLAG),
                                  is_error_frame=bool(can_id & ERR_FLAG), is_fd=fd, bitrate_switch=brs,
                                  dlc=length, data=datagram[at:at + length]))
        at += length
    return frames


class CannelloniBus(can.BusABC):
    """A CAN bus whose frames travel as cannelloni datagrams between `local` and `remote`
    ((host, port) pairs)."""

    def __init__(self, local, remote, **kwargs):
        self.channel_info = f"cannelloni udp:{local[0]}:{local[1]}->{remote[0]}:{remote[1]}"
        super().__init__(channel=self.channel_info, **kwargs)
        self._socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._socket.bind(local)
        self._remote = remote
        self._sequence = 0
        self._pending = collections.deque()
        self.malformed = 0

    def send(self, msg, timeout=None):
        self._socket.sendto(encode([msg], self._sequence), self._remote)
        self._sequence = (self._sequence + 1) & 0xFF

    def _recv_internal(self, timeout):
        if not self._pending:
            ready, _, _ = select.select([self._socket], [], [], timeout)
            if not ready:
                return None, False
            datagram = self._socket.recv(65535)
            try:
                self._pending.extend(decode(datagram, time.time()))
            except ValueError:
                self.malformed += 1
                return None, False
        if not self._pending:
            return None, False
        return self._pending.popleft(), False

    def shutdown(self):
        super().shutdown()
        self._socket.close()
