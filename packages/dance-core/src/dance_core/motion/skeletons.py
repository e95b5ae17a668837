"""Built-in skeletons: our default ``dance24`` (SMPL-24 joint names, our own proportions), Transflower's
21-joint BVH set, OpenPose BODY_25 (2D)."""

from __future__ import annotations

import numpy as np

from dance_core.motion.skeleton import Skeleton

SMPL_NAMES = [
    "Pelvis", "L_Hip", "R_Hip", "Spine1", "L_Knee", "R_Knee", "Spine2", "L_Ankle", "R_Ankle", "Spine3",
    "L_Foot", "R_Foot", "Neck", "L_Collar", "R_Collar", "Head", "L_Shoulder", "R_Shoulder", "L_Elbow",
    "R_Elbow", "L_Wrist", "R_Wrist", "L_Hand", "R_Hand",
]
SMPL_PARENTS = [-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21]
#: SMPL's 24 joints in body-model order, as the AIST++ feature code names them
SMPL_AIST_NAMES = (
    "root",
    "lhip",
    "rhip",
    "belly",
    "lknee",
    "rknee",
    "spine",
    "lankle",
    "rankle",
    "chest",
    "ltoes",
    "rtoes",
    "neck",
    "linshoulder",
    "rinshoulder",
    "head",
    "lshoulder",
    "rshoulder",
    "lelbow",
    "relbow",
    "lwrist",
    "rwrist",
    "lhand",
    "rhand",
)
#: SMPL-24 indices of (left ankle, left toe, right ankle, right toe)
SMPL_FEET = (7, 10, 8, 11)
#: the same joints by name in the other skeletons we know (SMPL's, AIST++'s, Mixamo's)
FEET_BY_NAME = (
    ("L_Ankle", "L_Foot", "R_Ankle", "R_Foot"),
    ("lankle", "ltoes", "rankle", "rtoes"),
    ("LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase"),
)
#: Our default body, from published anthropometry: David A. Winter, *Biomechanics and Motor Control of
#: Human Movement* (4th ed., Wiley 2009), Fig. 4.1, segment lengths and joint heights as fractions of
#: body height H (after Drillis & Contini, 1966). Values are (x, y, z) in units of H, Y up, +X to the
#: body's left, +Z forward, feet on the floor (y = 0), arms out in a T-pose. From Winter: heights of
#: shoulder 0.818, chest 0.720, hip joint (greater trochanter) 0.530, knee 0.285, ankle 0.039, top of
#: head 1.0; shoulder width 0.259, upper arm 0.186, forearm 0.146, hand 0.108, foot length 0.152.
#: Our own choices (no source): hip joints 0.053 either side of the midline; the shoulder joints 0.020
#: inside the ends of Winter's shoulder width (joint centres lie inside the acromia); the pelvis joint 0.045 above
#: them; the spine split evenly up to the chest; collar bones from 0.012 off the midline at 0.800;
#: neck 0.850 and head 0.900 (between the shoulder, chin 0.870 and eye 0.936 heights of Winter's figure);
#: the hand joint halfway along the hand; the ankle 0.2 of the foot length in front of the heel, the
#: ball of the foot (SMPL's "Foot") 0.55 of it further, 0.012 up.
_W = {  # Winter's fractions of H used below
    "shoulder": 0.818, "chest": 0.720, "hip": 0.530, "knee": 0.285, "ankle": 0.039, "top": 1.0,
    "shoulder_width": 0.259, "upper_arm": 0.186, "forearm": 0.146, "hand": 0.108, "foot": 0.152,
}
_HIP_X, _PELVIS_UP, _COLLAR_X, _COLLAR_Y, _NECK_Y, _HEAD_Y = 0.053, 0.045, 0.012, 0.800, 0.850, 0.900
_BALL_Y, _SHOULDER_IN = 0.012, 0.020
#: body height of the default skeleton, metres
DEFAULT_HEIGHT = 1.70


def _default_rest() -> tuple[np.ndarray, dict[int, np.ndarray]]:
    """Rest joint positions ``(24, 3)`` in units of H, SMPL's joint order, and End Site offsets."""
    w = _W
    pelvis = w["hip"] + _PELVIS_UP
    spine = np.linspace(pelvis, w["chest"], 4)[1:]
    sx = w["shoulder_width"] / 2 - _SHOULDER_IN
    elbow, wrist = sx + w["upper_arm"], sx + w["upper_arm"] + w["forearm"]
    hand = wrist + w["hand"] / 2
    ball_z = 0.55 * w["foot"]
    rows = {
        "Pelvis": (0, pelvis, 0), "Spine1": (0, spine[0], 0), "Spine2": (0, spine[1], 0),
        "Spine3": (0, spine[2], 0), "Neck": (0, _NECK_Y, 0), "Head": (0, _HEAD_Y, 0),
    }
    for side, sign in (("L", 1.0), ("R", -1.0)):
        rows |= {
            f"{side}_Hip": (sign * _HIP_X, w["hip"], 0), f"{side}_Knee": (sign * _HIP_X, w["knee"], 0),
            f"{side}_Ankle": (sign * _HIP_X, w["ankle"], 0), f"{side}_Foot": (sign * _HIP_X, _BALL_Y, ball_z),
            f"{side}_Collar": (sign * _COLLAR_X, _COLLAR_Y, 0), f"{side}_Shoulder": (sign * sx, w["shoulder"], 0),
            f"{side}_Elbow": (sign * elbow, w["shoulder"], 0), f"{side}_Wrist": (sign * wrist, w["shoulder"], 0),
            f"{side}_Hand": (sign * hand, w["shoulder"], 0),
        }
    rest = np.array([rows[n] for n in SMPL_NAMES], float)
    ends = {SMPL_NAMES.index("Head"): np.array([0.0, w["top"] - _HEAD_Y, 0.0])}
    for side, sign in (("L", 1.0), ("R", -1.0)):
        ends[SMPL_NAMES.index(f"{side}_Foot")] = np.array([0.0, -_BALL_Y, 0.25 * w["foot"]])
        ends[SMPL_NAMES.index(f"{side}_Hand")] = np.array([sign * w["hand"] / 2, 0.0, 0.0])
    return rest, ends


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


def dance24(height: float = DEFAULT_HEIGHT) -> Skeleton:
    """Our default skeleton: SMPL's 24 joint names and parent order (so SMPL / AIST++ motion maps onto
    it) with proportions from published anthropometry (Winter 2009, see ``_W``), ``height`` metres
    tall, standing on the floor in a T-pose, End Sites at the top of the head, finger tips and toes."""
    rest, ends = _default_rest()
    rest, parents = rest * height, np.array(SMPL_PARENTS)
    offsets = rest - np.where(parents[:, None] >= 0, rest[np.maximum(parents, 0)], 0.0)
    return Skeleton(list(SMPL_NAMES), list(SMPL_PARENTS), offsets, end_sites={k: v * height for k, v in ends.items()},
                    units="m", name="dance24")


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
