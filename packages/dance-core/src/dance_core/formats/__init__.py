"""Registered motion file formats: BVH, AIST++/SMPL pickles, joint-position arrays and 2D keypoints."""
