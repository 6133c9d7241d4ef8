#!/usr/bin/env python3
"""Reads a robomimic HDF5 file written by `dexwarp export --format robomimic` with h5py alone,
the way robomimic's own loader reads it (data/demo_N, attributes, mask/<key> as byte
strings), and compares it with the values the test expects (a JSON file the Rust test writes
from the demonstrations and reports, not from our HDF5 reader).

usage: readback_robomimic.py FILE.hdf5 EXPECTED.json      exit 0 when every value matches
"""
import json
import sys

import h5py


def main(path, expected_path):
    with open(expected_path) as f:
        want = json.load(f)
    problems = []

    def check(what, got, exp):
        if got != exp:
            problems.append(f"{what}: got {got!r:.200}, expected {exp!r:.200}")

    with h5py.File(path, "r") as f:
        data = f["data"]
        check("data.attrs[total]", int(data.attrs["total"]), want["total"])
        env = json.loads(data.attrs["env_args"])
        check("env_args.env_name", env["env_name"], want["env_name"])
        check("env_args.type", env["type"], 2)
        check("env_args has env_kwargs", isinstance(env.get("env_kwargs"), dict), True)
        check("data.attrs[actions_normalized]", bool(data.attrs["actions_normalized"]), True)
        offset = data.attrs["action_offset"]
        scale = data.attrs["action_scale"]
        demos = sorted(data.keys(), key=lambda k: int(k[5:]))
        check("demos", demos, [f"demo_{i}" for i in range(len(want["demos"]))])
        for name, exp in zip(demos, want["demos"]):
            g = data[name]
            check(f"{name} num_samples", int(g.attrs["num_samples"]), exp["num_samples"])
            for sub in ("obs", "next_obs"):
                check(f"{name}/{sub} keys", sorted(g[sub].keys()), sorted(exp[sub].keys()))
                for key, rows in exp[sub].items():
                    ds = g[sub][key]
                    check(f"{name}/{sub}/{key} dtype", str(ds.dtype), "float32")
                    check(f"{name}/{sub}/{key}", ds[()].tolist(), rows)
            for key in ("states", "rewards", "dones"):
                check(f"{name}/{key}", g[key][()].tolist(), exp[key])
            # The targets, and the actions scaled into [-1, 1] that scale back to them.
            check(f"{name}/actions_abs", g["actions_abs"][()].tolist(), exp["actions"])
            actions = g["actions"][()]
            check(f"{name}/actions within [-1, 1]",
                  bool((actions >= -1).all() and (actions <= 1).all()), True)
            back = actions.astype("float64") * scale + offset
            worst = float(abs(back - g["actions_abs"][()].astype("float64")).max())
            check(f"{name}/actions scale back within 1e-6", worst < 1e-6, True)
            for key, value in exp["attrs"].items():
                got = g.attrs.get(key)
                got = got.item() if hasattr(got, "item") else got
                check(f"{name}.attrs[{key}]", got, value)
            check(f"{name}.attrs[failure_reasons]", json.loads(g.attrs["failure_reasons"]),
                  exp["failure_reasons"])
        for key, names in want["masks"].items():
            got = [e.decode("utf-8") for e in f[f"mask/{key}"][()]]
            check(f"mask/{key}", got, names)
    if problems:
        print("\n".join(problems))
        return 1
    print(f"h5py {h5py.__version__}: {len(want['demos'])} demos, {want['total']} frames, "
          f"{len(want['masks'])} masks as expected")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))
