"""Core's file formats: WAV audio, and motion as NPZ, BVH, glTF binary, SMPL pickles, joint arrays, keypoints;
plus motion representations (skeletal motion to model features and back)."""

from __future__ import annotations

from dance_core.formats import configs as fc
from dance_core.hookspecs import hookimpl
from dance_core.motion import configs as mc

_F = "dance_core.formats"


@hookimpl
def register_audio_readers(register):
    """Core's WAV reader."""
    register("wav", fc.WavReaderConfig, f"{_F}.wav:build", "PCM and float WAV files",
             suffixes=(".wav", ".wave"))


@hookimpl
def register_motion_formats(register):
    """Core's readable and writable motion formats."""
    register("npz", fc.NpzFormatConfig, f"{_F}.npz:build", "frame array, fps and channel names",
             suffixes=(".npz",))
    register("bvh", fc.BvhFormatConfig, f"{_F}.bvh:build",
             "BVH mocap: any channel order, End Sites, continuous Euler", suffixes=(".bvh",))
    register("glb", fc.GlbFormatConfig, f"{_F}.glb:build",
             "glTF 2.0 binary: skeleton, skin, animation, a box body and markers (metres, Y up)", suffixes=(".glb",))
    register("fbx", fc.GlbFormatConfig, f"{_F}.fbx:build",
             "FBX through Blender when installed: the glb's armature, body and baked animation written; "
             "one armature's animation read", suffixes=(".fbx",))
    register("smpl", fc.SmplFormatConfig, f"{_F}.smpl:build",
             "AIST++ SMPL pickles (smpl_poses, smpl_trans) on your SMPL model's joints (model, --smpl-model), "
             "restricted unpickler", suffixes=(".pkl",))
    register("joints", fc.JointsFormatConfig, f"{_F}.joints:build",
             "HumanML3D new_joints arrays (T, 22, 3)", suffixes=(".npy",))
    register("keypoints", fc.KeypointsFormatConfig, f"{_F}.keypoints:build",
             "2D OpenPose BODY_25 keypoints as JSON (ours or DanceRevolution's dance_array)", suffixes=(".json",))


@hookimpl
def register_motion_representations(register):
    """Core's motion representations (skeletal motion to model features and back)."""
    register("rotations", mc.RotationRepresentationConfig, "dance_core.motion.representation:build_rotations",
             "root (Transflower's ground deltas or absolute) + joint rotations (expmap, 6d, quat, matrix)")
    register("positions", mc.PositionRepresentationConfig, "dance_core.motion.representation:build_positions",
             "root ground deltas + joint positions relative to the root (3D or 2D keypoints)")
