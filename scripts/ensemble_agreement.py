#!/usr/bin/env python3
"""How far the ensemble's keep/drop decisions depend on its seed, and whether a change to
the replay moves them by more than that.

    scripts/ensemble_agreement.py RUN_A RUN_B [CANDIDATE]

RUN_A and RUN_B are two `dexwarp augment` output folders of the same demonstration, spec,
`--seed` and `--count`, run with different `--ensemble-seed`. Prints, over the samples that
ran in both: how many got a different decision (kept in one, failed in the other), how many
of those were `uncertain` in at least one run, the mean absolute difference of their pass
fractions, and each differing sample. Exits 1 when a differing sample is certain in both runs.

With CANDIDATE, a third run of the same samples with a changed replay (another binary, or
the spec's `params.physics`): the same figures of CANDIDATE against RUN_A and against RUN_B,
and whether it agrees with the reference as well as the reference's two seeds agree with
each other: its kept share within the two seeds' difference of kept shares (at least one
sample), its mean absolute difference of pass fractions within the seeds' own. Exits 1 when
it does not.
"""
import csv
import sys
from pathlib import Path


def rows(folder):
    with open(Path(folder) / "samples.csv", newline="") as f:
        return {r["id"]: r for r in csv.DictReader(f) if r["status"] in ("kept", "failed")}


def figures(a, b):
    """(samples in both, kept share of a, of b, mean |pass fraction a - b|)."""
    both = sorted(set(a) & set(b))
    if not both:
        sys.exit("no sample ran in both runs")
    diffs = [
        abs(float(a[i]["pass_fraction"]) - float(b[i]["pass_fraction"]))
        for i in both
        if a[i]["pass_fraction"] and b[i]["pass_fraction"]
    ]
    share = lambda r: sum(1 for i in both if r[i]["status"] == "kept") / len(both)
    return len(both), share(a), share(b), sum(diffs) / max(len(diffs), 1)


def candidate(a, b, c):
    n, sa, sb, seeds = figures(a, b)
    print(f"\nreference seeds: kept share {sa:.3f} / {sb:.3f}, mean |pass fraction| difference {seeds:.3f} over {n}")
    ok = True
    for name, ref in (("A", a), ("B", b)):
        m, sr, sc, diff = figures(ref, c)
        share_gap = abs(sc - sr)
        allowed = max(abs(sa - sb), 1 / m)
        within = share_gap <= allowed and diff <= seeds
        ok &= within
        print(
            f"candidate against {name}: kept share {sc:.3f} against {sr:.3f} "
            f"(gap {share_gap:.3f}, seeds' {abs(sa - sb):.3f}, one sample {1 / m:.3f}); "
            f"mean |pass fraction| difference {diff:.3f} against the seeds' {seeds:.3f}: "
            + ("within" if within else "NOT within")
        )
    return ok


def main():
    if len(sys.argv) not in (3, 4):
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
    ok = len(uncertain) == len(differ)
    if len(sys.argv) == 4:
        ok &= candidate(a, b, rows(sys.argv[3]))
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
