#!/usr/bin/env python3
"""Does a keep/drop decision survive a micrometre? Re-validates augment's outputs under noise.

    scripts/revalidate_noise.py BIN RUN [--repeats 4] [--limit 20] [--ensemble K]
                                [--ensemble-seed S] [--sigma 1e-6]

For each sample of the `dexwarp augment` output folder RUN (kept/ and failed/, in id order,
at most --limit), validates its output trajectory once as written and --repeats times with
Gaussian noise of --sigma (m on every object and wrist position, rad on every joint), with
the binary BIN and the ensemble options given (those of the augment run, or others), and
counts the samples whose verdict under noise differs from the one augment wrote, and from
the one BIN gives the file as written. The noisy files
keep the trajectory's name, so the ensemble draws are the same.
"""
import argparse
import json
import random
import subprocess
import sys
import tempfile
from pathlib import Path


def verdict(binary, demo, extra):
    with tempfile.TemporaryDirectory() as out:
        subprocess.run(
            [binary, "validate", str(demo), "--out", out, *extra],
            check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
        p = json.loads((Path(out) / "report.json").read_text())["physics"]
    e = p.get("ensemble") or {}
    return p["verdict"], e.get("pass_fraction"), e.get("uncertain")


def noisy(doc, rng, sigma):
    for f in doc["frames"]:
        for key in ("object", "wrist"):
            f[key]["position"] = [x + rng.gauss(0.0, sigma) for x in f[key]["position"]]
        f["joints"] = [q + rng.gauss(0.0, sigma) for q in f["joints"]]
    return doc


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("binary")
    ap.add_argument("run", type=Path)
    ap.add_argument("--repeats", type=int, default=4)
    ap.add_argument("--limit", type=int, default=20)
    ap.add_argument("--ensemble", type=int)
    ap.add_argument("--ensemble-seed", type=int)
    ap.add_argument("--sigma", type=float, default=1e-6)
    a = ap.parse_args()
    extra = []
    if a.ensemble is not None:
        extra += ["--ensemble", str(a.ensemble)]
    if a.ensemble_seed is not None:
        extra += ["--ensemble-seed", str(a.ensemble_seed)]
    samples = sorted(
        (d for status in ("kept", "failed") for d in (a.run / status).glob("*") if d.is_dir()),
        key=lambda d: d.name,
    )[: a.limit]
    rng = random.Random(1)
    changed = changed_as_is = 0
    for d in samples:
        report = json.loads((d / "report.json").read_text())
        written = report["physics"]["verdict"]
        demo = next(p for p in d.glob("*.demo.json") if not p.name.startswith("baseline"))
        doc = json.loads(demo.read_text())
        as_is = verdict(a.binary, demo, extra)
        under = []
        for k in range(a.repeats):
            path = d / f".noisy{k}.demo.json"
            path.write_text(json.dumps(noisy(json.loads(json.dumps(doc)), rng, a.sigma)))
            try:
                under.append(verdict(a.binary, path, extra))
            finally:
                path.unlink()
        flips = sum(v[0] != written for v in under)
        changed += flips > 0
        changed_as_is += any(v[0] != as_is[0] for v in under)
        print(
            f"{d.name}: written {written}, as is {as_is[0]} ({as_is[1]}), under noise "
            + ", ".join(f"{v[0]} ({v[1]})" for v in under)
            + (" CHANGED" if flips else ""),
            flush=True,
        )
    print(f"decision changed under {a.sigma:g} noise on {changed} of {len(samples)} samples")
    print(
        f"against this binary's own decision on the file as written (other ensemble options "
        f"than the run's): changed on {changed_as_is} of {len(samples)}"
    )


if __name__ == "__main__":
    main()
