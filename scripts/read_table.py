#!/usr/bin/python3
"""Minimal reader of a brdftab table file, using only h5py and numpy.

Usage: /usr/bin/python3 scripts/read_table.py FILE [TABLE]

Prints the file attributes, the tables, and for TABLE (default: the first)
its datasets, axes and attributes.  It shares no code with brdftab: it is the
format description (docs/format.md) turned into a few lines of Python.
"""
import json
import sys

import h5py
import numpy as np


def main(argv):
    if len(argv) < 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    sys.stdout.reconfigure(encoding="utf-8")
    with h5py.File(argv[1], "r") as f:
        print("brdftab_format:", int(f.attrs["brdftab_format"]))
        print("brdftab_version:", f.attrs["brdftab_version"])
        print("created:", f.attrs["created"])
        names = sorted(k for k in f if isinstance(f[k], h5py.Group))
        print("tables:", ", ".join(names))
        g = f[argv[2] if len(argv) > 2 else names[0]]

        # Axes in order; each is a 1-D float64 dimension scale.
        axes = json.loads(g.attrs["axes"])
        for name in axes:
            a = g[name]
            print(f"axis {name}: {a.shape[0]} nodes {a[0]:g} .. {a[-1]:g} "
                  f"unit {a.attrs['unit']} spacing {a.attrs['spacing']}")

        for dname in ("value", "stderr", "samples"):
            if dname in g:
                d = g[dname]
                print(f"{dname}: shape {d.shape} dtype {d.dtype}")
        value = g["value"]
        print("dims:", ", ".join(dim.label for dim in value.dims))
        print(f"value[{','.join('0' * value.ndim)}]:",
              repr(float(value[(0,) * value.ndim])))

        for key in sorted(g.attrs):
            if key not in ("axes", "parameters"):
                print(f"{key}: {g.attrs[key]}")
        for key, val in sorted(json.loads(g.attrs["parameters"]).items()):
            print(f"parameters.{key}: {json.dumps(val)}")
        # Values are read as numpy arrays; float16/float32 widen exactly.
        print("value range:", np.min(value[...]), "..", np.max(value[...]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
