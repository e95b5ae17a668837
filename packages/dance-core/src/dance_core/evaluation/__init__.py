"""Evaluation of generated dances: motion features, the papers' metrics, reports and plots.

Every metric works on joint positions (``dance_core.protocols.JointClip``: ``(T, J, 3)`` metres,
Y up) at any frame rate, and is registered as a ``metric`` component by core's plugin. The entry
point of ``dance evaluate`` is :func:`dance_core.evaluation.report.evaluate`.
"""
