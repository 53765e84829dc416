"""Bounded work: every option that sets an amount of work (generations, layer widths, poses,
placements, configurations per socket, candidates, workers) has a largest value no real use
exceeds, declared once in its setting's constraint (robocal.settings), and a value beyond it
is refused in one line that says what the largest costs or what to do instead, on the
command line and in a fleet file alike; the values real use takes pass."""
import pytest

from refusals import PLATE, assert_refused
from robocal.errors import InputError
from robocal.interfaces.fleet import read_fleet
from robocal.methods import make_method
from robocal.methods.ann import GENERATIONS, HIDDEN

REFUSED = [
    ("calibrate ur5 meas.csv --method ann --generations 100000000 --out m.json", "<= 10,000 (300 take about"),
    ("calibrate ur5 meas.csv --method ann --hidden 100000,16 --out m.json", "<= 256"),
    ("calibrate ur5 meas.csv --method ann --hidden 8,8,8,8,8,8,8,8,8 --out m.json", "at most 8 of them"),
    ("simulate kr150-2 --sampling sockets --fixture {plate} --placements 5000 --out s.csv", "<= 1,000"),
    ("simulate kr150-2 --sampling sockets --fixture {plate} --per-socket 20000 --out s.csv", "<= 10,000"),
    ("design kr150-2 --fixture {plate} --region 1000,2000,-500,500,0,400 --n 24 --per-socket 20000 --out p.csv",
     "<= 10,000"),
    ("design ur5 --n 10 --pool 100000000 --out p.csv", "<= 200,000 (10,000, the default, take about 4 s"),
    ("design ur5 --n 10 --pool 1000000 --out p.csv", "<= 200,000"),
    ("simulate ur5 --n 100000000 --out s.csv", "<= 1,000,000"),
    ("compare ur5 meas.csv --jobs 100000", "<= 1,024"),
]


@pytest.mark.parametrize("command, says", REFUSED, ids=[row[0] for row in REFUSED])
def test_an_amount_of_work_beyond_any_real_use_is_refused_in_one_line(tmp_path, monkeypatch, command, says):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "meas.csv").write_text("q1,q2,q3,q4,q5,q6,x,y,z\n")
    before = {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()}
    assert_refused(command.format(plate=PLATE).split(), says, tmp_path, before)


def test_the_amounts_real_use_takes_pass():
    network = make_method("ann", generations=300, hidden=(16, 16))
    assert network.generations == 300 and tuple(network.hidden) == (16, 16)
    assert GENERATIONS.check(10_000) == 10_000 and HIDDEN.check((256,) * 8) == (256,) * 8
    with pytest.raises(InputError, match="--generations must be a whole number >= 0 and <= 10,000"):
        GENERATIONS.check(10_001)


@pytest.mark.parametrize("options, refused", [
    ("{ generations = 100000000 }", "options.generations must be a whole number >= 0 and <= 10,000"),
    ("{ hidden = [100000, 16] }", "options.hidden must be"),
    ("{ generations = 500, hidden = [32, 32] }", None),
])
def test_a_fleet_file_takes_the_same_bounds(tmp_path, options, refused):
    (tmp_path / "train.csv").write_text("q1\n")
    fleet = tmp_path / "fleet.toml"
    fleet.write_text(f'[[robot]]\nname = "r1"\nrobot = "ur5"\ntrain = "train.csv"\nmethod = "ann"\n'
                     f"options = {options}\n")
    if refused is None:
        assert read_fleet(fleet)[0].settings == {"generations": 500, "hidden": (32, 32)}
    else:
        with pytest.raises(InputError, match=refused):
            read_fleet(fleet)
