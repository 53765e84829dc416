"""The dataset loaders hand Python users a Dataset in internal units (rad, mm, rotation
matrices), with the file-unit measurements ``robocal dataset`` writes beside them; a
Dataset is not a tuple, so code written for the old ``chain, data = loader()`` fails with
a line that says what to use."""
import csv
import gzip

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from robocal.interfaces.jobs import DATASETS, dataset_job
from robocal.io import datasets
from robocal.io.datasets import PACKAGED_DATA, Dataset, ipa_ur10, mukca, ur5_tsinghua
from robocal.io.fixtures import read_fixture
from robocal.io.observations import read_observations
from robocal.io.tables import read_measurements

# The measurement writer's resolution for x, y, z (mm): 6 decimals.
WRITTEN_MM = 5e-7


def _file_columns(relative, names, delimiter=",", decimal_comma=False):
    """Columns ``names`` of a packaged CSV, read here without the loaders: (N, len(names))."""
    with gzip.open(PACKAGED_DATA / (relative + ".gz"), "rt", newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle, delimiter=delimiter))
    text = [[row[name].replace(",", ".") if decimal_comma else row[name] for name in names] for row in rows]
    return np.array(text, dtype=float)


@pytest.fixture(scope="module")
def ur5():
    return ur5_tsinghua()


@pytest.fixture(scope="module")
def panda():
    return mukca("panda_1")


def test_ur5_observations_are_the_files_degrees_in_radians_and_its_positions_in_mm(ur5):
    relative = "ur5_tsinghua/3D_UR5_uncalibrated_grid_cleaned.csv"
    degrees = _file_columns(relative, [f"joint_{k}" for k in range(1, 7)])
    target = _file_columns(relative, ["x_t", "y_t", "z_t"])
    dif = _file_columns(relative, ["x_dif", "y_dif", "z_dif"])
    obs = ur5.observations
    assert obs.kind == "position" and obs.n_poses == 1000
    np.testing.assert_array_equal(obs.joints, np.radians(degrees))
    np.testing.assert_array_equal(obs.positions, target + dif)
    # The file-unit twin keeps the degrees, for the files robocal writes.
    np.testing.assert_array_equal(ur5.measurements.joints, degrees)
    assert ur5.fixture is None and obs.fixture is None


def test_ur10_observations_carry_the_files_radians_and_its_orientations_as_matrices():
    dataset = ipa_ur10("B")
    relative = "ipa_ur10/Series_B/measurements_joint_configurations.csv"
    radians = _file_columns(relative, ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                                       "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"], ";", True)
    euler = _file_columns(relative, ["measurement_rx", "measurement_ry", "measurement_rz"], ";", True)
    obs = dataset.observations
    assert obs.kind == "pose"
    # The file is in rad; the file units between (deg) cost at most a rounding.
    np.testing.assert_allclose(obs.joints, radians, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(obs.rotations, Rotation.from_euler("XYZ", euler, degrees=True).as_matrix(),
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(dataset.measurements.joints, np.degrees(radians), rtol=1e-15)


def test_ball_in_socket_observations_carry_the_fixture_and_the_placements(panda):
    obs = panda.observations
    assert obs.kind == "constraint" and obs.positions is None
    assert obs.fixture is panda.fixture
    assert obs.fixture.distance("0", "1") == 50.0
    assert sorted(set(obs.placement)) == ["back-high", "front", "right"]
    assert set(obs.socket) == {"0", "1"}
    # The hole files hold rad; the first row of the first placement's socket 0, read here.
    with gzip.open(PACKAGED_DATA / "mukca/panda_1/back-high/hole_0.csv.gz", "rt") as handle:
        first = np.array(handle.readline().split(","), dtype=float)
    np.testing.assert_allclose(obs.joints[0], first, rtol=1e-15, atol=1e-15)
    assert (obs.placement[0], obs.socket[0]) == ("back-high", "0")
    assert np.abs(panda.measurements.joints).max() > 2 * np.pi  # the file-unit twin is in deg


@pytest.mark.parametrize("name", DATASETS)
def test_every_loader_names_its_dataset_as_robocal_dataset_does(name):
    loader, kwargs = DATASETS[name]
    dataset = getattr(datasets, loader)(**kwargs)
    assert isinstance(dataset, Dataset)
    assert dataset.name == name
    assert dataset.observations.n_poses == dataset.measurements.n_poses
    assert (dataset.fixture is None) == (dataset.measurements.fixture is None)
    assert dataset.description and dataset.citation
    assert name in repr(dataset) and "\n" not in repr(dataset)


@pytest.mark.parametrize("unpack", [
    lambda: _two(ur5_tsinghua()),
    lambda: _three(mukca("panda_1")),
    lambda: ur5_tsinghua()[1],
    lambda: ipa_ur10("B")[:2],
], ids=["chain, data", "chain, data, fixture", "index", "slice"])
def test_a_dataset_used_as_the_old_tuple_fails_saying_what_to_use(unpack):
    with pytest.raises(TypeError, match="not a tuple: use dataset.chain, dataset.observations") as given:
        unpack()
    assert "dataset.measurements" in str(given.value) and "\n" not in str(given.value)


def _two(dataset):
    chain, data = dataset
    return chain, data


def _three(dataset):
    chain, data, fixture = dataset
    return chain, data, fixture


def test_a_dataset_is_frozen(ur5):
    with pytest.raises(AttributeError):
        ur5.chain = None


@pytest.mark.parametrize("name, loader", [("ur5-tsinghua", ur5_tsinghua), ("mukca-panda-1", mukca)])
def test_the_written_dataset_reads_back_as_the_loaders_data(tmp_path, name, loader):
    """``robocal dataset`` writes the file-unit measurements; reading its files as a user's
    gives the loader's observations again."""
    dataset = loader()
    prefix = tmp_path / name
    written = dataset_job(name, prefix)
    assert written.poses == dataset.measurements.n_poses
    data = dataset.measurements
    back = read_measurements(f"{prefix}.csv")
    np.testing.assert_array_equal(back.joints, data.joints)
    for field in ("fixture", "socket"):
        assert (getattr(back, field) is None) == (getattr(data, field) is None)
        if getattr(data, field) is not None:
            np.testing.assert_array_equal(getattr(back, field), getattr(data, field))
    fixture = None if dataset.fixture is None else f"{prefix}_fixture.toml"
    obs = read_observations(f"{prefix}.csv", f"{prefix}.toml", fixture)
    np.testing.assert_allclose(obs.joints, dataset.observations.joints, rtol=1e-15, atol=1e-15)
    if dataset.fixture is None:
        np.testing.assert_allclose(obs.positions, dataset.observations.positions, rtol=0, atol=WRITTEN_MM)
    else:
        sockets = read_fixture(fixture).sockets
        assert sockets.keys() == dataset.fixture.sockets.keys()
        for socket, position in sockets.items():
            np.testing.assert_array_equal(position, dataset.fixture.sockets[socket])
        np.testing.assert_array_equal(obs.placement, dataset.observations.placement)
