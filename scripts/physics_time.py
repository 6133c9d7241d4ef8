#!/usr/bin/env python3
"""Physics time per trajectory of two dexwarp binaries, in the same run.

    scripts/physics_time.py OLD_BIN NEW_BIN [--runs N] [--threshold-mm 3.5] [CONFIG ...]

Runs `warp --config C --threshold-mm T` with each binary in turn, N times per config (all
configs of scenes/configs by default), and prints per config the median physics time of
each (the report's `physics.timing_s.total`, its replay part, steps simulated and skipped),
the verdicts, and the mean over the configs with the ratio old / new. Both binaries replay
once (`--ensemble 1` where the binary has the ensemble verdict): the figures are per replay.
"""
import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def single_replay_flags(binary):
    """`--ensemble 1` for a binary with the ensemble verdict (one replay, as older binaries
    judge), nothing for one without it."""
    text = subprocess.run([binary, "warp", "--help"], capture_output=True, text=True).stdout
    return ["--ensemble", "1"] if "--ensemble" in text else []


def run(binary, config, threshold):
    with tempfile.TemporaryDirectory() as out:
        subprocess.run(
            [binary, "warp", "--config", str(config), "--threshold-mm", str(threshold), "--out", out,
             *single_replay_flags(binary)],
            check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT,
        )
        report = json.loads((Path(out) / "report.json").read_text())
    p = report["physics"]
    return {
        "total": p["timing_s"]["total"],
        "replay": p["timing_s"]["replay"],
        "steps": p["replay"]["steps"],
        "skipped": p["replay"].get("skipped_steps", 0),
        "stopped": p["replay"].get("stopped_frame"),
        "verdict": p["verdict"],
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("configs", nargs="*")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--threshold-mm", type=float, default=3.5)
    a = ap.parse_intermixed_args()
    configs = [Path(c) for c in a.configs] or sorted((ROOT / "scenes/configs").glob("*.json"))
    print("| config | old s | new s | old / new | old replay s | new replay s | steps old | steps new | skipped | verdict old | verdict new |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|")
    means = {"old": [], "new": []}
    changed = []
    for c in configs:
        runs = {"old": [], "new": []}
        for _ in range(a.runs):
            for which, binary in (("old", a.old), ("new", a.new)):
                runs[which].append(run(binary, c, a.threshold_mm))
        med = {w: statistics.median(r["total"] for r in runs[w]) for w in runs}
        rep = {w: statistics.median(r["replay"] for r in runs[w]) for w in runs}
        o, n = runs["old"][0], runs["new"][0]
        for w in means:
            means[w].append(med[w])
        if o["verdict"] != n["verdict"]:
            changed.append(c.stem)
        print(f"| {c.stem} | {med['old']:.3f} | {med['new']:.3f} | {med['old'] / med['new']:.2f} | "
              f"{rep['old']:.3f} | {rep['new']:.3f} | {o['steps']} | {n['steps']} | {n['skipped']} | "
              f"{o['verdict']} | {n['verdict']}{' (stopped at ' + str(n['stopped']) + ')' if n['stopped'] is not None else ''} |")
        sys.stdout.flush()
    mo, mn = statistics.mean(means["old"]), statistics.mean(means["new"])
    print(f"| mean of {len(configs)} | {mo:.3f} | {mn:.3f} | {mo / mn:.2f} | | | | | | | |")
    print(f"largest new: {max(means['new']):.3f} s; verdicts changed: {changed or 'none'}")


if __name__ == "__main__":
    main()
