#!/usr/bin/env python3
"""Hardens lcm-gen's C++ decoders in place: a declared array count or string length is checked
against the bytes left in the message before anything is allocated, and a string must end at its
terminator (no NUL inside, a NUL at the end), so that what decodes encodes back to the same bytes.

lcm-gen writes `this->x.resize(count);` before decoding an array, so a forged count of 2e7 in a
92-byte message allocates gigabytes, and a negative count or string length throws out of decode().
Every element of an LCM array takes at least one byte, so a count larger than the bytes left cannot
be valid: the decoder now returns -1 (a malformed message) before the allocation. Usage:
    harden_decoders.py HEADER...
"""
import re
import sys

RESIZE = re.compile(r'^(?P<indent>\s*)this->(?P<field>[\w\[\]]+)\.resize\((?P<count>[^;]+)\);\s*$')
# A string's length (its NUL included) is checked against the bytes left, but not against 0 or a
# negative value, which reach std::string::assign(p, length - 1) and throw.
STRING_LEN = re.compile(r'if\((?P<len>__\w+)\s*>\s*maxlen - pos\) return -1;')
# A string's bytes: lcm-gen keeps whatever they hold, but its encoder writes up to the first NUL, so a
# string with a NUL inside (or no NUL at its end) would be re-published as a different, malformed
# message. Such a string makes the message malformed.
ASSIGN = re.compile(r'^(?P<indent>\s*)this->[\w\[\]]+\.assign\(\(\(const char\*\)buf\) \+ offset \+ pos, (?P<len>\w+)\s*-\s*1\);\s*$')


def harden(text: str) -> str:
    out = []
    in_decode = False
    for line in text.splitlines(keepends=True):
        if '::_decodeNoHash(' in line:
            in_decode = True
        elif re.match(r'^\w.*::\w+\(', line):
            in_decode = False
        m = RESIZE.match(line)
        if in_decode and m:
            count = m.group('count')
            guard = f"{m.group('indent')}if (({count}) < 0 || ({count}) > maxlen - pos) return -1;\n"
            if not out or out[-1] != guard:  # idempotent: a header hardened twice stays the same
                out.append(guard)
        a = ASSIGN.match(line)
        if in_decode and a:
            text_at = "((const char*)buf) + offset + pos"
            guard = (f"{a.group('indent')}if (memchr({text_at}, 0, {a.group('len')} - 1) != nullptr || "
                     f"({text_at})[{a.group('len')} - 1] != 0) return -1;\n")
            if not out or out[-1] != guard:
                out.append(guard)
        if in_decode:
            line = STRING_LEN.sub(lambda s: f"if({s.group('len')} < 1 || {s.group('len')} > maxlen - pos) return -1;", line)
        out.append(line)
    return ''.join(out)


def main() -> int:
    for path in sys.argv[1:]:
        with open(path, encoding='utf-8') as f:
            text = f.read()
        hardened = harden(text)
        if 'resize(' in text and hardened.count('> maxlen - pos) return -1;') == 0:
            sys.stderr.write(f'{path}: no decoder pattern recognised: lcm-gen output changed?\n')
            return 1
        with open(path, 'w', encoding='utf-8') as f:
            f.write(hardened)
    return 0


if __name__ == '__main__':
    sys.exit(main())
