"""Choreography from real moves: a motion graph over real dance takes, walked to a song's beats.

The takes (any rig, retargeted onto one skeleton by the ``mocap`` dataset) are cut at the dancer's own
accents (:func:`dance_core.motion.body.body_beats`: pauses of the limbs relative to the body),
so every *segment* runs from one accent to the next. A segment may follow the one after it in its
take (the natural successor) or any segment whose first pose is close to its last (a *transition*):
poses compared in the body's own frame (joints relative to the pelvis, facing forward) with their
velocities, per leg length. Walking the graph, each segment is time-warped so that its accents land on
the song's beats (one segment to one or two beats, whichever needs less warping, within
``max_warp``), placed where the previous one ended (position and heading carried over), and blended
in over ``blend`` seconds when it is a transition. A new section of the song, or a phrase that has run
``phrase_bars`` bars, prefers a jump to another take. Last (:func:`real_dance`), grounding puts the
feet on the floor and pins them where they are planted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dance_core.errors import DataError
from dance_core.motion.motion import Motion
from dance_core.motion.root import heading
from dance_core.motion.rotations import quat_mul, quat_rotate, quat_slerp, yaw_quat


@dataclass(frozen=True)
class Segment:
    """Frames ``[start, stop]`` of take ``take`` (both ends are accents)."""

    take: int
    start: int
    stop: int

    @property
    def frames(self) -> int:
        """Frames spanned (stop - start)."""
        return self.stop - self.start


@dataclass
class GraphOptions:
    """Cutting, matching and walking."""

    min_seconds: float = 0.2  # segments shorter than this merge with the next
    max_seconds: float = 1.6  # and longer ones are split at their middle
    neighbours: int = 8  # transitions kept per segment end
    max_warp: float = 1.5  # a segment is played at most this much faster or slower
    blend: float = 0.25  # seconds over which a transition blends in
    stay: float = 0.7  # chance of the natural successor when there is one
    phrase_bars: int = 4  # after this many bars on one take, prefer another take


def _body_frame(motion: Motion) -> np.ndarray:
    """``(T, J*3 * 2)`` pose features: joints relative to the pelvis in the heading frame, and their
    velocities (times 0.1 s), per leg length."""
    pos = motion.positions()
    yaw = heading(motion.rotations[:, 0])
    rel = pos - pos[:, :1]
    q = yaw_quat(-yaw)
    local = quat_rotate(q[:, None], rel)
    vel = np.gradient(local, axis=0) * motion.fps * 0.1
    leg = max(float(np.percentile(pos[:, 0, 1], 90)), 1e-6)
    return np.concatenate([local.reshape(len(pos), -1), vel.reshape(len(pos), -1)], axis=1) / leg


class MotionGraph:
    """Segments of real takes and the transitions between them (see the module's note)."""

    def __init__(self, takes: list[Motion], names: list[str] | None = None, options: GraphOptions | None = None):
        from dance_core.motion.body import body_beats

        if not takes:
            raise DataError("motion graph: no takes")
        self.options = options or GraphOptions()
        self.takes = takes
        self.names = names or [f"take{i}" for i in range(len(takes))]
        self.fps = takes[0].fps
        if any(abs(t.fps - self.fps) > 1e-6 or not t.skeleton.same_topology(takes[0].skeleton) for t in takes):
            raise DataError("motion graph: every take must be on one skeleton at one frame rate")
        self.features = [_body_frame(t) for t in takes]
        self.segments: list[Segment] = []
        o = self.options
        lo, hi = int(round(o.min_seconds * self.fps)), int(round(o.max_seconds * self.fps))
        for k, take in enumerate(takes):
            cuts = [0] + [int(round(b * self.fps)) for b in body_beats(take.positions(), self.fps,
                                                                          take.skeleton.names)] + [take.n_frames - 1]
            merged = [cuts[0]]
            for c in cuts[1:]:
                if c - merged[-1] >= lo:
                    merged.append(c)
            for a, b in zip(merged[:-1], merged[1:], strict=True):
                pieces = max(1, int(np.ceil((b - a) / hi)))
                edges = np.linspace(a, b, pieces + 1).round().astype(int)
                self.segments += [Segment(k, int(s), int(e)) for s, e in zip(edges[:-1], edges[1:], strict=True)
                                  if e - s >= lo]
        if len(self.segments) < 2:
            raise DataError("motion graph: the takes give fewer than 2 segments")
        self.successor = {}
        for i, (s, t) in enumerate(zip(self.segments[:-1], self.segments[1:], strict=True)):
            if s.take == t.take and s.stop == t.start:
                self.successor[i] = i + 1
        starts = np.stack([self.features[s.take][s.start] for s in self.segments])
        ends = np.stack([self.features[s.take][s.stop] for s in self.segments])
        k = min(o.neighbours, len(self.segments) - 1)
        self.transitions = np.zeros((len(ends), k), int)
        self.cost = np.zeros((len(ends), k))
        sq = (starts**2).sum(1)
        for a in range(0, len(ends), 256):  # in blocks: the full matrix of a large graph would not fit
            e = ends[a:a + 256]
            d = np.sqrt(np.maximum((e**2).sum(1)[:, None] + sq[None] - 2 * e @ starts.T, 0.0) / starts.shape[1])
            d[np.arange(len(e)), np.arange(a, a + len(e))] = np.inf
            nearest = np.argsort(d, axis=1)[:, :k]
            self.transitions[a:a + len(e)] = nearest
            self.cost[a:a + len(e)] = np.take_along_axis(d, nearest, axis=1)

    def next_segment(self, i: int, rng: np.random.Generator, leave_take: bool) -> tuple[int, bool]:
        """The segment after ``i``: its natural successor (unless leaving its take) or a transition,
        drawn with weights falling with the pose distance; and whether it is a transition."""
        o = self.options
        nat = self.successor.get(i)
        if nat is not None and not leave_take and rng.random() < o.stay:
            return nat, False
        cands, cost = self.transitions[i], self.cost[i]
        if leave_take:
            other = [c for c in range(len(cands)) if self.segments[cands[c]].take != self.segments[i].take]
            if other:
                cands, cost = cands[other], cost[other]
        w = np.exp(-(cost - cost.min()) / max(float(np.median(cost) - cost.min()), 1e-6))
        j = int(rng.choice(cands, p=w / w.sum()))
        return j, j != nat

    def _sample(self, seg: Segment, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Root positions and rotations of a segment's take at fractional ``frames`` (linear, slerp)."""
        take = self.takes[seg.take]
        frames = np.clip(frames, 0, take.n_frames - 1)
        lo = np.floor(frames).astype(int)
        hi = np.minimum(lo + 1, take.n_frames - 1)
        w = (frames - lo)[:, None]
        root = (1 - w) * take.root[lo] + w * take.root[hi]
        return root, quat_slerp(take.rotations[lo], take.rotations[hi], w[:, None])

    def dance(self, beats: np.ndarray, seconds: float, fps: float, rng: np.random.Generator,
              downbeats: np.ndarray | None = None, sections: np.ndarray | None = None) -> Motion:
        """A dance of ``seconds`` to ``beats`` (times in s) at ``fps``: segments warped onto beats, each
        placed where the last one ended, transitions blended in; not yet grounded."""
        o = self.options
        beats = np.sort(np.asarray(beats, np.float64))
        if len(beats) < 2:
            raise DataError("motion graph: a dance needs at least 2 beats")
        period = float(np.median(np.diff(beats)))
        before = beats[0] - period * np.arange(int(np.ceil(beats[0] / period)) + 1, 0, -1)
        after = beats[-1] + period * np.arange(1, int(np.ceil(max(seconds - beats[-1], 0) / period)) + 3)
        grid = np.concatenate([before, beats, after])
        bar_starts = np.asarray(downbeats if downbeats is not None else beats[::4], np.float64)
        section_starts = np.asarray(sections if sections is not None else [], np.float64)
        n_out = int(round(seconds * fps))
        out_root = np.zeros((n_out, 3))
        out_rot = np.zeros((n_out, len(self.takes[0].skeleton), 4))
        i = int(rng.integers(len(self.segments)))
        k = int(np.searchsorted(grid, 0.0, side="right")) - 1
        place, yaw, transition, bars = None, 0.0, False, 0
        last_root = last_rot = None
        while k < len(grid) - 1 and grid[k] < seconds:
            seg = self.segments[i]
            natural = seg.frames / self.fps
            n = min((1, 2), key=lambda m: abs(np.log(natural / (grid[min(k + m, len(grid) - 1)] - grid[k]))))
            n = min(n, len(grid) - 1 - k)
            t0, t1 = grid[k], grid[k + n]
            out_t = np.arange(max(0, int(np.ceil(t0 * fps - 1e-9))), min(n_out, int(np.ceil(t1 * fps - 1e-9))))
            # the segment's frames at the output times (time-warped onto the beats), and its last frame
            frames = seg.start + (out_t / fps - t0) / (t1 - t0) * seg.frames
            root, rot = self._sample(seg, np.concatenate([frames, [seg.stop]]))
            if place is None:
                place, yaw = np.array([root[0, 0], 0.0, root[0, 2]]), float(heading(rot[:1, 0])[0])
            turn = yaw_quat(np.array(yaw - heading(rot[:1, 0])[0]))
            root = quat_rotate(turn, root - [root[0, 0], 0.0, root[0, 2]]) + place
            rot[:, 0] = quat_mul(turn, rot[:, 0])
            if transition and last_rot is not None and len(out_t):
                w = np.clip((np.arange(len(root)) + 1) / max(1, round(o.blend * fps)), 0, 1)[:, None]
                rot = quat_slerp(np.repeat(last_rot[None], len(rot), 0), rot, w[:, None])
                root[:, 1] = (1 - w[:, 0]) * last_root[1] + w[:, 0] * root[:, 1]
            if len(out_t):
                out_root[out_t], out_rot[out_t] = root[:-1], rot[:-1]
                last_root, last_rot = root[-2].copy(), rot[-2].copy()
            place, yaw = np.array([root[-1, 0], 0.0, root[-1, 2]]), float(heading(rot[-1:, 0])[0])
            k += n
            if np.any(np.abs(bar_starts - grid[k]) < period / 4):
                bars += 1
            new_section = bool(np.any(np.abs(section_starts - grid[k]) < period / 2))
            nxt, transition = self.next_segment(i, rng, new_section or bars >= o.phrase_bars)
            if self.segments[nxt].take != seg.take:
                bars = 0
            i = nxt
        return Motion(self.takes[0].skeleton, fps, out_root, out_rot)


def real_dance(graph: MotionGraph, beats: np.ndarray, seconds: float, fps: float, rng: np.random.Generator,
               downbeats: np.ndarray | None = None, sections: np.ndarray | None = None) -> Motion:
    """A grounded dance of real moves to ``beats`` (see :meth:`MotionGraph.dance`)."""
    from dance_core.motion.grounding import ground

    return ground(graph.dance(beats, seconds, fps, rng, downbeats, sections))[0]
