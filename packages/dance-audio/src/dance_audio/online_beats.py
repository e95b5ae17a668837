"""The ``beats`` extractor live: :mod:`.flux_beats`' tracker run causally, frame by frame, as audio arrives.

Offline, the flux tracker sees the whole song: the onset envelope in dB below the song's loudest band,
the activation over a centred 0.5-s mean and 4-s maximum, and Viterbi over the whole bar-pointer
model. Live, each of these uses only what has been heard:

* the same SuperFlux envelope at :data:`.flux_beats.FPS`, in dB below the loudest band heard so far;
* the activation over the mean of the last 0.5 s and the maximum of the last 4 s (no crop);
* the **forward pass** of the same beat-only bar-pointer HMM (:func:`.dbn.bar_model`, the same tempo
  transitions and log-normal tempo prior): per frame the filtered state probabilities, normalised;
  the most probable state gives the tempo and the beat phase, and a beat is marked when that phase
  wraps (so tempo changes are followed from beat to beat, as offline);
* bars as offline (:func:`.beats.bar_positions`): the beat phase modulo the longest bar whose beats
  carry the most onset energy, from running sums over the beats heard;
* **settled beats** (:class:`SettledBeats`, for whoever can wait, as the live beat lock does): the same
  model decoded by Viterbi as offline, run forward frame by frame and traced back every
  :data:`SETTLE_EVERY` s over the last :data:`SETTLE_WINDOW` s, so a beat heard a second ago is placed
  knowing the second after it (fixed-lag smoothing), which the forward pass's best state cannot
  (``benchmarks/online_beats.py``).

The columns are those of :class:`.beats.BeatFeatures`. A beat is marked on the first frame at or after
its time (offline: the nearest frame). Look-ahead: half the tracker's 1024-sample window (23 ms) plus,
when the input is not at 22.05 kHz, the streaming resampler's delay.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from .flux_beats import (
    FLOOR,
    FLOOR_DB,
    FMAX,
    FMIN,
    FPS,
    HOP,
    LAG,
    LOW_BANDS,
    LOW_WEIGHT,
    MEAN_SECONDS,
    N_FFT,
    N_MELS,
    NUM_TEMPI,
    OBSERVATION_LAMBDA,
    PEAK,
    RATE,
    SCALE_SECONDS,
    SPREAD,
    TRANSITION_LAMBDA,
    prior_transitions,
)

#: seconds the settled beats are traced back over, and how often (s) they are traced
SETTLE_WINDOW, SETTLE_EVERY = 20.0, 0.25


class OnlineEnvelope:
    """The SuperFlux onset envelope of :func:`.flux_beats.onset_envelope`, one frame at a time, in dB
    below the loudest mel band value heard so far."""

    def __init__(self) -> None:
        from .spectral import mel_filterbank

        self.bank = mel_filterbank(RATE, N_FFT, N_MELS, FMIN, FMAX).T
        self.top = 0.0
        self.past: deque[np.ndarray] = deque(maxlen=LAG)  # the reference spectra of the last LAG frames

    def frames(self, spectra: np.ndarray) -> np.ndarray:
        """Envelope values of consecutive magnitude spectra ``(k, n_fft // 2 + 1)``."""
        mel = spectra @ self.bank
        out = np.zeros(len(mel))
        for t, row in enumerate(mel):
            self.top = max(self.top, float(row.max()))
            if not self.top > 0:
                db = np.full(N_MELS, FLOOR_DB)
            else:
                db = 20.0 * np.log10(np.maximum(row / self.top, 10.0 ** (FLOOR_DB / 20.0)))
            reference = db.copy()
            for shift in range(1, SPREAD // 2 + 1):
                np.maximum(reference[shift:], db[:-shift], out=reference[shift:])
                np.maximum(reference[:-shift], db[shift:], out=reference[:-shift])
            if len(self.past) == LAG:
                rise = np.maximum(0.0, db - self.past[0])
                out[t] = rise.mean() + LOW_WEIGHT * rise[:LOW_BANDS].mean()
            self.past.append(reference)
        return out


class OnlineActivation:
    """Beat probabilities from envelope values: the rise over the mean of the last 0.5 s, over the
    maximum of the last 4 s, mapped between the floor and the peak of :mod:`.flux_beats`."""

    def __init__(self) -> None:
        self.recent: deque[float] = deque(maxlen=max(1, int(MEAN_SECONDS * FPS)))
        self.rises: deque[float] = deque(maxlen=max(1, int(SCALE_SECONDS * FPS)))
        self.top = 0.0

    def __call__(self, env: float) -> float:
        """The activation of the next envelope value."""
        self.recent.append(env)
        rise = max(0.0, env - float(np.mean(self.recent)))
        self.rises.append(rise)
        self.top = max(self.top, rise)
        if not self.top > 0:
            return FLOOR
        scale = max(max(self.rises), 0.05 * self.top)
        return FLOOR + (PEAK - FLOOR) * min(max(rise / scale, 0.0), 1.0)


class BeatChains:
    """The states of the beat-only bar-pointer HMM that :func:`.flux_beats.decode_beats` decodes, laid out
    for stepping frame by frame: one chain of states per tempo (``periods`` frames each, the first
    ``beat_len`` of them in the beat range), ``log_trans[j, i]`` from the end of chain ``j`` into the start
    of chain ``i`` (the tempo prior included), and per state its ``chain``, ``position`` and ``on_beat``."""

    def __init__(self, min_bpm: float, max_bpm: float, fps: float = FPS) -> None:
        from .dbn import bar_model

        model = bar_model(1, 60.0 * fps / max_bpm, 60.0 * fps / min_bpm, NUM_TEMPI, TRANSITION_LAMBDA,
                          float(OBSERVATION_LAMBDA))
        log_trans, periods = prior_transitions(model.log_trans, model.periods, fps)
        self.periods = np.asarray(periods, dtype=np.int64)
        self.log_trans = np.asarray(log_trans, np.float64)
        self.starts = np.concatenate(([0], np.cumsum(self.periods)[:-1]))
        self.ends = self.starts + self.periods - 1
        self.chain = np.repeat(np.arange(len(self.periods)), self.periods)
        self.position = np.arange(int(self.periods.sum())) - self.starts[self.chain]
        self.beat_len = np.asarray(model.on_beat[0], np.int64)
        self.on_beat = self.position < self.beat_len[self.chain]


class ForwardBarPointer:
    """The forward (filtering) pass of the beat-only bar-pointer HMM that :func:`.flux_beats.decode_beats`
    decodes by Viterbi: states are (tempo, frame within the beat); ``step(p)`` takes one frame's beat
    activation and returns the most probable state's ``(beat phase in [0, 1), beat period in frames)``."""

    def __init__(self, min_bpm: float, max_bpm: float, fps: float = FPS) -> None:
        m = BeatChains(min_bpm, max_bpm, fps)
        self.periods, self.starts, self.ends = m.periods, m.starts, m.ends
        self.chain, self.position, self.on_beat = m.chain, m.position, m.on_beat
        self.trans = np.exp(m.log_trans - m.log_trans.max())  # [j, i]: from the end of chain j into chain i
        self.alpha = np.full(len(self.chain), 1.0 / len(self.chain))

    def step(self, p: float) -> tuple[float, int]:
        """Advance one frame with beat activation ``p``."""
        alpha = self.alpha
        new = np.empty_like(alpha)
        new[1:] = alpha[:-1]
        new[self.starts] = alpha[self.ends] @ self.trans
        new *= np.where(self.on_beat, p, (1.0 - p) / (OBSERVATION_LAMBDA - 1))
        total = new.sum()
        self.alpha = new / total if total > 0 else np.full_like(new, 1.0 / len(new))
        best = int(np.argmax(self.alpha))
        period = int(self.periods[self.chain[best]])
        return float(self.position[best]) / period, period


class SettledBeats:
    """Beats placed with hindsight: Viterbi over the same model as :class:`ForwardBarPointer`, run forward
    one frame at a time (``push(p)``: the best score of every state and, for each tempo's first state, the
    tempo it was best entered from), traced back every :data:`SETTLE_EVERY` s from the best state now over
    the last :data:`SETTLE_WINDOW` s. ``times`` holds those beats in seconds from the stream's start, each
    on the largest activation of its beat range as offline. It is the offline tracker's decoding of
    everything heard so far, so each trace may move the beats of the one before it."""

    def __init__(self, min_bpm: float, max_bpm: float) -> None:
        m = BeatChains(min_bpm, max_bpm)
        self.periods, self.log_trans, self.starts, self.ends = m.periods, m.log_trans, m.starts, m.ends
        self.chain, self.position, self.beat_len, self.on_beat = m.chain, m.position, m.beat_len, m.on_beat
        self.score = np.zeros(len(self.chain))  # log scores less their maximum (uniform start)
        size = int(round(SETTLE_WINDOW * FPS))
        self.back = np.zeros((size, len(self.periods)), np.int16)  # ring: per frame, each chain entered from
        self.p = np.zeros(size)  # ring: the activations
        self.count = 0  # tracker frames pushed
        self.times = np.zeros(0)
        #: (seconds heard, beats) of each trace not yet taken (the last 256: a minute's)
        self.traces: deque[tuple[float, np.ndarray]] = deque(maxlen=256)

    def push(self, p: float) -> None:
        """The next tracker frame's activation; traces the beats back when due."""
        p = float(p)
        score = self.score
        new = np.empty_like(score)
        new[1:] = score[:-1]
        entering = score[self.ends][:, None] + self.log_trans
        best = np.argmax(entering, axis=0)
        new[self.starts] = entering[best, np.arange(len(best))]
        new += np.where(self.on_beat, np.log(p), np.log((1.0 - p) / (OBSERVATION_LAMBDA - 1)))
        self.score = new - new.max()
        k = self.count % len(self.p)
        self.back[k], self.p[k] = best, p
        self.count += 1
        if self.count % round(SETTLE_EVERY * FPS) == 0:
            self.times = self._trace()
            self.traces.append((self.count / FPS, self.times))

    def _trace(self) -> np.ndarray:
        """The beats of the best path ending now, over the frames still in the ring."""
        size, last = len(self.p), self.count - 1
        oldest = max(0, self.count - size)
        state = int(np.argmax(self.score))
        chain, entry = int(self.chain[state]), last - int(self.position[state])
        beats = []
        while entry >= oldest:
            frames = np.arange(entry, min(entry + int(self.beat_len[chain]), last + 1))
            beats.append(int(frames[np.argmax(self.p[frames % size])]))
            if entry - 1 < oldest:
                break
            before = int(self.back[entry % size, chain])
            entry, chain = entry - int(self.periods[before]), before
        return np.array(beats[::-1], np.float64) / FPS


class OnlineBeats:
    """The ``beats`` columns of an audio stream at ``fps``: ``push(samples)`` returns the frames it
    completes ``(k, 6)``, ``finish(n_frames)`` the rest up to ``n_frames`` (the audio padded with
    silence, as offline frames past the end are)."""

    def __init__(self, fps: float, rate: int, beats_per_bar: list[int], min_bpm: float, max_bpm: float) -> None:
        from .stft import periodic_hann

        self.fps, self.rate = float(fps), int(rate)
        self.bar = max(beats_per_bar)
        self.resampler = None
        if self.rate != RATE:
            import soxr

            self.resampler = soxr.ResampleStream(self.rate, RATE, 1, dtype="float32", quality="HQ")
        self.window = periodic_hann(N_FFT)
        self.y = np.zeros(N_FFT // 2, np.float32)  # the audio at RATE from sample y_start - N_FFT // 2
        self.y_start = 0
        self.envelope, self.activation = OnlineEnvelope(), OnlineActivation()
        self.hmm = ForwardBarPointer(min_bpm, max_bpm)
        self.settled = SettledBeats(min_bpm, max_bpm)
        self.tracker_frames = 0  # tracker frames done
        self.frames = 0  # output frames done
        self.phase, self.beats, self.last_phase = 0.0, 0, 0.0
        self.strength = np.zeros(self.bar)
        self.counts = np.zeros(self.bar)
        self.recent_env: deque[float] = deque(maxlen=5)
        self.pending_beat = self.pending_downbeat = False
        #: seconds of audio past a frame's time needed before the frame is known (resampler delay not included)
        self.lookahead = (N_FFT // 2) / RATE

    def dim(self) -> int:
        """Six columns, as the offline extractor."""
        return 6

    def settled_beats(self) -> np.ndarray:
        """The beats heard so far placed with hindsight (s; :class:`SettledBeats`), those of the last
        :data:`SETTLE_WINDOW` s."""
        return self.settled.times

    def take_settled(self) -> list[tuple[float, np.ndarray]]:
        """Each placing of the settled beats since the last call, in order: ``(seconds of the stream the beats
        were placed with, beats in seconds)``, so a consumer can use each from a point of the music on,
        however the audio was split into blocks."""
        traces = list(self.settled.traces)
        self.settled.traces.clear()
        return traces

    def push(self, samples: np.ndarray) -> np.ndarray:
        """Frames completed by the next block of mono float samples at the stream's rate."""
        samples = np.asarray(samples, np.float32)
        if self.resampler is not None:
            samples = self.resampler.resample_chunk(samples, last=False)
        return self._feed(samples, None)

    def finish(self, n_frames: int) -> np.ndarray:
        """The remaining frames up to ``n_frames``, the audio after the end taken as silence."""
        tail = np.zeros(0, np.float32)
        if self.resampler is not None:
            tail = self.resampler.resample_chunk(np.zeros(0, np.float32), last=True)
        return self._feed(tail, n_frames)

    def _feed(self, samples: np.ndarray, n_frames: int | None) -> np.ndarray:
        self.y = np.concatenate([self.y, samples.astype(np.float32)])
        have = self.y_start + len(self.y) - N_FFT // 2  # samples at RATE received
        if n_frames is None:  # a tracker frame centred at f * HOP needs samples up to f * HOP + N_FFT // 2
            last = (have - N_FFT // 2) // HOP
        else:
            last = int(np.ceil((n_frames - 1) / self.fps * FPS)) + 1
            self.y = np.concatenate([self.y, np.zeros(max(0, (last + 1) * HOP + N_FFT - len(self.y)), np.float32)])
        rows = []
        for f in range(self.tracker_frames, last + 1):
            lo = f * HOP - self.y_start  # index into y of the frame's first sample (y holds N_FFT // 2 before)
            frame = self.y[lo : lo + N_FFT]
            spectrum = np.abs(np.fft.rfft(frame * self.window))[None, :]
            env = float(self.envelope.frames(spectrum)[0])
            self._track(env)
            self.tracker_frames = f + 1
            time = f / FPS
            while self.frames / self.fps <= time and (n_frames is None or self.frames < n_frames):
                rows.append(self._row())
                self.frames += 1
        keep = max(0, self.tracker_frames * HOP - self.y_start)
        self.y, self.y_start = self.y[keep:], self.y_start + keep
        if n_frames is not None:
            while self.frames < n_frames:
                rows.append(self._row())
                self.frames += 1
        return np.array(rows, np.float32).reshape(-1, 6)

    def _track(self, env: float) -> None:
        self.recent_env.append(env)
        p = self.activation(env)
        self.settled.push(p)
        phase, _ = self.hmm.step(p)
        if phase < self.last_phase - 0.5:  # the most probable state entered a new beat
            k = self.beats % self.bar
            self.strength[k] += max(self.recent_env)
            self.counts[k] += 1
            self.beats += 1
            self.pending_beat = True
            self.pending_downbeat = self._position() == 1
        self.last_phase, self.phase = phase, phase

    def _position(self) -> int:
        """The current beat's position in its bar, 1..bar (1 = downbeat)."""
        if self.beats == 0:
            return 1
        means = np.where(self.counts > 0, self.strength / np.maximum(self.counts, 1), 0.0)
        offset = int(np.argmax(means))
        return (self.beats - 1 - offset) % self.bar + 1

    def _row(self) -> list[float]:
        beat_phase = 2 * np.pi * self.phase
        bar_phase = 2 * np.pi * ((self._position() - 1 + self.phase) / self.bar)
        row = [float(self.pending_beat), float(self.pending_beat and self.pending_downbeat),
               np.sin(beat_phase), np.cos(beat_phase), np.sin(bar_phase), np.cos(bar_phase)]
        self.pending_beat = self.pending_downbeat = False
        return row
