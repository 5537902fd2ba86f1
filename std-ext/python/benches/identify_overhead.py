"""The Python call's cost over the command line's: `rotorid identify` on a
measurement file, done from Python (read the file, identify, write the
JSON) as one whole process, to be timed beside the `rotorid identify
--json` process on the same file (docs/benchmarks.md, "Python").

    python std-ext/python/benches/identify_overhead.py SWEEP.csv OUT.json
"""

import json
import sys

import rotorid

speeds, phasors, std = rotorid.read_measurements(sys.argv[1])
ident = rotorid.identify(rotorid.Model.paper(), speeds, phasors, std)
with open(sys.argv[2], "w", encoding="utf-8") as f:
    json.dump(ident.to_dict(), f, indent=2)
