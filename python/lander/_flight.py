"""Loads the flight software a scenario's flight.python names ("FILE.py:CLASS")."""
import importlib.util
import os


def load(spec, flight_config, plugin_config):
    """CLASS(flight_config, plugin_config) from FILE.py; both configurations are dicts."""
    path, _, cls_name = spec.rpartition(":")
    if not path or not cls_name:
        raise ValueError(f"flight.python must be FILE.py:CLASS, got {spec!r}")
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{path}: no such file")
    name = "lander_flight_" + os.path.splitext(os.path.basename(path))[0]
    module_spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(module_spec)
    module_spec.loader.exec_module(module)
    cls = getattr(module, cls_name, None)
    if cls is None:
        raise AttributeError(f"{path} has no class {cls_name!r}")
    return cls(flight_config, plugin_config)
