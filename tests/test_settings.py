"""A setting's constraint (robocal.settings) is the one check of its values: the methods run it
at the start of fit, the command line's options and a fleet file's keys are generated from it."""
import pytest
import typer

from robocal.errors import InputError
from robocal.interfaces.cli import app
from robocal.methods import REGISTRY, settings_by_option
from robocal.settings import Choice, Either, Flag, Number, Numbers, Refusal, Setting, merged_constraint

COMMANDS = typer.main.get_command(app).commands


def _options(command):
    return {opt: param for param in COMMANDS[command].params for opt in param.opts if opt.startswith("--")}


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_every_setting_declares_a_constraint_its_default_meets(name):
    for setting in REGISTRY[name].settings:
        assert setting.constraint is not None, setting.name
        assert setting.check(setting.default) == setting.default, setting.name


@pytest.mark.parametrize("command, skipped", [("calibrate", ()), ("validate", ("--seed",))])
def test_calibrate_and_validate_take_every_setting_with_its_choices(command, skipped):
    options = _options(command)
    for option, entries in settings_by_option().items():
        assert option in options, (command, option)
        if option in skipped:
            continue
        constraint = merged_constraint([setting for _, setting in entries])
        if isinstance(constraint, Choice):
            assert all(value in options[option].metavar for value in constraint.values), option


def test_a_setting_is_refused_in_one_line_naming_its_option():
    loss = Setting("loss", "linear", "--loss", "the loss", Choice(("linear", "huber")))
    with pytest.raises(InputError, match=r"^--loss must be one of linear, huber, got 'cauchy'$"):
        loss.check("cauchy")
    with pytest.raises(Refusal, match=r"must be one of linear, huber: 'cauchy' is not available"):
        loss.parse("cauchy")
    payload = Setting("payload", None, "--payload", "kg", Number(at_least=0))
    assert payload.check(None) is None and payload.check(2) == 2.0
    with pytest.raises(InputError, match=r"^--payload must be a number >= 0, got -1$"):
        payload.check(-1)


@pytest.mark.parametrize("constraint, text, value", [
    (Number(whole=True, at_least=2), "3", 3),
    (Number(between=(0, 1)), "0.5", 0.5),
    (Numbers(whole=True, at_least=1, at_least_count=2), "16,8", [16, 8]),
    (Either(Choice(("estimate",)), Number(at_least=0)), "estimate", "estimate"),
    (Either(Choice(("estimate",)), Number(at_least=0)), "0.25", 0.25),
])
def test_a_typed_value_is_parsed(constraint, text, value):
    assert constraint.parse(text) == value


@pytest.mark.parametrize("constraint, value, phrase", [
    (Number(whole=True, at_least=2), "1", "must be a whole number >= 2, got '1'"),
    (Number(whole=True, at_least=2), 2.5, "must be a whole number >= 2, got 2.5"),
    (Number(whole=True, at_least=0), True, "must be a whole number >= 0, got True"),
    (Number(whole=True, at_least=1), 10**10, "must be a whole number >= 1 and <= 1,000,000,000"),
    (Number(between=(0, 1)), float("nan"), "must be a number between 0 and 1 (exclusive)"),
    (Numbers(whole=True, at_least=1, at_least_count=2), (16,), "must be at least 2 comma-separated whole numbers"),
    (Numbers(count=3), [1, 2, float("inf")], "must be 3 comma-separated numbers"),
    (Either(Choice(("estimate",)), Number(at_least=0)), -1, "must be 'estimate' or a number >= 0, got -1"),
    (Flag(), "yes", "must be true or false, got 'yes'"),
    (Choice(("a", "b")), None, "must be one of a, b, got None"),
])
def test_a_value_outside_its_constraint_is_refused(constraint, value, phrase):
    with pytest.raises(Refusal) as caught:
        (constraint.parse if isinstance(value, str) else constraint.check)(value)
    assert phrase in caught.value.phrase


def test_one_option_of_several_methods_takes_their_choices_together():
    assert merged_constraint([Setting("p", "a", "--p", "", Choice(("a", "b"))),
                              Setting("p", "c", "--p", "", Choice(("c", "a")))]).values == ("a", "b", "c")
    with pytest.raises(TypeError):
        merged_constraint([Setting("p", 1, "--p", "", Number()), Setting("p", "a", "--p", "", Choice(("a",)))])
