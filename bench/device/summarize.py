"""Table of bench/device/issue29.sh's JSON lines: per configuration, each binary's median
steps/s and spring updates/s over the rounds it ran (min-max), and new/old."""
import json
import sys
from collections import defaultdict

runs = defaultdict(lambda: defaultdict(list))
for line in open(sys.argv[1]):
    r = json.loads(line)
    res = r["result"]
    key = (r["args"], res["integrator"], res["masses"], res["springs"])
    runs[key][r["binary"]].append(res["steps_per_sec"]["median"])
print(f"{'configuration':58} {'old steps/s':>22} {'new steps/s':>22} {'new/old':>9} {'new spring upd/s':>17}")
for (args, integrator, masses, springs), by in runs.items():
    def span(v):
        return f"{min(v):,.0f}-{max(v):,.0f}" if v else "-"
    old, new = by.get("old", []), by.get("new", [])
    ratio = f"{min(new) / max(old):.2f}-{max(new) / min(old):.2f}" if old and new else "-"
    upd = f"{max(new) * springs:.3e}" if new else "-"
    print(f"{args[:58]:58} {span(old):>22} {span(new):>22} {ratio:>9} {upd:>17}")
