# ruff: noqa: E501  (one input per table row)
"""Broken files. Wrong encodings, truncated or corrupted CSV / JSON / TOML /
URDF, wrong types inside valid files, NaN and inf, empty files, duplicate columns, BOMs, CRLF,
semicolons and decimal commas. Each is refused in one line naming the file (and row, column or
key) and what to do, never a traceback; the harmless variants (a BOM, CRLF, UTF-16, quoted
numbers, trailing commas) give the same answer as the clean file."""
import gzip
import json
import os
import re
from pathlib import Path

import pytest

from user_files import campaign, invoke, prepare, refuse, text


def ur5(change):
    return lambda base: change((base / "ur5.csv").read_text())


def row(n, column):
    """The text of cell (data row n, column index) of ur5.csv."""
    return text("ur5.csv").splitlines()[n].split(",")[column]


def with_header(change):
    def make(base):
        header, *body = (base / "ur5.csv").read_text().splitlines()
        return change(header) + "\n" + "\n".join(body) + "\n"
    return make


CSV_REFUSED = [
    ("utf-16-without-bom", ur5(lambda t: t.encode("utf-16-le")), "is not a text CSV file"),
    ("semicolons", ur5(lambda t: t.replace(",", ";")), "is not comma-separated"),
    ("semicolons-and-decimal-commas", ur5(lambda t: t.replace(",", ";").replace(".", ",")), "is not comma-separated"),
    ("tabs", ur5(lambda t: t.replace(",", "\t")), "is not comma-separated"),
    ("empty", lambda b: "", "is empty"),
    ("blank-lines-only", lambda b: "\n\n\n", "is empty"),
    ("header-only", ur5(lambda t: t.splitlines()[0] + "\n"), "has a header but no data rows"),
    ("truncated-mid-row", ur5(lambda t: t[: len(t) // 2]), "cells but the header has 12 columns"),
    ("nan-cell", ur5(lambda t: t.replace(row(4, 6), "nan", 1)), "'nan' is not a finite number"),
    ("inf-cell", ur5(lambda t: t.replace(row(4, 7), "inf", 1)), "'inf' is not a finite number"),
    ("empty-cell", ur5(lambda t: t.replace(row(4, 8), "", 1)), "the cell is empty"),
    ("text-cell", ur5(lambda t: t.replace(row(4, 0), "abc", 1)), "'abc' is not a number"),
    ("hex-float", ur5(lambda t: t.replace(row(3, 0), "0x1p3", 1)), "'0x1p3' is not a number"),
    ("huge-number", ur5(lambda t: t.replace(row(3, 6), "1e308", 1)), "1e308 is beyond"),
    ("duplicate-x", with_header(lambda h: h.replace(",y,", ",x,")), "column 'x' appears twice"),
    ("duplicate-q1", with_header(lambda h: h.replace("q2", "q1")), "column 'q1' appears twice"),
    ("upper-case-header", with_header(str.upper), "did you mean 'q1'?"),
    ("five-joint-columns", ur5(lambda t: "\n".join(",".join(v for i, v in enumerate(r.split(",")) if i != 5) for r in t.splitlines()) + "\n"), "has 5 joint columns"),
    ("seven-joint-columns", ur5(lambda t: "\n".join([t.splitlines()[0].replace("q6,", "q6,q7,")] + [",".join(r.split(",")[:6] + ["0"] + r.split(",")[6:]) for r in t.splitlines()[1:]]) + "\n"), "has 7 joint columns"),
    ("nul-bytes", ur5(lambda t: t.replace("\n", "\x00\n", 3)), "is not a text CSV file"),
    ("gzip", ur5(lambda t: gzip.compress(t.encode())), "is not a text CSV file"),
    ("comment-line", ur5(lambda t: "# measured 2026\n" + t), "line 1 is a comment"),
    ("sep-semicolon-with-decimal-commas", ur5(lambda t: "sep=;\n" + t.replace(",", ";").replace(".", ",")), "use '.' as the decimal point"),
    ("negative-sigma", ur5(lambda t: t.replace(",0.02,0.02,0.02", ",-0.02,0.02,0.02", 2)), "a standard deviation must be > 0"),
    ("zero-sigma", ur5(lambda t: t.replace(",0.02,0.02,0.02", ",0,0,0", 2)), "a standard deviation must be > 0"),
    ("joints-numbered-from-q0", with_header(lambda h: ",".join(f"q{int(c[1:]) - 1}" if c[:1] == "q" else c for c in h.split(","))), "has a column q0: joint columns are numbered from q1"),
    ("joints-named-j1-to-j6", with_header(lambda h: h.replace("q", "j")), "has no joint columns: add q1"),
    ("thousands-separator-in-quoted-x", lambda b: thousands((b / "kr.csv").read_text()), "column 'x': '1,"),
]


def thousands(text):
    """``text`` (a CSV) with x written as a spreadsheet shows it, "1,234.5678" (quoted)."""
    header, *body = text.splitlines()
    k = header.split(",").index("x")
    return "\n".join([header] + [",".join(f'"{float(v):,.4f}"' if i == k else v for i, v in enumerate(r.split(",")))
                                 for r in body]) + "\n"



@pytest.mark.parametrize("verb", ["calibrate", "evaluate"])
@pytest.mark.parametrize("content, says", [r[1:] for r in CSV_REFUSED], ids=[r[0] for r in CSV_REFUSED])
def test_broken_measurement_file_is_refused(tmp_path, verb, content, says):
    args = ["calibrate", "ur5", "f.csv", "--out", "o.json"] if verb == "calibrate" else ["evaluate", "ur5_model.json", "f.csv"]
    refuse(tmp_path, args, {"f.csv": content}, says)


CSV_SAME = [
    ("utf-16", ur5(lambda t: t.encode("utf-16"))),
    ("utf-32", ur5(lambda t: t.encode("utf-32"))),
    ("bom", ur5(lambda t: ("\ufeff" + t).encode())),
    ("bom-and-crlf", ur5(lambda t: ("\ufeff" + t).replace("\n", "\r\n").encode())),
    ("crlf", ur5(lambda t: t.replace("\n", "\r\n"))),
    ("cr-only", ur5(lambda t: t.replace("\n", "\r"))),
    ("trailing-blank-lines", ur5(lambda t: t + "\n\n\n")),
    ("trailing-commas", ur5(lambda t: "\n".join(r + "," for r in t.splitlines()) + "\n")),
    ("spaces-after-commas-in-header", with_header(lambda h: h.replace(",", ", "))),
    ("quoted-numbers", ur5(lambda t: "\n".join([t.splitlines()[0]] + [",".join(f'"{v}"' for v in r.split(",")) for r in t.splitlines()[1:]]) + "\n")),
    ("extra-comment-column-latin-1", ur5(lambda t: ("\n".join([t.splitlines()[0] + ",comment"] + [r + ",café" for r in t.splitlines()[1:]]) + "\n").encode("latin-1"))),
    # hostile pass 5
    ("utf-16-big-endian-with-bom", ur5(lambda t: ("\ufeff" + t).encode("utf-16-be"))),
    ("blank-lines-between-rows", ur5(lambda t: t.replace("\n", "\n\n", 20))),
]


@pytest.mark.parametrize("content", [r[1] for r in CSV_SAME], ids=[r[0] for r in CSV_SAME])
def test_harmless_variant_evaluates_as_the_clean_file(tmp_path, content):
    prepare(tmp_path, {"f.csv": content})
    got = invoke(tmp_path, ["evaluate", "ur5_model.json", "f.csv", "--json"])
    want = invoke(tmp_path, ["evaluate", "ur5_model.json", "ur5.csv", "--json"])
    assert got.code == 0, got.output
    assert json.loads(got.result.stdout)["mean_mm"] == pytest.approx(json.loads(want.result.stdout)["mean_mm"], rel=1e-9)


@pytest.mark.parametrize("content", [CSV_SAME[0][1], CSV_SAME[3][1]], ids=["utf-16", "bom-and-crlf"])
def test_harmless_variant_calibrates_as_the_clean_file(tmp_path, content):
    prepare(tmp_path, {"f.csv": content})
    assert invoke(tmp_path, ["calibrate", "ur5", "f.csv", "--out", "o.json"]).code == 0
    got = invoke(tmp_path, ["evaluate", "o.json", "ur5.csv", "--json"])
    want = invoke(tmp_path, ["evaluate", "ur5_model.json", "ur5.csv", "--json"])
    assert json.loads(got.result.stdout)["mean_mm"] == pytest.approx(json.loads(want.result.stdout)["mean_mm"], rel=1e-6)


def targets(change):
    return lambda base: change((base / "targets.csv").read_text())


TARGETS_REFUSED = [
    ("empty", lambda b: "", "is empty"),
    ("header-only", targets(lambda t: t.splitlines()[0] + "\n"), "has a header but no data rows"),
    ("nan", targets(lambda t: t.replace("78.439", "nan")), "'nan' is not a finite number"),
    ("inf", targets(lambda t: t.replace("-38.323", "inf")), "'inf' is not a finite number"),
    ("semicolons-decimal-commas", targets(lambda t: t.replace(",", ";").replace(".", ",")), "is not comma-separated"),
    ("duplicate-rx", targets(lambda t: t.replace("ry", "rx", 1)), "column 'rx' appears twice"),
    ("truncated", targets(lambda t: t[: len(t) // 2]), "cells but the header has 13 columns"),
    ("utf-16-without-bom", targets(lambda t: t.encode("utf-16-le")), "is not a text CSV file"),
    ("hints-without-orientation", targets(lambda t: "\n".join(",".join(c for i, c in enumerate(r.split(",")) if i not in (3, 4, 5)) for r in t.splitlines()) + "\n"), "lacks columns rx, ry, rz"),
    # hostile pass 5
    ("utf-32-little-endian-without-bom", targets(lambda t: t.encode("utf-32-le")), "is not a text CSV file"),
    ("nan-posture-hint", targets(lambda t: "\n".join(",".join("nan" if (k == 3 and i == 8) else v for i, v in enumerate(r.split(","))) for k, r in enumerate(t.splitlines())) + "\n"), "row 4, column 'q3': 'nan' is not a finite number"),
]


@pytest.mark.parametrize("content, says", [r[1:] for r in TARGETS_REFUSED], ids=[r[0] for r in TARGETS_REFUSED])
def test_broken_targets_file_is_refused(tmp_path, content, says):
    refuse(tmp_path, ["compensate", "ur5_model.json", "t.csv", "--out", "o.csv"], {"t.csv": content}, says)


def model(change):
    return lambda base: change((base / "ur5_model.json").read_text())


def edited(key, value):
    def change(t):
        data = json.loads(t)
        if value is KeyError:
            data.pop(key)
        else:
            data[key] = value
        return json.dumps(data)
    return model(change)


MODEL_KEYS = ["software_version", "created", "method", "robot", "kinematics", "reference", "error_model",
              "training", "options", "domain", "bound"]
MODEL_REFUSED = [
    ("truncated", model(lambda t: t[: len(t) // 2]), "not JSON"),
    ("empty", lambda b: "", "not JSON"),
    ("empty-object", lambda b: "{}", 'no "schema": "robocal.model"'),
    ("a-list", lambda b: "[]", 'no "schema": "robocal.model"'),
    ("null", lambda b: "null", 'no "schema": "robocal.model"'),
    ("nan-literal", model(lambda t: t.replace("89.159", "NaN", 1)), "holds NaN or infinite numbers"),
    ("infinity-literal", model(lambda t: t.replace("89.159", "Infinity", 1)), "holds NaN or infinite numbers"),
    ("trailing-garbage", model(lambda t: t + "xyz"), "Extra data"),
    ("gzip-compressed", model(lambda t: gzip.compress(t.encode())), "it is not a text file"),
    ("no-schema-version", edited("schema_version", KeyError), "has no 'schema_version'"),
    ("schema-version-text", edited("schema_version", "x"), "'schema_version' in the model file has the wrong type"),
    ("schema-version-from-the-future", edited("schema_version", 7), "schema version 7 is newer"),
    ("no-checksum", edited("checksum", KeyError), "has no 'checksum'"),
    ("checksum-a-number", edited("checksum", 7), "'checksum' in the model file has the wrong type"),
    ("schema-a-number", edited("schema", 7), 'no "schema": "robocal.model"'),
    # hostile pass 5: one byte that is not UTF-8 in the robot's name
    ("one-latin-1-byte", lambda b: (b / "ur5_model.json").read_bytes().replace(b"Universal Robots UR5", b"Universal Robots UR5\xe9", 1), "the checksum does not match"),
] + [(f"{key}-removed", edited(key, KeyError), "the checksum does not match") for key in MODEL_KEYS] + [
    (f"{key}-a-text", edited(key, "x"), "the checksum does not match") for key in MODEL_KEYS]


@pytest.mark.parametrize("content, says", [r[1:] for r in MODEL_REFUSED], ids=[r[0] for r in MODEL_REFUSED])
def test_broken_model_file_is_refused(tmp_path, content, says):
    refuse(tmp_path, ["evaluate", "m.json", "ur5.csv"], {"m.json": content}, says)


@pytest.mark.parametrize("content", [model(lambda t: t.encode("utf-16")), model(lambda t: ("\ufeff" + t).encode()),
                                     model(lambda t: t.replace("\n", "\r\n"))], ids=["utf-16", "bom", "crlf"])
def test_re_encoded_model_file_still_loads(tmp_path, content):
    prepare(tmp_path, {"m.json": content})
    assert invoke(tmp_path, ["evaluate", "m.json", "ur5.csv"]).code == 0


def robot(change):
    return lambda base: change((base / "ur5_cal.toml").read_text())


def joint_entries(*entries):
    """A change of the robot file setting each (joint, key, TOML text) of ``entries``: the
    calibrated values differ in their last digits from one version of the fit to another."""
    def change(text):
        blocks = text.split("[[joints]]")
        for joint, key, value in entries:
            blocks[joint] = re.sub(rf"(?m)^{key} = .*$", f"{key} = {value}", blocks[joint], count=1)
        return "[[joints]]".join(blocks)
    return change


# A UR5 in product-of-exponentials form (robocal export --convention poe writes this form).
POE = 'name = "ur5 poe"\nconvention = "poe"\n' + "".join(
    f"\n[[joints]]\naxis = {axis}\npoint = {point}\ntheta = 0.0\nmin = -360.0\nmax = 360.0\n" for axis, point in [
        ("[0.0, 0.0, 1.0]", "[0.0, 0.0, 0.0]"), ("[0.0, 1.0, 0.0]", "[0.0, 0.0, 89.159]"),
        ("[0.0, 1.0, 0.0]", "[-425.0, 0.0, 89.159]"), ("[0.0, 1.0, 0.0]", "[-817.25, 0.0, 89.159]"),
        ("[0.0, 0.0, -1.0]", "[-817.25, -109.15, 0.0]"), ("[0.0, 1.0, 0.0]", "[-817.25, 0.0, -5.491]")])

ROBOT_REFUSED = [
    ("truncated", robot(lambda t: t[: len(t) // 2]), "is not valid TOML"),
    ("empty", lambda b: "", "the robot file is empty"),
    ("nan-length", robot(joint_entries((2, "a", "nan"))), "joint 2 a must be finite"),
    ("inf-length", robot(lambda t: t.replace("d = 89.159", "d = inf")), "joint 1 d must be finite"),
    ("length-in-quotes", robot(joint_entries((2, "a", '"-424.9"'))), "joint 2 a must be a number"),
    ("decimal-comma", robot(lambda t: t.replace("d = 89.159", "d = 89,159")), "is not valid TOML"),
    ("boolean-twist", robot(joint_entries((1, "alpha", "true"))), "joint 1 alpha must be a number"),
    ("min-above-max", robot(lambda t: t.replace("min = -360.0", "min = 400.0", 1)), "min 400.0 is above max 360.0"),
    ("no-joints", robot(lambda t: t.split("[[joints]]")[0] + "[tool]\nxyz=[0,0,0]\n"), "no [[joints]] tables"),
    ("one-joint", robot(lambda t: "[[joints]]".join(t.split("[[joints]]")[:2]) + "\n"), "but the robot has 1 joints"),
    ("duplicate-key", robot(lambda t: t.replace("d = 89.159", "d = 89.159\nd = 90.0")), "Cannot overwrite a value"),
    ("unknown-convention", robot(lambda t: t.replace('convention = "dh"', 'convention = "xyz"')), "convention must be one of 'dh', 'mdh', 'poe'"),
    ("joints-single-brackets", robot(lambda t: t.replace("[[joints]]", "[joints]", 1)), "is not valid TOML"),
    ("nul-bytes", robot(lambda t: t.replace("\n", "\x00\n", 2)), "is not a text file"),
    ("negative-mass", robot(lambda t: t.replace("mass = 3.7", "mass = -3.7")), "masses must be 6 finite values >= 0 kg"),
    ("poe-axis-of-zero-length", lambda b: POE.replace("axis = [0.0, 1.0, 0.0]", "axis = [0.0, 0.0, 0.0]", 1), "a POE joint axis has zero length"),
    ("twists-in-radians", robot(joint_entries((1, "alpha", "1.5703"), (4, "alpha", "1.5705"), (5, "alpha", "-1.5708"))), "the alpha of the [[joints]] look like radians"),
    # hostile pass 5
    ("infinite-joint-limit", robot(lambda t: t.replace("max = 360.0", "max = inf", 1)), "joint 1 max must be finite, got inf"),
    ("mass-of-one-joint-left-out", robot(lambda t: t.replace("mass = 3.7\n", "", 1)), "mass (kg) is given for 5 of 6 joints: give it for every joint or none"),
]


@pytest.mark.parametrize("content, says", [r[1:] for r in ROBOT_REFUSED], ids=[r[0] for r in ROBOT_REFUSED])
def test_broken_robot_file_is_refused(tmp_path, content, says):
    refuse(tmp_path, ["calibrate", "r.toml", "ur5.csv", "--out", "o.json"], {"r.toml": content}, says)


def urdf(change):
    return lambda base: change((base / "ur5_cal.urdf").read_text())


BOMB = ('<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "aaaaaaaaaa">'
        + "".join(f'<!ENTITY {n} "{("&" + p + ";") * 10}">' for p, n in zip("abcdefg", "bcdefgh"))
        + ']><robot name="&h;"></robot>')
URDF_REFUSED = [
    ("truncated", urdf(lambda t: t[: len(t) // 2]), "is not well-formed XML"),
    ("empty", lambda b: "", "is not well-formed XML"),
    ("not-xml", lambda b: "hello", "is not well-formed XML"),
    ("no-joints", lambda b: '<robot name="x"><link name="a"/></robot>', "no movable joint"),
    ("billion-laughs", lambda b: BOMB, "is not well-formed XML"),
    ("nan-origin", urdf(lambda t: t.replace('xyz="0.0 0.0 1.0"', 'xyz="nan 0.0 1.0"', 1)), "is not three numbers"),
    ("decimal-comma", urdf(lambda t: t.replace('xyz="0.0 0.0 1.0"', 'xyz="0,0 0.0 1.0"', 1)), "is not three numbers"),
    ("two-numbers", urdf(lambda t: t.replace('xyz="0.0 0.0 1.0"', 'xyz="0.0 1.0"', 1)), "is not three numbers"),
    ("branch-without-tip", urdf(lambda t: t.replace("</robot>", '<link name="camera"/><joint name="cam" type="fixed"><parent link="base_link"/><child link="camera"/></joint></robot>')), "choose the tip link"),
    # hostile pass 5
    ("lower-limit-above-upper", urdf(lambda t: re.sub(r'lower="([^"]*)" upper="([^"]*)"', r'lower="\2" upper="\1"', t, count=1)), "joint 'joint_1' has lower limit 6.283185307179586 above upper limit"),
    ("quadratic-entity-blowup", lambda b: '<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "' + "a" * 100000 + '">]><robot name="x">' + "&a;" * 20000 + "</robot>", "is not well-formed XML (limit on input amplification factor"),
]


@pytest.mark.parametrize("content, says", [r[1:] for r in URDF_REFUSED], ids=[r[0] for r in URDF_REFUSED])
def test_broken_urdf_is_refused(tmp_path, content, says):
    refuse(tmp_path, ["calibrate", "r.urdf", "ur5.csv", "--out", "o.json"], {"r.urdf": content}, says)


def fixture(change):
    return lambda base: change((base / "plate.toml").read_text())


FIXTURE_REFUSED = [
    ("empty", lambda b: "", "has no [sockets] table"),
    ("truncated", fixture(lambda t: t[:-20]), "is not valid TOML"),
    ("no-sockets", lambda b: 'name = "x"\n', "has no [sockets] table"),
    ("one-socket", lambda b: "[sockets]\nA = [0.0, 0.0, 0.0]\n", "needs at least two"),
    ("nan", fixture(lambda t: t.replace("150.0", "nan")), "is not three finite numbers"),
    ("two-coordinates", fixture(lambda t: t.replace("[150.0, 0.0, 0.0]", "[150.0, 0.0]")), "is not three finite numbers"),
    ("coordinate-in-quotes", fixture(lambda t: t.replace("150.0", '"150"')), "is not three finite numbers"),
    ("socket-given-twice", fixture(lambda t: t + "B = [150.0, 1.0, 0.0]\n"), "is not valid TOML (Cannot overwrite a value"),
    ("four-coordinates", fixture(lambda t: t.replace("[150.0, 0.0, 0.0]", "[150.0, 0.0, 0.0, 1.0]")), "is not three finite numbers"),
    ("sockets-as-inline-tables", lambda b: "[sockets]\nA = {x = 0.0, y = 0.0, z = 0.0}\nB = {x = 150.0, y = 0.0, z = 0.0}\nC = {x = 0.0, y = 120.0, z = 0.0}\n", "write it as [x, y, z] in mm"),
    ("coincident-sockets", fixture(lambda t: t.replace("[150.0, 0.0, 0.0]", "[0.0, 0.0, 0.0]")), "are both at"),
    ("sockets-an-array", lambda b: "sockets = [1,2,3]\n", "has no [sockets] table"),
    ("socket-ids-not-in-data", fixture(lambda t: t.replace("A = ", "X = ")), "socket id(s) A are not in fixture"),
    ("spacings-ten-percent-large", fixture(lambda t: t.replace("150.0", "165.0").replace("120.0", "132.0")), "these ball-in-socket data are not this robot's (or fixture's)"),
    ("kilometre-spacing", fixture(lambda t: t.replace("150.0", "150000.0")), "misses the fixture's socket distances"),
]


@pytest.mark.parametrize("content, says", [r[1:] for r in FIXTURE_REFUSED], ids=[r[0] for r in FIXTURE_REFUSED])
def test_broken_fixture_is_refused(tmp_path, content, says):
    refuse(tmp_path, ["calibrate", "kr150-2", "sockets.csv", "--method", "constraint", "--fixture", "f.toml", "--out", "o.json"],
           {"f.toml": content}, says)


FLEET = '[[robot]]\nname = "a"\nrobot = "ur5"\ntrain = "ur5.csv"\n'
FLEET_REFUSED = [
    ("empty", "", "lists no robots"),
    ("unknown-top-key", 'title = "x"\n', "unknown key 'title' at the top"),
    ("single-brackets", FLEET.replace("[[robot]]", "[robot]"), "must be [[robot]] tables (double brackets)"),
    ("no-train", '[[robot]]\nname = "a"\nrobot = "ur5"\n', "no train"),
    ("name-climbs-out", FLEET.replace('"a"', '"../evil"'), "is not a plain file name"),
    ("name-empty", FLEET.replace('"a"', '""'), "name must be a non-empty text in quotes"),
    ("name-a-number", FLEET.replace('"a"', "3"), "name must be a non-empty text in quotes"),
    ("two-robots-one-name", FLEET + FLEET, "are both named 'a'"),
    ("unknown-option", FLEET + "options = { foo = 1 }\n", "calibrate has no option --foo"),
    ("option-of-wrong-type", FLEET + 'options = { seed = "x" }\n', "options.seed must be a whole number"),
    ("option-nested", FLEET + "options = { parameters = { a = 1 } }\n", "options.parameters must be a text"),
    ("option-out", FLEET + 'options = { out = "x.json" }\n', "calibrate has no option --out"),
    ("unknown-method", FLEET + 'method = "magic"\n', "method must be one of"),
    ("unknown-robot", FLEET.replace('"ur5"', '"ur99"'), "robot 'ur99' is neither a built-in robot"),
    ("truncated", FLEET[:30], "is not valid TOML"),
    ("options-a-text", FLEET + 'options = "parameters=full"\n', "options must be a table of calibrate's options"),
    # hostile pass 5
    ("name-dot-dot", FLEET.replace('"a"', '".."'), "name '..' is not a plain file name"),
    ("option-misspelt", FLEET + '[robot.options]\nparamters = "full"\n', "calibrate has no option --paramters"),
]


@pytest.mark.parametrize("content, says", [r[1:] for r in FLEET_REFUSED], ids=[r[0] for r in FLEET_REFUSED])
def test_broken_fleet_file_is_refused(tmp_path, content, says):
    refuse(tmp_path, ["fleet", "fl.toml", "--out", "FO", "--jobs", "1"], {"fl.toml": content}, says)


def truth(change):
    return lambda base: change((base / "ur5_truth.json").read_text())


TRUTH_REFUSED = [
    ("empty", lambda b: "", "is not a JSON truth file"),
    ("truncated", truth(lambda t: t[: len(t) // 2]), "is not a JSON truth file"),
    ("a-list", lambda b: "[]", "not a robocal truth file"),
    ("no-format", truth(lambda t: json.dumps({k: v for k, v in json.loads(t).items() if k != "format"})), "not a robocal truth file"),
    ("format-a-text", truth(lambda t: json.dumps(dict(json.loads(t), format="x"))), "not a robocal truth file"),
    ("version-a-text", truth(lambda t: json.dumps(dict(json.loads(t), version="x"))), "this robocal reads version 1"),
    ("negative-noise", truth(lambda t: json.dumps(dict(json.loads(t), noise=-1.0))), "noise must be a standard deviation >= 0"),
    ("nan-deviation", truth(lambda t: re.sub(r'("a2": )(-?[0-9.e-]+)', r"\1NaN", t, count=1)), "deviations a2 must be finite"),
    # hostile pass 5
    ("deviations-a-list", truth(lambda t: json.dumps(dict(json.loads(t), deviations=[1, 2]))), "deviations must be a table, got [1, 2]"),
]


@pytest.mark.parametrize("content, says", [r[1:] for r in TRUTH_REFUSED], ids=[r[0] for r in TRUTH_REFUSED])
def test_broken_truth_file_is_refused(tmp_path, content, says):
    refuse(tmp_path, ["simulate", "ur5", "--n", "10", "--errors", "t.json", "--out", "s.csv"], {"t.json": content}, says)


TRUTH_ENTRIES = ["backlash", "noise", "compliance", "deviations", "seed", "robot", "noise_orientation"]


@pytest.fixture(scope="module")
def truth_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("truth")
    from typer.testing import CliRunner

    from robocal.interfaces.cli import app

    CliRunner().invoke(app, ["simulate", "ur5", "--n", "10", "--out", str(folder / "a.csv"),
                             "--truth", str(folder / "t.json")])
    return folder, json.loads((folder / "t.json").read_text())


@pytest.mark.parametrize("entry", TRUTH_ENTRIES)
def test_a_truth_file_entry_of_the_wrong_type_is_refused_naming_it(entry, truth_file):
    from typer.testing import CliRunner

    from robocal.interfaces.cli import app

    folder, document = truth_file
    (folder / f"bad_{entry}.json").write_text(json.dumps({**document, entry: "x"}))
    out = folder / f"s_{entry}.csv"
    result = CliRunner().invoke(app, ["simulate", "ur5", "--n", "10", "--errors", str(folder / f"bad_{entry}.json"),
                                      "--out", str(out)])
    assert result.exit_code != 0 and f"{entry} must be" in result.output
    assert "Traceback" not in result.output and len(result.output.strip().splitlines()) == 1
    assert not out.exists()


def test_a_fleet_file_that_is_a_pipe_or_a_folder_is_named_as_such(tmp_path):
    from typer.testing import CliRunner

    from robocal.interfaces.cli import app

    os.mkfifo(tmp_path / "pipe.toml")
    (tmp_path / "folder.toml").mkdir()
    for name, says in (("pipe.toml", "not a regular file"), ("folder.toml", "is a directory")):
        result = CliRunner().invoke(app, ["fleet", str(tmp_path / name), "--out", str(tmp_path / "out")])
        assert result.exit_code != 0 and says in result.output and "does not exist" not in result.output
        assert not (tmp_path / "out").exists()


def test_an_output_under_a_file_says_the_file_is_not_a_folder(tmp_path):
    from typer.testing import CliRunner

    from robocal.interfaces.cli import app

    (tmp_path / "afile").write_text("")
    result = CliRunner().invoke(app, ["simulate", "ur5", "--n", "10", "--out", str(tmp_path / "afile" / "o.csv")])
    assert result.exit_code != 0 and "is a file, not a directory" in result.output


# Every reader of a table, given a file of another format, names what the file is in one line
# (robocal.io.file_kinds.text_format, asked by the bounded reader of tables), whichever verb
# reads it: never a row count, a field-size complaint or a traceback.
PROGRAMS = Path(__file__).resolve().parent / "data" / "programs"
POINTS = "name,x,y,z\nP1,100,200,300\nP2,110,210,310\nP3,120,220,320\n"
TABLE_READERS = [
    ("measurements", ["calibrate", "ur5", "{f}", "--out", "o.json"]),
    ("evaluate-data", ["evaluate", "ur5_model.json", "{f}"]),
    ("targets", ["compensate", "ur5_model.json", "{f}", "--out", "o.csv"]),
    ("candidates", ["design", "ur5", "--n", "6", "--candidates", "{f}", "--out", "p.csv"]),
    ("existing", ["design", "ur5", "--n", "6", "--pool", "100", "--existing", "{f}", "--out", "p.csv"]),
    ("placements", ["design", "kr150-2", "--n", "6", "--fixture", "plate.toml", "--placements", "{f}", "--out", "p.csv"]),
    ("tracker-points", ["import", "--points", "{f}", "--joints", "ur5.csv", "--out", "j.csv"]),
    ("joint-log", ["import", "--points", "pts.csv", "--joints", "{f}", "--out", "j.csv"]),
    ("iso-campaign", ["iso9283", "{f}"]),
]
OTHER_FORMATS = [
    # robocal's own files are named by their kind (robocal.io.file_kinds.check) ...
    ("report.html", "is robocal's HTML report, written by 'robocal report', not a"),
    ("ur5_model.json", "is a robocal model file, written by 'robocal calibrate', not a"),
    ("ur5_truth.json", "is a truth file (the simulated robot's true errors), written by 'robocal simulate --truth', not"),
    ("plate.toml", "is a fixture file (socket centres), not a"),
    ("ur5_cal.toml", "is a robot file, written by 'robocal export', not a"),
    ("ur5_cal.urdf", "is a URDF robot description, written by 'robocal export --format urdf', not a"),
    # ... other files by their format (robocal.io.file_kinds.text_format).
    ("doc.json", "is a JSON document (a robocal model file?), not a table"),
    ("prog.script", "is a robot program, not a table"),
    ("prog.src", "is a robot program, not a table"),
]


@pytest.mark.parametrize("name, says", OTHER_FORMATS, ids=[row[0] for row in OTHER_FORMATS])
@pytest.mark.parametrize("args", [row[1] for row in TABLE_READERS], ids=[row[0] for row in TABLE_READERS])
def test_a_file_of_another_format_given_as_a_table_is_named(tmp_path, args, name, says):
    files = {"pts.csv": POINTS, "doc.json": '[\n  {"a": 1, "b": [2, 3]}\n]\n',
             "prog.script": (PROGRAMS / "urscript" / "feeder_to_tray.script").read_text(),
             "prog.src": next((PROGRAMS / "krl").glob("*.src")).read_text(errors="replace")}
    refuse(tmp_path, [a.format(f=name) for a in args], files, f"{name} {says}")


def sep_line(separator, data="ur5.csv"):
    """Excel's export of ``data`` with its separator stated on a first line sep=X."""
    def make(base):
        body = (base / data).read_text()
        return f"sep={separator}\r\n" + body.replace(",", separator).replace("\n", "\r\n")
    return make


# Columns separated by anything but the comma, unstated, are refused saying what separates
# them, by every CSV reader; stated on Excel's first line (sep=, or sep=;) they are read.
SEPARATORS_REFUSED = [
    ("tabs", ur5(lambda t: t.replace(",", "\t")), "its columns are separated by tabs"),
    ("spaces", ur5(lambda t: t.replace(",", " ")), "its columns are separated by spaces"),
    ("aligned-spaces", ur5(lambda t: t.replace(",", "   ")), "its columns are separated by spaces"),
    ("semicolons", ur5(lambda t: t.replace(",", ";")), "its columns are separated by semicolons"),
    ("markdown-table", ur5(lambda t: "\n".join("| " + r.replace(",", " | ") + " |" for r in t.splitlines()) + "\n"), "its columns are separated by vertical bars"),
    ("sep-tab-stated", ur5(lambda t: "sep=\t\n" + t.replace(",", "\t")), "its first line (sep=) says the columns are separated by a tab"),
    ("sep-pipe-stated", ur5(lambda t: "sep=|\n" + t.replace(",", "|")), "separated by '|'"),
]
SEPARATOR_READERS = [row for row in TABLE_READERS
                     if row[0] in ("measurements", "candidates", "existing", "joint-log", "iso-campaign")]


@pytest.mark.parametrize("content, says", [r[1:] for r in SEPARATORS_REFUSED], ids=[r[0] for r in SEPARATORS_REFUSED])
@pytest.mark.parametrize("args", [row[1] for row in SEPARATOR_READERS], ids=[row[0] for row in SEPARATOR_READERS])
def test_columns_not_separated_by_commas_are_refused_saying_by_what(tmp_path, args, content, says):
    refuse(tmp_path, [a.format(f="f.csv") for a in args], {"f.csv": content, "pts.csv": POINTS}, says)


@pytest.mark.parametrize("separator", [",", ";"], ids=["sep-comma", "sep-semicolon"])
def test_an_excel_sep_line_is_honoured(tmp_path, separator):
    prepare(tmp_path, {"m.csv": sep_line(separator), "t.csv": sep_line(separator, "targets.csv"),
                       "c.csv": sep_line(separator, "plan.csv")})
    assert invoke(tmp_path, ["calibrate", "ur5", "m.csv", "--out", "o.json"]).code == 0
    got = invoke(tmp_path, ["evaluate", "o.json", "ur5.csv", "--json"])
    want = invoke(tmp_path, ["evaluate", "ur5_model.json", "ur5.csv", "--json"])
    assert json.loads(got.result.stdout)["mean_mm"] == pytest.approx(json.loads(want.result.stdout)["mean_mm"], rel=1e-9)
    # Targets and a design's candidates too: the same answer as the comma file.
    assert invoke(tmp_path, ["compensate", "ur5_model.json", "t.csv", "--out", "o.csv"]).code == 0
    assert (tmp_path / "o.csv").read_text() == text("cmds.csv")
    for data, out in (("c.csv", "a.csv"), ("plan.csv", "b.csv")):
        outcome = invoke(tmp_path, ["design", "ur5", "--n", "10", "--candidates", data, "--out", out])
        assert outcome.code == 0, outcome.output
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()


def cycles_as_text(base):
    """An ISO 9283 campaign whose cycle column says "cycle 1", as a hand-kept log does."""
    header, *body = campaign()(base).splitlines()
    k = header.split(",").index("cycle")
    return "\n".join([header] + [",".join(f"cycle {v}" if i == k else v for i, v in enumerate(r.split(",")))
                                 for r in body]) + "\n"



def pose_id_emptied(base):
    """An ISO 9283 campaign whose first visit has lost its pose id."""
    header, first, *body = campaign()(base).splitlines()
    k = header.split(",").index("pose")
    return "\n".join([header, ",".join("" if i == k else v for i, v in enumerate(first.split(",")))] + body) + "\n"


ISO_REFUSED = [
    ("cycle-as-text", cycles_as_text, "column 'cycle': 'cycle 1' is not a number"),
    # hostile pass 5
    ("pose-id-empty", pose_id_emptied, "row 2, column 'pose' is empty: every row needs a pose id"),
]


@pytest.mark.parametrize("content, says", [r[1:] for r in ISO_REFUSED], ids=[r[0] for r in ISO_REFUSED])
def test_broken_iso_campaign_is_refused(tmp_path, content, says):
    refuse(tmp_path, ["iso9283", "f.csv"], {"f.csv": content}, says)
