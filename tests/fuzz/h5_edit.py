#!/usr/bin/env python3
"""Writes an input of the structure-aware HDF5 fuzz targets that names its objects (h5_mutator.hpp),
for tests/fuzz/regression/<target>/: edits that survive a regenerated base file.
    python3 tests/fuzz/h5_edit.py OUT OP OBJECT PARAMETER [OP OBJECT PARAMETER ...]
OP: 0 delete, 1 swap, 2 reshape, 3 retype, 4 set values, 5 dataset <-> group, 6 attribute length/type;
OBJECT: "/a/b" or "/a/b@attribute"; PARAMETER: the op's variant (see h5_mutator.cpp).
Rerun a target on it with GRAINTWIN_FUZZ_TRACE=1 to see the edits applied."""
import struct
import sys

args = sys.argv[2:]
if len(args) == 0 or len(args) % 3:
    sys.exit(__doc__)
out = b""
for op, name, param in zip(args[0::3], args[1::3], args[2::3]):
    n = name.encode()
    out += bytes([int(op)]) + b"\xff\xff" + bytes([len(n)]) + n + struct.pack("<Q", int(param, 0))
open(sys.argv[1], "wb").write(out)
