"""The real datasets ship inside the package: they load from any working directory without
../shared, equal the originals exactly, and an override folder that lacks them is reported."""
import gzip
import hashlib
import importlib.metadata
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import robocal
from robocal.errors import InputError
from robocal.io.datasets import PACKAGED_DATA, dataset_dir, ipa_ur10, mukca, ur5_tsinghua

ENV = "ROBOCAL_SHARED_DATA"
# name -> (loader taking root=, poses, fixture placements or None)
DATASETS = {
    "ur5": (lambda root=None: ur5_tsinghua(root=root), 1000, None),
    "ur10-A": (lambda root=None: ipa_ur10("A", root=root), 11911, None),
    "ur10-B": (lambda root=None: ipa_ur10("B", root=root), 1495, None),
    "ur10-D": (lambda root=None: ipa_ur10("D", root=root), 632, None),
    "panda_1": (lambda root=None: mukca("panda_1", root=root), 182, 3),
    "panda_2": (lambda root=None: mukca("panda_2", root=root), 559, 9),
    "panda_3": (lambda root=None: mukca("panda_3", root=root), 387, 6),
}
# Shipped from the source repository (ipa-robot-accuracy, commit 507fba69) but not among the
# originals in ../shared/data: checked against the SHA-256 of the source's file instead.
SOURCE_ONLY = {"ipa_ur10/Series_D/measurements_iso_cubes.csv":
               "a49dfd2182e662e65c217b00015433f5048ebad0f04c46c33c97a5c4a5643332"}
FIELDS = ("joints", "positions", "orientations", "sigmas", "fixture", "socket")
# The uncompressed originals: $ROBOCAL_SHARED_DATA as the session started, or ../shared/data
# beside the checkout.
ORIGINALS = Path(os.environ.get(ENV) or Path(__file__).resolve().parents[2] / "shared" / "data")


def _originals():
    """ORIGINALS, where present: absent on a user's machine (the comparison skips); CI has
    them, so there it must run."""
    root = ORIGINALS
    if not (root / "ur5_tsinghua").is_dir():
        if os.environ.get("CI"):
            pytest.fail(f"CI must have the original datasets in {root}")
        pytest.skip(f"original datasets not available in {root}")
    return root


@pytest.fixture
def elsewhere(monkeypatch, tmp_path):
    """No override, and a temporary working directory: only the packaged copy can be found."""
    monkeypatch.delenv(ENV, raising=False)
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.parametrize("name", DATASETS)
def test_loads_from_the_packaged_copy(elsewhere, name):
    load, poses, placements = DATASETS[name]
    data = load().measurements
    assert Path(data.path).is_relative_to(PACKAGED_DATA)
    assert data.n_poses == poses
    assert np.isfinite(data.joints).all()
    if placements is not None:
        assert len(np.unique(data.fixture)) == placements
        assert sorted(np.unique(data.socket)) == ["0", "1"]


def test_packaged_files_decompress_to_the_originals_byte_for_byte():
    originals = _originals()
    packaged = sorted(p for p in PACKAGED_DATA.rglob("*") if p.is_file() and p.name != "README.md")
    assert len(packaged) == 3 + 1 + 4 + 36  # licences, panda.urdf, tracker CSVs, MUKCa hole files
    for path in packaged:
        relative = path.relative_to(PACKAGED_DATA).as_posix()
        if path.suffix == ".gz":
            content, relative = gzip.decompress(path.read_bytes()), relative[:-len(".gz")]
        else:
            content = path.read_bytes()
        if relative in SOURCE_ONLY:
            assert hashlib.sha256(content).hexdigest() == SOURCE_ONLY[relative], relative
        else:
            assert content == (originals / relative).read_bytes(), relative


@pytest.mark.parametrize("name", [name for name in DATASETS if name != "ur10-D"])  # D: SOURCE_ONLY
def test_packaged_data_equal_the_originals(elsewhere, name):
    originals = _originals()
    load = DATASETS[name][0]
    packaged, original = load().measurements, load(root=originals).measurements
    assert Path(original.path).is_relative_to(originals)
    assert packaged.n_poses == original.n_poses
    for field in FIELDS:
        a, b = getattr(packaged, field), getattr(original, field)
        assert (a is None) == (b is None), field
        if a is not None:
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b), err_msg=field)
    assert set(packaged.extra) == set(original.extra)
    for key in packaged.extra:
        np.testing.assert_array_equal(np.asarray(packaged.extra[key]), np.asarray(original.extra[key]))


def test_environment_variable_selects_the_originals(monkeypatch):
    originals = _originals()
    monkeypatch.setenv(ENV, str(originals))
    assert dataset_dir() == originals
    assert Path(ur5_tsinghua().measurements.path).is_relative_to(originals)


def test_cli_exports_a_dataset_from_any_folder(elsewhere):
    env = {k: v for k, v in os.environ.items() if k != ENV}
    # The child imports the same robocal as these tests, whether installed or a checkout.
    package_parent = str(Path(robocal.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package_parent, env.get("PYTHONPATH")) if p)
    prefix = elsewhere / "ur5"
    run = subprocess.run([sys.executable, "-m", "robocal.interfaces.cli", "dataset", "ur5-tsinghua",
                          "--out", str(prefix), "--json"], cwd=elsewhere, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout)
    assert result["poses"] == 1000
    assert Path(result["source"]).is_relative_to(PACKAGED_DATA)
    assert Path(f"{prefix}.toml").is_file()
    lines = Path(f"{prefix}.csv").read_text().splitlines()
    assert len(lines) == 1 + 1000  # header and one row per pose


@pytest.mark.parametrize("name", DATASETS)
def test_override_folder_without_the_data_names_the_folder(monkeypatch, tmp_path, name):
    load = DATASETS[name][0]
    with pytest.raises(InputError) as given:
        load(root=tmp_path)
    message = str(given.value)
    assert str(tmp_path) in message and "\n" not in message
    monkeypatch.setenv(ENV, str(tmp_path))
    with pytest.raises(InputError, match=f"\\${ENV}") as given:
        load()
    assert str(tmp_path) in str(given.value) and "\n" not in str(given.value)


def test_an_installed_wheel_carries_every_data_file():
    """Checks pyproject's package-data where robocal is installed from a wheel (as in CI)."""
    try:
        dist = importlib.metadata.distribution("robocal")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("robocal is not installed")
    listed = {f.as_posix() for f in dist.files or ()}
    module = "robocal/io/datasets.py"
    if module not in listed:
        pytest.skip("robocal is installed in editable mode: no wheel to check")
    if Path(dist.locate_file(module)).read_bytes() != (PACKAGED_DATA.parent / "datasets.py").read_bytes():
        pytest.skip("the installed robocal is another version than the one under test")
    root = PACKAGED_DATA.parents[2]
    expected = {p.relative_to(root).as_posix() for p in PACKAGED_DATA.rglob("*") if p.is_file()}
    assert expected - listed == set()
