#!/usr/bin/env python3
"""Reads a LeRobot v3 dataset written by `dexwarp export` with pyarrow alone and compares
it with the values the test expects (a JSON file the Rust test writes from the
demonstrations and reports, not from our parquet reader).

usage: readback.py DATASET EXPECTED.json      exit 0 when every value matches
"""
import glob
import json
import os
import sys

import pyarrow.parquet as pq


def table(paths):
    import pyarrow as pa

    return pa.concat_tables([pq.read_table(p) for p in sorted(paths)])


def main(root, expected_path):
    with open(expected_path) as f:
        want = json.load(f)
    with open(os.path.join(root, "meta", "info.json")) as f:
        info = json.load(f)
    problems = []

    def check(what, got, exp):
        if got != exp:
            problems.append(f"{what}: got {got!r:.200}, expected {exp!r:.200}")

    check("codebase_version", info["codebase_version"], "v3.0")
    check("total_frames", info["total_frames"], len(want["frames"]["index"]))
    data = table(glob.glob(os.path.join(root, "data", "chunk-*", "file-*.parquet")))
    for key, values in want["frames"].items():
        check(f"data column {key}", data.column(key).to_pylist(), values)
    for key in ("observation.state", "observation.environment_state", "action"):
        t = data.schema.field(key).type
        check(f"{key} type", str(t).startswith("fixed_size_list<item: float>"), True)
    episodes = table(glob.glob(os.path.join(root, "meta", "episodes", "chunk-*", "file-*.parquet")))
    for key, values in want["episodes"].items():
        check(f"episodes column {key}", episodes.column(key).to_pylist(), values)
    tasks = pq.read_table(os.path.join(root, "meta", "tasks.parquet"))
    check("tasks", tasks.column("task").to_pylist(), want["tasks"])
    pandas = json.loads(tasks.schema.metadata[b"pandas"])
    check("tasks pandas index", pandas["index_columns"], ["task"])
    if problems:
        print("\n".join(problems))
        return 1
    print(f"pyarrow {__import__('pyarrow').__version__}: {len(want['frames']['index'])} frames, "
          f"{len(want['episodes'])} episode columns, {len(want['tasks'])} tasks as expected")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))
