#!/usr/bin/env python3
"""Compare two scripts/behaviour-capture.sh folders, timing and cost fields aside.
usage: scripts/behaviour-diff.py BASE NEW   (exit 1 when any file differs)"""
import json, os, re, sys

base, new = sys.argv[1], sys.argv[2]
TIMING = [(re.compile(r'[0-9.e+-]+ s wall, [0-9.e+-]+ s per (cycle|simulated s)'), r'T s wall, T s per \1'),
          (re.compile(r'; [0-9.e+-]+ s(\b|$)'), '; T s'),
          (re.compile(r'(CPU|cpu) [0-9.e+-]+ s'), r'\1 T s'),
          (re.compile(r'(_seconds)=[0-9.e+-]+'), r'\1=T')]


def text(s):
    for pattern, replacement in TIMING:
        s = pattern.sub(replacement, s)
    return s


def strip(j):
    if isinstance(j, dict):
        return {k: strip(v) for k, v in j.items() if 'seconds' not in k}
    if isinstance(j, list):
        return [strip(v) for v in j]
    return text(j) if isinstance(j, str) else j


differ = 0
for name in sorted(os.listdir(base)):
    a, b = (open(os.path.join(d, name)).read() for d in (base, new))
    try:  # a command that failed wrote no JSON: its text then
        a, b = (json.dumps(strip(json.loads(x)), indent=1) for x in (a, b))
        assert name.endswith('.json')
    except (ValueError, AssertionError):
        a, b = text(a), text(b)
    if a == b:
        continue
    differ += 1
    print(f'DIFF {name}')
    al, bl = a.splitlines(), b.splitlines()
    for i, (x, y) in [(i, p) for i, p in enumerate(zip(al, bl)) if p[0] != p[1]][:4]:
        print(f'  {i}: - {x[:200]}\n  {i}: + {y[:200]}')
    if len(al) != len(bl):
        print(f'  lines {len(al)} vs {len(bl)}')
print(f'{differ} files differ')
sys.exit(1 if differ else 0)
