"""Built-in skeletons: SMPL-24 (AIST++), Transflower's 21-joint BVH set, OpenPose BODY_25 (2D)."""

from __future__ import annotations

import numpy as np

from dance_core.motion.skeleton import Skeleton

SMPL_NAMES = [
    "Pelvis", "L_Hip", "R_Hip", "Spine1", "L_Knee", "R_Knee", "Spine2", "L_Ankle", "R_Ankle", "Spine3",
    "L_Foot", "R_Foot", "Neck", "L_Collar", "R_Collar", "Head", "L_Shoulder", "R_Shoulder", "L_Elbow",
    "R_Elbow", "L_Wrist", "R_Wrist", "L_Hand", "R_Hand",
]
SMPL_PARENTS = [-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21]
#: rest joint positions (metres, Y up, +X to the body's left, +Z forward) of a mean-shaped SMPL template
SMPL_REST = np.array([
    [-0.0018, -0.2233, 0.0282], [0.0695, -0.3142, 0.0239], [-0.0677, -0.3145, 0.0214],
    [-0.0025, -0.1033, 0.0120], [0.1040, -0.6760, 0.0170], [-0.1060, -0.6767, 0.0141],
    [0.0050, 0.0302, 0.0045], [0.0885, -1.0782, -0.0255], [-0.0863, -1.0725, -0.0236],
    [0.0017, 0.0836, 0.0355], [0.1210, -1.1276, 0.0920], [-0.1184, -1.1287, 0.0998],
    [-0.0130, 0.2952, -0.0143], [0.0733, 0.2055, -0.0017], [-0.0728, 0.2047, -0.0043],
    [0.0102, 0.3574, 0.0485], [0.1648, 0.2316, -0.0138], [-0.1592, 0.2299, -0.0213],
    [0.4149, 0.2122, -0.0360], [-0.4108, 0.2101, -0.0438], [0.6679, 0.2197, -0.0338],
    [-0.6673, 0.2189, -0.0424], [0.7546, 0.2137, -0.0491], [-0.7540, 0.2134, -0.0549],
])

TRANSFLOWER_NAMES = [
    "Hips", "Spine", "Spine1", "Neck", "Head", "RightShoulder", "RightArm", "RightForeArm", "RightHand",
    "LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand", "RightUpLeg", "RightLeg", "RightFoot",
    "RightToeBase", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase",
]
TRANSFLOWER_PARENTS = [-1, 0, 1, 2, 3, 2, 5, 6, 7, 2, 9, 10, 11, 0, 13, 14, 15, 0, 17, 18, 19]
_TF_OFFSETS = [  # centimetres, proportions of an adult Mixamo-style rig
    [0, 95, 0], [0, 10, 0], [0, 25, 0], [0, 20, 0], [0, 10, 2], [-4, 14, 0], [-12, 0, 0], [-27, 0, 0],
    [-25, 0, 0], [4, 14, 0], [12, 0, 0], [27, 0, 0], [25, 0, 0], [-9, -6, 0], [0, -42, 0], [0, -40, 0],
    [0, -6, 13], [9, -6, 0], [0, -42, 0], [0, -40, 0], [0, -6, 13],
]

#: OpenPose BODY_25 keypoints in OpenPose's index order
BODY25_ORDER = [
    "Nose", "Neck", "RShoulder", "RElbow", "RWrist", "LShoulder", "LElbow", "LWrist", "MidHip", "RHip",
    "RKnee", "RAnkle", "LHip", "LKnee", "LAnkle", "REye", "LEye", "REar", "LEar", "LBigToe", "LSmallToe",
    "LHeel", "RBigToe", "RSmallToe", "RHeel",
]
_BODY25_TREE = [  # (name, parent name, offset in metres; the image plane is x right, y up)
    ("MidHip", None, (0, 1.0, 0)), ("Neck", "MidHip", (0, 0.5, 0)), ("Nose", "Neck", (0, 0.15, 0)),
    ("REye", "Nose", (-0.03, 0.03, 0)), ("REar", "REye", (-0.05, 0, 0)), ("LEye", "Nose", (0.03, 0.03, 0)),
    ("LEar", "LEye", (0.05, 0, 0)), ("RShoulder", "Neck", (-0.18, 0, 0)), ("RElbow", "RShoulder", (0, -0.28, 0)),
    ("RWrist", "RElbow", (0, -0.25, 0)), ("LShoulder", "Neck", (0.18, 0, 0)), ("LElbow", "LShoulder", (0, -0.28, 0)),
    ("LWrist", "LElbow", (0, -0.25, 0)), ("RHip", "MidHip", (-0.1, 0, 0)), ("RKnee", "RHip", (0, -0.45, 0)),
    ("RAnkle", "RKnee", (0, -0.42, 0)), ("RHeel", "RAnkle", (0, -0.06, 0)), ("RBigToe", "RAnkle", (-0.02, -0.07, 0)),
    ("RSmallToe", "RAnkle", (-0.06, -0.07, 0)), ("LHip", "MidHip", (0.1, 0, 0)), ("LKnee", "LHip", (0, -0.45, 0)),
    ("LAnkle", "LKnee", (0, -0.42, 0)), ("LHeel", "LAnkle", (0, -0.06, 0)), ("LBigToe", "LAnkle", (0.02, -0.07, 0)),
    ("LSmallToe", "LAnkle", (0.06, -0.07, 0)),
]


def smpl24() -> Skeleton:
    """The SMPL body's 24 joints (AIST++), offsets from a template body at rest (no body model)."""
    offsets = SMPL_REST - np.where(np.array(SMPL_PARENTS)[:, None] >= 0, SMPL_REST[np.maximum(SMPL_PARENTS, 0)], 0.0)
    offsets[0] = SMPL_REST[0]
    return Skeleton(list(SMPL_NAMES), list(SMPL_PARENTS), offsets, units="m", name="smpl24")


def transflower21() -> Skeleton:
    """The 21-joint Mixamo-style set Transflower selects (Spine2 and fingers left out), in cm."""
    ends = {4: np.array([0, 15.0, 0]), 8: np.array([-18.0, 0, 0]), 12: np.array([18.0, 0, 0]),
            16: np.array([0, 0, 8.0]), 20: np.array([0, 0, 8.0])}
    return Skeleton(list(TRANSFLOWER_NAMES), list(TRANSFLOWER_PARENTS), np.array(_TF_OFFSETS, float),
                    end_sites=ends, units="cm", name="transflower21")


def body25() -> Skeleton:
    """OpenPose BODY_25 as a tree rooted at MidHip (used for 2D keypoints; z is 0)."""
    names = [n for n, _, _ in _BODY25_TREE]
    parents = [-1 if p is None else names.index(p) for _, p, _ in _BODY25_TREE]
    return Skeleton(names, parents, np.array([o for _, _, o in _BODY25_TREE], float), units="m", name="body25")
