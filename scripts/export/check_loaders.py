#!/usr/bin/env python3
"""Our exports in the real libraries: LeRobot 0.4.4 and robomimic 0.3.0 from PyPI (see
check_loaders.sh, which makes the venv and the exports).

usage: check_loaders.py WORK      WORK holds lerobot/ (a LeRobot export) and robomimic.hdf5

Checks, each printed as one line, exit 1 on the first failure:
- LeRobot: LeRobotDataset loads the export, a DataLoader with delta_timestamps gives a batch;
  delete_episodes and split_dataset write datasets whose meta/stats.json has the statistics of
  every feature; lerobot-train runs two steps of ACT on it (CPU, no hub, no wandb).
- robomimic: get_dataset_info exits 0 (actions in [-1, 1]); SequenceDataset loads the `pass`
  filter key; two training steps of BC.
"""
import json
import subprocess
import sys
from pathlib import Path

FEATURES = [
    "observation.state",
    "observation.environment_state",
    "action",
    "timestamp",
    "frame_index",
    "episode_index",
    "index",
    "task_index",
]
STATS = ["min", "max", "mean", "std", "count"]


def ok(what):
    print(f"ok: {what}", flush=True)


def fail(what):
    print(f"FAILED: {what}", flush=True)
    sys.exit(1)


def stats_complete(root, what):
    stats = json.loads((Path(root) / "meta/stats.json").read_text())
    missing = [f"{f}/{s}" for f in FEATURES for s in STATS if s not in stats.get(f, {})]
    if missing:
        fail(f"{what}: meta/stats.json lacks {', '.join(missing[:6])} ({len(missing)} in all)")
    ok(f"{what}: meta/stats.json has {len(stats)} features with min, max, mean, std, count")


def lerobot_checks(work):
    import torch
    from lerobot.datasets.dataset_tools import delete_episodes, split_dataset
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    root = work / "lerobot"
    ds = LeRobotDataset("dexwarp/check", root=root)
    ok(f"LeRobotDataset: {ds.num_episodes} episodes, {ds.num_frames} frames, fps {ds.fps}")
    dt = [i / ds.fps for i in range(4)]
    ds = LeRobotDataset("dexwarp/check", root=root, delta_timestamps={"action": dt})
    batch = next(iter(torch.utils.data.DataLoader(ds, batch_size=4, shuffle=True)))
    ok(f"DataLoader with delta_timestamps: action batch {tuple(batch['action'].shape)}")
    deleted = delete_episodes(ds, episode_indices=[0], output_dir=work / "lerobot_deleted",
                              repo_id="dexwarp/check_deleted")
    ok(f"delete_episodes: {deleted.meta.total_episodes} episodes left")
    stats_complete(work / "lerobot_deleted", "after delete_episodes")
    n = ds.meta.total_episodes
    half = max(1, n // 2)
    splits = split_dataset(ds, splits={"train": list(range(half)), "val": list(range(half, n))},
                           output_dir=work / "lerobot_split")
    for name, part in splits.items():
        ok(f"split_dataset {name}: {part.meta.total_episodes} episodes")
        stats_complete(part.root, f"after split_dataset ({name})")
    train = subprocess.run(
        [str(Path(sys.executable).parent / "lerobot-train"),
         "--dataset.repo_id=dexwarp/check", f"--dataset.root={root}",
         "--policy.type=act", "--policy.device=cpu", "--policy.push_to_hub=false",
         "--steps=2", "--batch_size=2", "--num_workers=0", "--log_freq=1",
         "--save_checkpoint=false", "--eval_freq=0", "--wandb.enable=false",
         f"--output_dir={work / 'lerobot_train'}"],
        capture_output=True, text=True)
    if train.returncode != 0:
        fail(f"lerobot-train: exit {train.returncode}\n{train.stderr[-3000:]}")
    ok("lerobot-train: two steps of ACT")


def robomimic_checks(work):
    path = work / "robomimic.hdf5"
    info = subprocess.run(
        [sys.executable, "-m", "robomimic.scripts.get_dataset_info", "--dataset", str(path)],
        capture_output=True, text=True)
    if info.returncode != 0:
        fail(f"get_dataset_info: exit {info.returncode}\n{info.stdout[-2000:]}{info.stderr[-2000:]}")
    ok("get_dataset_info: exit 0")
    import robomimic.utils.obs_utils as ObsUtils
    import robomimic.utils.train_utils as TrainUtils
    from robomimic.config import config_factory
    from robomimic.utils.dataset import SequenceDataset

    keys = ["wrist_pos", "wrist_quat", "joint_pos", "object_pos", "object_quat"]
    ObsUtils.initialize_obs_utils_with_obs_specs({"obs": {"low_dim": keys, "rgb": []}})
    ds = SequenceDataset(hdf5_path=str(path), obs_keys=keys, dataset_keys=["actions"],
                         load_next_obs=False, seq_length=1, filter_by_attribute="pass")
    ok(f"SequenceDataset, filter key pass: {len(ds)} samples")
    config = config_factory("bc")
    with config.values_unlocked():
        config.train.data = str(path)
        config.train.output_dir = str(work / "robomimic_train")
        config.train.num_epochs = 1
        config.train.batch_size = 4
        config.train.num_data_workers = 0
        config.train.hdf5_filter_key = "pass"
        config.experiment.epoch_every_n_steps = 2
        config.experiment.validate = False
        config.experiment.rollout.enabled = False
        config.experiment.render_video = False
        config.experiment.save.enabled = False
        config.experiment.logging.log_tb = False
        config.observation.modalities.obs.low_dim = keys
        config.observation.modalities.obs.rgb = []
    from robomimic.scripts.train import train
    train(config, device="cpu")
    ok("robomimic train: one epoch of two BC steps")


def main(work):
    work = Path(work)
    lerobot_checks(work)
    robomimic_checks(work)
    print("every check passed")


if __name__ == "__main__":
    main(sys.argv[1])
