"""Tables of bench/device/gpu_rows.sh's JSON lines (and those of the retired issue29.sh), any number of files:
every row's median steps/s, spring updates/s, traffic and where it ended; then, for issue 29,
each configuration's baseline ("old") against this binary ("new") over the rounds run."""
import json
import sys
from collections import defaultdict

rows = []
for path in sys.argv[1:]:
    for line in open(path):
        if line.strip():
            rows.append(json.loads(line))


def label(r):
    return r.get("label") or f"29-{r['binary']}"


print(f"{'label':14} {'scene':22} {'integrator':14} {'steps/s':>12} {'spring upd/s':>12} "
      f"{'GB/s':>7} {'t_end s':>8} {'mean y m':>10}  backend")
for r in rows:
    res = r["result"]
    sps = res["steps_per_sec"]["median"]
    bps = res.get("bytes_per_step")
    gbs = f"{bps * sps / 1e9:7.0f}" if bps else "      -"
    end = res.get("end_mean_position_m")
    t_end = res.get("end_time_secs")
    print(f"{label(r):14} {res['scene'][:22]:22} {res['integrator']:14} {sps:12,.1f} "
          f"{res['spring_updates_per_sec']['median']:12.3e} {gbs} "
          f"{t_end if t_end is not None else float('nan'):8.3f} "
          f"{end[1] if end else float('nan'):10.5f}  {res['backend'][:40]}")

runs = defaultdict(lambda: defaultdict(list))
for r in rows:
    tag = label(r)
    issue, _, which = tag.rpartition("-")
    if which in ("old", "new"):
        res = r["result"]
        key = (issue, r["args"], res["integrator"], res["springs"])
        runs[key][which].append(res["steps_per_sec"]["median"])
if runs:
    print(f"\n{'issue: configuration':58} {'old steps/s':>22} {'new steps/s':>22} {'new/old':>9}")
    for (issue, args, integrator, springs), by in runs.items():
        def span(v):
            return f"{min(v):,.0f}-{max(v):,.0f}" if v else "-"
        old, new = by.get("old", []), by.get("new", [])
        ratio = f"{min(new) / max(old):.2f}-{max(new) / min(old):.2f}" if old and new else "-"
        print(f"{(issue + ': ' + args)[:58]:58} {span(old):>22} {span(new):>22} {ratio:>9}")
