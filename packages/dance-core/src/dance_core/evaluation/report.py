"""Run registered metrics over a generated and a reference set; the report as JSON and as a table."""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from dance_core.errors import DanceError, DataError
from dance_core.protocols import JointClip, MetricResult
from dance_core.registry import Registry, get_registry


@dataclass
class Report:
    """Results by metric name, metrics that could not run (with the reason), clips left out (with
    the reason, keyed ``generated/NAME`` or ``reference/NAME``), and notes."""

    results: dict[str, MetricResult] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)
    unusable: dict[str, str] = field(default_factory=dict)

    def values(self) -> dict[str, float]:
        """Every summary value of every metric that ran, in one flat dict."""
        return {k: v for r in self.results.values() for k, v in r.values.items()}

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict (non-finite numbers become null)."""
        return {
            **self.info,
            "values": _finite(self.values()),
            "metrics": {
                name: {
                    "values": _finite(r.values),
                    "per_clip": {c: _finite(v) for c, v in r.per_clip.items()},
                    "notes": r.notes,
                }
                for name, r in self.results.items()
            },
            "skipped": self.skipped,
            "unusable_clips": self.unusable,
            "notes": self.notes,
        }

    def scored(self) -> bool:
        """True when at least one metric gave at least one finite value."""
        return any(math.isfinite(v) for v in self.values().values())


def _finite(values: dict[str, float]) -> dict[str, float | None]:
    return {k: (float(v) if math.isfinite(v) else None) for k, v in values.items()}


def build_metric(name: str, registry: Registry, options: dict[str, Any] | None = None, compat: bool = False):
    """Build a registered metric with options (``compat`` applies where the config has it)."""
    entry = registry.get("metric", name)
    opts = dict(options or {})
    if compat and entry.config is not None and "compat" in entry.config.model_fields:
        opts.setdefault("compat", True)
    return registry.create("metric", name, opts)


def evaluate(
    generated: Sequence[JointClip],
    reference: Sequence[JointClip] | None = None,
    names: Sequence[str] | None = None,
    *,
    compat: bool = False,
    options: dict[str, dict[str, Any]] | None = None,
    registry: Registry | None = None,
    progress: Callable[[str], None] | None = None,
) -> Report:
    """Score ``generated`` with every named metric (default: all registered metrics).

    A metric whose needs are not met, or that raises a ``DataError``, is recorded in ``skipped``
    with the reason instead of stopping the others. Clips marked ``meta["unusable"]`` (NaN or inf
    positions, see :func:`~dance_core.evaluation.loading.load_clips`) are left out and listed in
    ``unusable`` and the notes.
    """
    registry = registry or get_registry()
    names = list(names) if names else registry.names("metric")
    for name in names:
        registry.get("metric", name)  # unknown names fail before any work
    report = Report()
    generated = _usable(generated, "generated", report)
    reference = _usable(reference, "reference", report) if reference is not None else None
    if not generated:
        bad = [k.split("/", 1)[1] for k in report.unusable if k.startswith("generated/")]
        why = f" ({_shorten(', '.join(bad), 200)} hold NaN or inf values)" if bad else ""
        for name in names:
            report.skipped[name] = f"no usable generated clip{why}"
        return report
    has_music = any(c.music_beats is not None for c in generated)
    for name in names:
        if progress:
            progress(name)
        metric = build_metric(name, registry, (options or {}).get(name), compat)
        needs = getattr(metric, "needs", ())
        if "reference" in needs and not reference:
            report.skipped[name] = "needs a reference set"
            continue
        if "music" in needs and not has_music:
            report.skipped[name] = "needs music beats (--music DIR with songs or .beats files)"
            continue
        try:
            result = metric(generated, reference)
        except DataError as exc:
            report.skipped[name] = str(exc)
            continue
        report.results[name] = result
        report.notes.extend(result.notes)
    return report


def _usable(clips: Sequence[JointClip], label: str, report: Report) -> list[JointClip]:
    """The clips without ``meta["unusable"]``; the others are recorded in the report."""
    kept = []
    for clip in clips:
        reason = clip.meta.get("unusable")
        if reason is None:
            kept.append(clip)
            continue
        report.unusable[f"{label}/{clip.name}"] = reason
        report.notes.append(f"{label} clip {clip.meta.get('path', clip.name)} left out: {reason}")
    return kept


def check_scored(report: Report) -> None:
    """A DanceError when no metric gave a finite value (the CLI then exits non-zero), naming why:
    the clips left out and the metrics skipped."""
    if report.scored():
        return
    why = []
    if report.unusable:
        shown = ", ".join(report.unusable)
        why.append(f"{len(report.unusable)} clip(s) hold NaN or inf values ({_shorten(shown)})")
    reasons = sorted(set(report.skipped.values()))
    if reasons:
        why.append("metrics skipped: " + _shorten("; ".join(reasons)))
    if report.results:
        why.append(f"{', '.join(report.results)} gave only n/a")
    raise DanceError("could score nothing: " + ("; ".join(why) or "no metric ran"))


def _shorten(text: str, limit: int = 300) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def write_json(report: Report, path) -> None:
    """Write the report atomically."""
    from dance_core.atomic import write_text

    write_text(path, json.dumps(report.to_json(), indent=2, allow_nan=False) + "\n")


def format_value(value: float) -> str:
    """Four significant digits, or ``n/a``."""
    if not math.isfinite(value):
        return "n/a"
    return f"{value:.4g}" if abs(value) >= 1e-3 or value == 0 else f"{value:.3e}"


def render_table(report: Report, title: str = "dance evaluate"):
    """A rich table: one row per value, then ``n/a`` for each skipped metric (reasons in ``skipped``)."""
    from rich.table import Table

    table = Table(title=title)
    table.add_column("metric", no_wrap=True)
    table.add_column("value name", no_wrap=True)
    table.add_column("value", justify="right", no_wrap=True)
    for name, result in report.results.items():
        for key, value in result.values.items():
            table.add_row(name, key, format_value(value))
    for name in report.skipped:
        table.add_row(name, "-", "[yellow]n/a[/]")
    return table


def check_selected(report: Report, selected: Sequence[str] | None) -> None:
    """A DanceError naming every explicitly selected metric that could not run."""
    failed = [f"{n}: {report.skipped[n]}" for n in (selected or []) if n in report.skipped]
    if failed:
        raise DanceError("could not compute " + "; ".join(failed))
