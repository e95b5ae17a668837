"""A live session: audio in from a source, features and beats as it arrives, the model stepping in its own
thread, poses out to every sink; latency and drops measured.

Threads: the caller's thread reads the source and computes features (cheap; it never waits for the
model, so audio is never dropped); the generation thread steps the model on the frames whose music is
known; each sink writes from its own thread. When generation falls more than ``max_lag`` seconds
behind the music it may step on, it drops frames (holding the last pose) and counts them.

**Latency** of a frame: from the arrival of the audio block that completed the newest music frame it
reads (so the first frame that can react to those samples) to the frame handed to the sinks. Samples
earlier in the same frame hop wait up to one hop more (50 ms at 20 fps). The frame for music time
``t`` needs the audio up to ``t + music_delay`` (the model's look-ahead: a windowed encoder's
``cond_future`` frames, a song-level model's own, and the features' look-ahead), so a figure shown
with the music lags it by that much unless the audio is delayed too.

A frame is posed knowing what the music up to the newest frame it waited for told, and no more: the beat
tracker's rows and settled beats through :class:`~dance_core.live.beat_lock.BeatFeed`, the silence through
:class:`~dance_core.live.silence.SilenceGate` (the figure rests where the music is silent), so the same song
gives the same dance however fast its audio arrives.
"""

from __future__ import annotations

import queue
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dance_core.errors import DanceError
from dance_core.live.beat_lock import BeatClock, BeatFeed
from dance_core.live.features import LiveFeatures
from dance_core.live.generator import LiveGenerator
from dance_core.live.pose import LivePoses, Pose, PoseDecoder
from dance_core.live.silence import FLOOR_DB, SilenceGate
from dance_core.live.texts import LiveTexts, parse_command

#: seconds generation may fall behind the music it could step on before it drops frames
MAX_LAG = 0.25


@dataclass
class LiveStats:
    """What a session measured."""

    frames: int = 0
    dropped: int = 0
    latencies: list[float] = field(default_factory=list)
    times: list[float] = field(default_factory=list)  # the music time (s) of each frame whose latency is kept
    first: list[bool] = field(default_factory=list)  # whether each frame was the first of its model step
    music_seconds: float = 0.0
    wall_seconds: float = 0.0
    stopped: str = "end of input"

    def summary(self, extra: dict[str, Any]) -> dict[str, Any]:
        """A JSON-able report: frames, drops, the latency distribution in ms, over the whole run and per minute
        of music (``latency_ms_by_minute``: is it growing?), and over the first frame of each model step alone
        (``latency_ms_step_first``: the first frame that can react to the music; a step of several frames, such
        as a TM2D token's 8, gives the rest after posing the ones before)."""
        lat, minute = np.asarray(self.latencies) * 1000.0, np.asarray(self.times, np.float64) // 60
        by_minute = [_distribution(lat[minute == m]) for m in np.unique(minute)] if len(lat) > 0 else []
        return {"frames": self.frames, "dropped_frames": self.dropped, "music_seconds": round(self.music_seconds, 3),
                "wall_seconds": round(self.wall_seconds, 3), "stopped": self.stopped, "latency_ms": _distribution(lat),
                "latency_ms_by_minute": by_minute,
                "latency_ms_step_first": _distribution(lat[np.asarray(self.first, bool)]) if len(lat) else {},
                **extra}


def _distribution(lat: np.ndarray) -> dict[str, float]:
    """p50, p95, p99, max and mean of latencies (ms); empty for none."""
    if not len(lat):
        return {}
    return ({k: round(float(np.percentile(lat, q)), 2) for k, q in (("p50", 50), ("p95", 95), ("p99", 99))}
            | {"max": round(float(lat.max()), 2), "mean": round(float(lat.mean()), 2)})


def frame_message(index: int, fps: float, pose: Pose) -> dict:
    """A frame as sinks send it: ``t`` (music time, s), root position, rotations (xyzw), positions (m)."""
    out = {"t": round(index / fps, 4), "frame": index, "root": np.round(pose.root, 5).tolist()}
    if pose.rotations is not None:
        out["rotations"] = np.round(pose.rotations, 5).tolist()
    out["positions"] = np.round(pose.positions, 5).tolist()
    return out


