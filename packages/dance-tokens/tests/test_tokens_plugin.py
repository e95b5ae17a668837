from importlib.metadata import entry_points


def test_entry_point_is_declared_and_loads():
    eps = {ep.name: ep for ep in entry_points(group="dance")}
    assert eps["tokens"].value == "dance_tokens.plugin"
    assert eps["tokens"].dist.name == "dance-tokens"
    module = eps["tokens"].load()
    assert module.__name__ == "dance_tokens.plugin"
