"""Shared fixtures of the Python package's tests (run by CTest: tests/CMakeLists.txt)."""
import os
import sys

import pytest

SOURCE_DIR = os.environ.get("LANDER_SOURCE_DIR") or os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(SOURCE_DIR, "examples"))


@pytest.fixture
def src():
    return SOURCE_DIR


@pytest.fixture
def default_yaml(src):
    return os.path.join(src, "scenarios", "default.yaml")
