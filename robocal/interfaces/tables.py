"""Rich tables of robots and results for the terminal."""
import numpy as np
from rich.table import Table

from ..spatial import pose_to_xyz_rpy


def _fmt(value, digits=4):
    if not np.isfinite(value):
        return "-"
    text = f"{value:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def robot_tables(chain):
    """Parameter table, limits and frames of a chain (file units: mm, deg)."""
    title = f"{chain.name} — {chain.convention.upper()}, {chain.n_joints} joints"
    table = Table(title=title)
    table.add_column("joint")
    table.add_column("type")
    if chain.convention == "poe":
        cols = ("axis", "point (mm)", "theta")
    else:
        cols = ("a (mm)", "alpha (deg)", "d (mm)", "theta (deg)", "beta (deg)")
    masses = ("mass (kg)",) if chain.masses is not None else ()
    for c in cols + ("min", "max", "sign") + masses:
        table.add_column(c, justify="right")
    coupled = not np.allclose(chain.joint_map, np.diag(np.diag(chain.joint_map)))
    for i, kind in enumerate(chain.joint_types):
        revolute = kind == "revolute"
        ang = np.degrees if revolute else (lambda v: v)
        if chain.convention == "poe":
            vals = (" ".join(_fmt(v) for v in chain.axes[i]), " ".join(_fmt(v, 3) for v in chain.points[i]),
                    _fmt(ang(chain.theta[i])))
        else:
            vals = (_fmt(chain.a[i]), _fmt(np.degrees(chain.alpha[i])), _fmt(chain.d[i]),
                    _fmt(ang(chain.theta[i])), _fmt(np.degrees(chain.beta[i])))
        sign = "coupled" if coupled else ("-1" if chain.joint_map[i, i] < 0 else "+1")
        mass = (_fmt(chain.masses[i], 3),) if masses else ()
        # A joint's name (URDF, or name = in the robot file) beside its number: data files may
        # name their columns either way.
        label = str(i + 1) if not chain.joint_names else f"{i + 1} {chain.joint_names[i]}"
        table.add_row(label, kind[0].upper(), *vals, _fmt(ang(chain.lower[i]), 2),
                      _fmt(ang(chain.upper[i]), 2), sign, *mass)
    frames = Table(title="frames (xyz mm, rpy deg)")
    for c in ("frame", "x", "y", "z", "rx", "ry", "rz"):
        frames.add_column(c, justify="right")
    named = [("base", chain.base)]
    poe = chain.convention == "poe"
    named.append(("home" if poe else "flange", chain.home if poe else chain.flange))
    named.append(("tool", chain.tool))
    named.append(("TCP at q = 0", chain.fk(np.zeros(chain.n_joints))))
    for label, T in named:
        xyz, rpy = pose_to_xyz_rpy(T)
        frames.add_row(label, *(_fmt(v, 3) for v in xyz), *(_fmt(v, 3) for v in np.degrees(rpy)))
    out = [table, frames]
    if coupled:
        out.append("joint_map (q_model = joint_map @ q_controller):\n" + np.array2string(chain.joint_map))
    return out


# What the POE parameter names mean, said wherever they are printed.
POE_NAMES_NOTE = ("POE parameters: thetaK is joint K's zero offset; uxK, uyK shift its axis along the x, y "
                  "of its frame; wxK, wyK tilt the axis about them; home_* is the flange pose at zero")
BASE_NOTE = ("base_* and tool_* are changes from the registered start (nominal geometry with base and tool "
             "fitted to the data), not from the robot file")


def estimate_text(value, std_error):
    """A deviation written to the precision its standard error supports: the standard error
    to two significant digits and the deviation to the same decimal place."""
    if not (np.isfinite(std_error) and std_error > 0):
        return f"{value:.6g}", f"{std_error:.2g}"
    place = 1 - int(np.floor(np.log10(std_error)))  # decimals that show 2 digits of the error
    digits = max(place, 0)
    text = f"{value:.{digits}f}"
    return ("0" if float(text) == 0 else text), f"{std_error:.{digits}f}"


def parameter_rows(calibration, chain):
    """(name, deviation, standard error, unit) of every identified parameter of a
    :class:`~robocal.methods.CalibrationRecord`, as text; ``chain`` names the units.  A
    calibration under the tolerances adds (prior, share of its variance the data removed):
    "held by its prior" below half."""
    from ..estimation.identification import HELD_BY_PRIOR

    space = chain.parameters
    rows = []
    for name, estimate in calibration.parameters.items():
        deviation, error = estimate_text(estimate.deviation, estimate.std_error)
        record = space.get(name)
        row = (name, deviation, error, record.file_unit if record is not None else "")
        if estimate.data_share is not None:
            prior = "-" if estimate.prior_std is None else f"{estimate.prior_std:.2g}"
            share = "-" if estimate.prior_std is None else f"{estimate.data_share:.0%}"
            if estimate.prior_std is not None and estimate.data_share < HELD_BY_PRIOR:
                share += " (held by its prior)"
            row += (prior, share)
        rows.append(row)
    return rows


# What the prior columns mean, said wherever they are printed.
PRIOR_NOTE = ("prior: the tolerance the fit weighed the parameter against (the robot file's [tolerances] or the "
              "defaults, times the scale the data support; - for none); from data: how much of its prior variance "
              "the data removed")


def parameter_notes(calibration, chain):
    """The sentences a parameter table needs to be read right."""
    notes = [BASE_NOTE] if any(n.startswith(("base_", "tool_")) for n in calibration.parameters) else []
    if any(p.data_share is not None for p in calibration.parameters.values()):
        notes.append(PRIOR_NOTE)
    if chain.convention == "poe":
        notes.append(POE_NAMES_NOTE)
    return notes
