from importlib.metadata import entry_points


def test_entry_point_is_declared_and_loads():
    eps = {ep.name: ep for ep in entry_points(group="dance")}
    assert eps["rnn"].value == "dance_rnn.plugin"
    assert eps["rnn"].dist.name == "dance-rnn"
    module = eps["rnn"].load()
    assert module.__name__ == "dance_rnn.plugin"
