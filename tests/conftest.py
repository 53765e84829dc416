"""The real datasets live in ../shared/data, beside the checkout rather than in it: tests
marked ``shared_data`` are skipped, with the reason, where they are absent — except in CI
(CI set), where they must run."""
import os

import pytest

from robocal.errors import InputError
from robocal.io.datasets import shared_data_dir

DATASETS = ("ur5_tsinghua", "ipa_ur10", "mukca")


def _missing_data():
    try:
        root = shared_data_dir()
    except InputError as why:
        return str(why)
    absent = [name for name in DATASETS if not (root / name).is_dir()]
    return f"{root} has no {', '.join(absent)}" if absent else None


def pytest_configure(config):
    config.addinivalue_line("markers", "shared_data: needs the real datasets of ../shared/data")


def pytest_collection_modifyitems(config, items):
    missing = _missing_data()
    if missing and not os.environ.get("CI"):
        skip = pytest.mark.skip(reason=f"real datasets not available: {missing}")
        for item in items:
            if "shared_data" in item.keywords:
                item.add_marker(skip)
