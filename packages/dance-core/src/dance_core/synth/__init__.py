"""The synthesizer: songs (drums, bass, chords) with known beats and sections, a beat-locked dancer on
``dance24`` with labelled moves, its choreography to any song, the ``synthetic-dance`` and
``synthetic-moves`` datasets and ``dance synth``; registered by core's ``synth`` default plugin
(``dance_core.defaults.synth``)."""
