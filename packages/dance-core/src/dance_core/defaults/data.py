"""Core's datasets: click-track songs with a beat-locked dancer, mixes, and folders of real music/motion
pairs (the synthetic dancer's datasets are the synth plugin's, ``dance_core.defaults.synth``)."""

from __future__ import annotations

from dance_core.data import dataset_configs as dc
from dance_core.hookspecs import hookimpl


@hookimpl
def register_datasets(register):
    """Core's synthetic-beats, mix and folder datasets."""
    register("synthetic-beats", dc.SyntheticBeatsConfig, "dance_core.data.synthetic_beats:build",
             "click-track music with known beats and a beat-locked dancer")
    register("mix", dc.MixConfig, "dance_core.data.mix:build",
             "the clips of several datasets in one training set (optionally without a part's texts)")
    register("folder", dc.FolderDatasetConfig, "dance_core.data.folders:build_folder",
             "a folder of name.<audio> + name.<motion> pairs (optional name.texts), cached features")
    register("aist", dc.AistDatasetConfig, "dance_core.data.folders:build_aist",
             "AIST++ layout: motions/*.pkl (SMPL, 60 fps), wav/, splits/; music id from the name")
    register("mocap", dc.MocapDatasetConfig, "dance_core.data.mocap:build",
             "a folder of motion-capture takes of any rig (no music), retargeted onto one skeleton, cached")
    register("humanml3d", dc.HumanMLConfig, "dance_core.data.folders:build_humanml",
             "HumanML3D new_joints (T, 22, 3) at 20 fps with captions (no music)")