class LiveSession:
    """One run of ``dance live``: ``run()`` plays the source to its end (or Ctrl-C, or every sink's
    consumer gone) and returns the summary."""

    def __init__(self, composer, source, sinks: list, seed_motion: str | None = None, max_lag: float = MAX_LAG,
                 texts: list[str] = (), control=None, lookahead: float | None = None,
                 silence: float | None = FLOOR_DB):
        from dance_core.runtime import generation_threads

        self.composer, self.source, self.sinks = composer, source, sinks
        recipe = composer.recipe
        self.fps = recipe.fps
        beats = frozenset(e.name for e in composer.registry.entries("feature") if e.info.get("beats"))
        self.features = LiveFeatures(composer.stack, composer.checkpoint, source.rate, beats)
        if recipe.compose.beat_align and self.features.beat_part is None:
            self.features.tracker = _tracker(composer.registry, self.fps, source.rate)
        self.generator = LiveGenerator(composer.model, recipe, composer.seed(seed_motion), composer.device,
                                       None if lookahead is None else int(round(lookahead * self.fps)))
        self.texts, self.control, self.commands = None, control, queue.Queue()
        self.text_log: list[dict] = []  # what each command did
        if texts or control is not None:
            self.texts = LiveTexts(composer.stack, composer.checkpoint, composer.device)
            self.features.texts = self.texts
            for given in texts:
                span = parse_command(given, 0.0)
                self.texts.add(span)
                self.text_log.append(_logged(given, span))
            self.generator.texts(self.texts.spans())
        self.decoder = PoseDecoder(composer.checkpoint, composer.registry, self.fps)
        tracked = self.features.beat_part is not None or self.features.tracker is not None
        self.clock = BeatClock(self.fps) if recipe.compose.beat_align and tracked else None
        self.feed = BeatFeed(self.clock) if self.clock is not None else None
        self.poses = LivePoses(self.decoder, recipe.compose.ground, self.clock, rest=silence is not None)
        self.gate = SilenceGate(self.fps, source.rate, silence if self.poses.rest is not None else None)
        self.threads = generation_threads(composer.model, 1, composer.device, recipe.compose.threads)
        self.max_lag = max(1, int(round(max_lag * self.fps)))
        self.stats = LiveStats()
        self.inbox: queue.Queue = queue.Queue()
        self.arrivals: list[float] = []  # per music frame, when the audio completing it arrived
        self.error: BaseException | None = None
        self.stop = threading.Event()

    def run(self) -> dict[str, Any]:
        """Play the source through; the summary (``stopped`` says why it ended)."""
        for sink in self.sinks:
            sink.start(self.decoder.skeleton_json())
        if self.control is not None:
            self.control.start(self)
        worker = threading.Thread(target=self._generate, name="live-generate", daemon=True)
        begin = time.perf_counter()
        worker.start()
        failure: BaseException | None = None
        samples = 0
        try:
            for block in self.source.blocks():
                arrived = time.perf_counter()
                samples += len(block)
                self.gate.push(block)  # before the features: a frame's level is known when the frame is
                self.inbox.put((self.features.push(block), self.features.take_beats(), self.features.take_settled(),
                                arrived))
                if self.stop.is_set():
                    break
                if self.sinks and all(s.closed.is_set() for s in self.sinks):
                    self.stats.stopped = "every output closed"
                    break
            else:
                self.inbox.put((self.features.finish(), self.features.take_beats(), self.features.take_settled(),
                                time.perf_counter()))
        except KeyboardInterrupt:
            self.stats.stopped = "interrupted"
        except DanceError as exc:
            failure = exc
            self.stats.stopped = "input error"
        finally:
            self.stats.music_seconds = samples / self.source.rate  # what was heard, however the session ended
            self.source.close()
            if self.control is not None:
                self.control.shutdown()
            self.inbox.put(None)
            try:
                worker.join()
            except KeyboardInterrupt:
                self.stop.set()
                worker.join()
                self.stats.stopped = "interrupted"
            for sink in self.sinks:
                sink.close()
            self.stats.wall_seconds = time.perf_counter() - begin
        if self.error is not None:
            raise self.error
        if failure is not None:
            raise failure
        return self.summary()

    def summary(self) -> dict[str, Any]:
        """The report of the session so far."""
        model = self.generator.lookahead / self.fps
        return self.stats.summary({
            "fps": self.fps, "input": self.source.name, "rate": self.source.rate,
            "lookahead_s": {"features": round(self.features.lookahead, 4), "model": round(model, 4)},
            "music_delay_s": round(self.features.lookahead + model, 4),
            "threads": self.threads, "outputs": {s.name: s.stats() for s in self.sinks},
            "grounded": self.poses.grounding is not None, "grounding_lookahead_s": round(self.poses.lookahead, 4),
            "beat_lock": self._lock_summary(),
            "silence": self._silence_summary(),
            **({"texts": list(self.text_log)} if self.texts is not None else {}),
        })

    # -- text commands (from the control's threads; applied by the generation thread before it steps)

    def command(self, line: str, reply=None) -> None:
        """Queue a text command (``now: TEXT``, ``START-END: TEXT``); ``reply`` gets one line about it."""
        self.commands.put((line, reply, None))

    def refuse(self, message: str, reply=None) -> None:
        """Queue input that is no command (reported in its turn among the commands)."""
        self.commands.put((None, reply, message))

    def _refuse(self, message: str, reply) -> None:
        """One line on standard error (and to the client)."""
        print(f"dance: live: {message}", file=sys.stderr, flush=True)
        if len(self.text_log) < 1000:
            self.text_log.append({"command": None, "error": message})
        if reply is not None:
            reply(f"error: {message}")

    def _apply_commands(self) -> None:
        while True:
            try:
                line, reply, error = self.commands.get_nowait()
            except queue.Empty:
                return
            if error is not None:
                self._refuse(error, reply)
                continue
            try:
                span = parse_command(line, self.generator.first_open() / self.fps)
                self.texts.add(span)
            except DanceError as exc:
                self._refuse(str(exc), reply)
                continue
            self.generator.texts(self.texts.spans())
            self.text_log.append(_logged(line, span))
            if reply is not None:
                reply(f"ok: {span.start:.2f}-{span.end:.2f}: {span.text}")

    def _lock_summary(self) -> dict[str, Any] | None:
        lock = self.poses.lock
        if lock is None:
            return {"note": self.poses.note} if self.poses.note else None
        lag = np.asarray(lock.lags or [0.0])
        return {"accents": lock.accents.count, "tempo_bpm": round(60.0 / self.clock.period, 1) if self.clock.period
                else None, "lag_s": {"mean": round(float(lag.mean()), 3), "max": round(float(lag.max()), 3)}}

    def _silence_summary(self) -> dict[str, Any] | None:
        """The rest in silence: its level and the seconds at rest, why there is none, or None when off."""
        if self.poses.rest_note:
            return {"note": self.poses.rest_note}
        if self.gate.floor is None:
            return None
        return {"floor_dbfs": self.gate.floor, "rested_s": round(self.gate.rested / self.fps, 2)}

    def _generate(self) -> None:
        """The generation thread: take feature frames, step the model, hand poses to the sinks."""
        import torch

        torch.set_num_threads(self.threads)
        gen, ended = self.generator, False
        try:
            while not self.stop.is_set():
                item = self.inbox.get()
                while item is not None:
                    streams, beats, settled, arrived = item
                    self._beats(beats, settled)
                    k = len(next(iter(streams.values()))) if streams else 0
                    self.arrivals += [arrived] * k
                    gen.add(streams)
                    try:
                        item = self.inbox.get_nowait()
                    except queue.Empty:
                        break
                if item is None:
                    ended = True
                    gen.end()
                self._apply_commands()
                behind = gen.ready()
                if not ended and behind > self.max_lag:
                    gen.skip(behind - 1)
                    self.stats.dropped += behind - 1
                while gen.ready() > 0 and not self.stop.is_set():
                    first = gen.t
                    for offset, frame in enumerate(gen.step()):
                        self._emit(first + offset, frame, offset == 0)
                if ended:
                    return
        except BaseException as exc:  # noqa: BLE001 - handed to the caller's thread
            self.error = exc
            self.stop.set()

    def _beats(self, rows: np.ndarray, settled: list) -> None:
        """The beat tracker's rows and settled beats, held for the clock until the frames they may inform."""
        if self.feed is not None:
            self.feed.add(rows, settled)

    def _emit(self, index: int, frame: np.ndarray, first: bool = True) -> None:
        newest = self.generator.newest(index)  # the newest music frame this frame waited for
        if self.feed is not None:
            self.feed.advance(newest)
        rest = self.gate.weight(index, newest - 1)
        message = frame_message(index, self.fps, self.poses(index, frame, rest))
        for sink in self.sinks:
            sink.send(message)
        completed = min(newest, len(self.arrivals) - 1)
        self.stats.latencies.append(time.perf_counter() - self.arrivals[completed])
        self.stats.times.append(index / self.fps)
        self.stats.first.append(first)
        self.stats.frames += 1


def _logged(command: str, span) -> dict[str, Any]:
    """A text command as the summary lists it."""
    return {"command": command[:100], "start": round(span.start, 3), "end": round(span.end, 3), "text": span.text}


def _tracker(registry, fps: float, rate: int):
    """A streaming beat tracker for beat locking when the recipe's streams have none: the registered beat
    tracker's ``streaming`` form, or None."""
    from dance_core.data.beat_tracking import beat_tracker

    entry = beat_tracker(registry)
    if entry is None:
        return None
    live = getattr(entry.build(entry.config_for({})), "streaming", None)
    return live(fps, rate) if live else None
