from importlib.metadata import entry_points


def test_entry_point_is_declared_and_loads():
    eps = {ep.name: ep for ep in entry_points(group="dance")}
    assert eps["flow"].value == "dance_flow.plugin"
    assert eps["flow"].dist.name == "dance-flow"
    module = eps["flow"].load()
    assert module.__name__ == "dance_flow.plugin"
