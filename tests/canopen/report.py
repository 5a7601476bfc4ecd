"""What a CANopen reference check reports: one JSON line per check ({"check", "ok", "detail"}),
lines the test acts on ({"ready": ...}), and a summary; python-canopen's own warnings on stderr."""

import argparse
import json
import logging
import sys

_failures = 0


def log_warnings():
    """python-canopen's warnings (what it finds odd about the other side) to the test's output."""
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr, format="python-canopen %(levelname)s %(name)s: %(message)s")


def check(name, ok, detail=""):
    global _failures
    _failures += 0 if ok else 1
    print(json.dumps({"check": name, "ok": bool(ok), "detail": detail}), flush=True)


def announce(**fields):
    print(json.dumps(fields), flush=True)


def summary(bus):
    """Prints the summary; the exit code: 0 when every check passed."""
    announce(summary={"failures": _failures, "malformed_datagrams": bus.malformed})
    return 0 if _failures == 0 else 1


def arguments(doc, port_help):
    """The command line both checks share: the host, the bus's port and the drive's data sheet."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--host", default="127.0.0.1")
    ap.add_argument("--port", type=int, required=True, help=port_help)
    ap.add_argument("--eds", required=True, help="the emulated drive's data sheet")
    return ap
