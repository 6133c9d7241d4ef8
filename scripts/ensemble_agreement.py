#!/usr/bin/env python3
"""How far the ensemble's keep/drop decisions depend on its seed.

    scripts/ensemble_agreement.py RUN_A RUN_B

RUN_A and RUN_B are two `dexwarp augment` output folders of the same demonstration, spec,
`--seed` and `--count`, run with different `--ensemble-seed`. Prints, over the samples that
ran in both: how many got a different decision (kept in one, failed in the other), how many
of those were `uncertain` in at least one run, the mean absolute difference of their pass
fractions, and each differing sample. Exits 1 when a differing sample is certain in both runs.
"""
import csv
import sys
from pathlib import Path


def rows(folder):
    with open(Path(folder) / "samples.csv", newline="") as f:
        return {r["id"]: r for r in csv.DictReader(f) if r["status"] in ("kept", "failed")}


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    a, b = rows(sys.argv[1]), rows(sys.argv[2])
    both = sorted(set(a) & set(b))
    if not both:
        sys.exit("no sample ran in both runs")
    differ = [i for i in both if a[i]["status"] != b[i]["status"]]
    uncertain = [i for i in differ if "true" in (a[i]["uncertain"], b[i]["uncertain"])]
    fractions = [
        abs(float(a[i]["pass_fraction"]) - float(b[i]["pass_fraction"]))
        for i in both
        if a[i]["pass_fraction"] and b[i]["pass_fraction"]
    ]
    kept = lambda r: sum(1 for i in both if r[i]["status"] == "kept")
    unc = lambda r: sum(1 for i in both if r[i]["uncertain"] == "true")
    print(f"samples that ran in both: {len(both)}")
    print(f"kept: {kept(a)} / {kept(b)}; uncertain: {unc(a)} / {unc(b)}")
    print(
        f"decisions that differ: {len(differ)} ({100 * len(differ) / len(both):.1f} %), "
        f"uncertain in at least one run: {len(uncertain)}"
    )
    if fractions:
        print(f"mean |pass fraction A - B|: {sum(fractions) / len(fractions):.3f} over {len(fractions)}")
    for i in differ:
        print(
            f"  {i}: {a[i]['status']} {a[i]['pass_fraction']} "
            f"(uncertain {a[i]['uncertain']}) / {b[i]['status']} {b[i]['pass_fraction']} "
            f"(uncertain {b[i]['uncertain']})"
        )
    sys.exit(0 if len(uncertain) == len(differ) else 1)


if __name__ == "__main__":
    main()
