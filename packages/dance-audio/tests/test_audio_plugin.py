from importlib.metadata import entry_points


def test_entry_point_is_declared_and_loads():
    eps = {ep.name: ep for ep in entry_points(group="dance")}
    assert eps["audio"].value == "dance_audio.plugin"
    assert eps["audio"].dist.name == "dance-audio"
    module = eps["audio"].load()
    assert module.__name__ == "dance_audio.plugin"
