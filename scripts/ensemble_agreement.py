#!/usr/bin/env python3
"""How far the ensemble's keep/drop decisions depend on its seed, and whether a change to
the replay moves them by more than that.

    scripts/ensemble_agreement.py RUN_A RUN_B
    scripts/ensemble_agreement.py RUN_A RUN_B RUN_C CANDIDATE

RUN_A, RUN_B (and RUN_C) are `dexwarp augment` output folders of the same demonstration,
spec, `--seed` and `--count`, run with different `--ensemble-seed`. Prints, over the samples
that ran in both A and B: how many got a different decision (kept in one, failed in the
other), how many of those were `uncertain` in at least one run, the mean absolute difference
of their pass fractions, and each differing sample. Exits 1 when a differing sample is
certain in both runs.

With RUN_C and CANDIDATE: CANDIDATE is a run of the same samples with a changed replay
(another binary, or the spec's `params.physics`) and the same `--ensemble-seed` as RUN_C, so
that the two differ by the change alone. The seed-to-seed figures are those of the three
reference pairs (A-B, A-C, B-C); the change is acceptable when the candidate's mean absolute
difference of pass fractions from RUN_C is at most their mean, and its kept share differs
from RUN_C's by no more than the largest kept-share gap between two seeds (at least one
sample): the change moves the pass fractions less than drawing the ensemble again does.
Exits 1 when it does not.
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


def candidate(refs, c, cand):
    pairs = [(0, 1), (0, 2), (1, 2)]
    seeds = []
    gaps = []
    for i, j in pairs:
        n, si, sj, diff = figures(refs[i], refs[j])
        seeds.append(diff)
        gaps.append(abs(si - sj))
        print(f"reference seeds {'ABC'[i]}-{'ABC'[j]}: kept share {si:.3f} / {sj:.3f}, mean |pass fraction| difference {diff:.3f} over {n}")
    n, sc, sx, diff = figures(c, cand)
    differ = [i for i in sorted(set(c) & set(cand)) if c[i]["status"] != cand[i]["status"]]
    certain = [
        i for i in differ if c[i]["uncertain"] != "true" and cand[i]["uncertain"] != "true"
    ]
    seed_mean = sum(seeds) / len(seeds)
    allowed = max(max(gaps), 1 / n)
    ok = diff <= seed_mean and abs(sx - sc) <= allowed + 1e-12
    print(
        f"candidate against C (same ensemble seed): kept share {sx:.3f} against {sc:.3f} "
        f"(gap {abs(sx - sc):.3f}, seeds' largest {max(gaps):.3f}, one sample {1 / n:.3f}); "
        f"decisions that differ {len(differ)} of {n} ({len(certain)} certain in both); "
        f"mean |pass fraction| difference {diff:.3f} against the seeds' mean {seed_mean:.3f}: "
        + ("within" if ok else "NOT within")
    )
    return ok


def main():
    if len(sys.argv) not in (3, 5):
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
    if len(sys.argv) == 5:
        c = rows(sys.argv[3])
        ok &= candidate([a, b, c], c, rows(sys.argv[4]))
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
