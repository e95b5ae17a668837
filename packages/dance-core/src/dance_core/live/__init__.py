"""``dance live``: music in as it plays, a dancing figure out as it goes.

``sources`` (a file at real time, raw PCM on standard input, a microphone), ``features`` (the recipe's
streams with a fixed look-ahead, beats by the tracker's forward pass), ``generator`` (the model stepping
as music arrives, keeping its state), ``pose`` (frames decoded one by one), ``sinks`` (JSON Lines),
``websocket`` (a WebSocket server and the live page), ``osc`` (VMC over OSC), ``session`` (threads,
drops, latency). See docs/live.md.
"""
