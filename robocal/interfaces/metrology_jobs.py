"""The job behind ``robocal iso9283 CAMPAIGN.csv``: the measured figures, with ``--model`` the
figures the compensated robot is predicted to reach beside them, with ``--report`` the ISO
page.

A campaign is measured with the controller's own (uncompensated) commands, so the
compensated robot's figures cannot be measured from it, only predicted: each visit's
attained position less the model's predicted systematic error at its joint command, where
the model says the TCP goes (``predict(q)``, brought from the measurement frame into the
robot base frame the model registered) less where the controller's nominal robot puts it
(its forward kinematics from its base, which is what ``iso9283 plan`` commands).  That is
the error compensation removes: the geometry's, and the tool's offset the calibration found.
The campaign's positions are taken to be in the robot base frame as the model registered it
(the instrument's frame registered to the robot as the calibration did).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..acceptance.iso9283 import DEFAULT_MATCH_MM, PREDICTED_NOTE, characteristics, predicted_compensated
from ..acceptance.job import check_match_mm
from ..errors import InputError
from ..io.atomic import check_outputs
from ..estimation.plausibility import check_model_data
from ..io.iso_campaign import campaign_measurements, read_iso_campaign
from ..io.observations import observations
from .results import CompensatedFigures, Iso9283Figures


def systematic_error(model, fitted, joints_file):
    """The model's predicted systematic error (N, 3) mm in the robot base frame at the joint
    commands ``joints_file`` (N, n) in file units (deg, mm): where the fitted method says the
    TCP goes, in the base frame its registered nominal robot (``fitted.reference_``) stands
    in, less where the controller's nominal robot (``model.nominal`` from its base) puts it."""
    reference = fitted.reference_
    if reference is None:
        raise InputError("this model file records no registered robot base to bring its prediction into the "
                         "campaign's frame: calibrate it again with this version of robocal")
    joints = model.nominal.joints_from_file(joints_file)
    base = reference.base
    # Row vectors: p_base = R^T (p - t) is (p - t) @ R.
    predicted = (fitted.predict(joints) - base[:3, 3]) @ base[:3, :3]
    return predicted - model.nominal.replace(base=np.eye(4)).fk_positions(joints)


def iso9283_job(measurements, *, match_mm=DEFAULT_MATCH_MM, model=None, report=None, instrument=None,
                conditions=None):
    """The ISO 9283 figures of the campaign file ``measurements``, an
    :class:`.results.Iso9283Figures`; with ``model`` (a model file) the predicted figures of
    the compensated robot (``compensated``); with ``report`` the ISO page written there (HTML,
    atomically), naming the ``instrument`` and the test ``conditions`` given."""
    check_match_mm(match_mm)
    if report is not None and not str(report).lower().endswith((".html", ".htm")):
        raise InputError(f"the ISO page is HTML: give --report a .html file name, got {report}")
    check_outputs([report], [measurements, model])
    campaign = read_iso_campaign(measurements)
    result = Iso9283Figures(characteristics(campaign, match_mm=match_mm),
                            None if model is None else _compensated(campaign, model, match_mm))
    if report is not None:
        from .report_iso import write_iso_page

        write_iso_page(report, campaign, result, instrument=instrument, conditions=conditions)
        result = replace(result, report=str(report))
    return result


def _compensated(campaign, model_path, match_mm):
    """The :class:`.results.CompensatedFigures`: the predicted figures, the model they come
    from and what they mean."""
    from .jobs import load_fitted

    model, fitted = load_fitted(model_path)
    chain = model.nominal
    if campaign.joints is None:
        raise InputError(f"{campaign.path} has no joint command q1..q{chain.n_joints}: --model predicts the "
                         "compensated robot at each visit's joint command (iso9283 plan writes it)")
    if campaign.joints.shape[1] != chain.n_joints:
        raise InputError(f"{campaign.path} has joint columns q1..q{campaign.joints.shape[1]}, but the model's robot "
                         f"{chain.name!r} has {chain.n_joints} joints")
    # The campaign's joint commands and measured positions are a robot's data given to a model:
    # the units judged by its robot and the one data check, as evaluate's (jobs.read_model_data).
    check_model_data(model, observations(model.kinematics, campaign_measurements(campaign)), model_path)
    _check_commands_are_the_models(campaign, model, model_path)
    predicted = predicted_compensated(campaign, systematic_error(model, fitted, campaign.joints), match_mm=match_mm)
    return CompensatedFigures(str(model_path), model.method, PREDICTED_NOTE, predicted)


def _check_commands_are_the_models(campaign, model, model_path):
    """InputError when the campaign's commanded positions are not where the model's nominal
    robot (its forward kinematics from its base, what ``iso9283 plan`` commands) puts the
    joint commands: then the campaign's TCP or frame is another one, and the model's
    systematic error, taken between its prediction and that nominal robot, would carry the
    difference into every compensated figure (ipa UR10 series D's campaign, 92 mm from the
    robot file's tool: AP 1.14 mm measured, 19 mm "compensated").  Allowed: the registered
    nominal robot's 95th percentile of predicted error (a controller whose own model
    differs from the drawing as a real robot does), else the largest training residual
    before calibration."""
    joints = model.nominal.joints_from_file(campaign.joints)
    nominal = model.nominal.replace(base=np.eye(4)).fk_positions(joints)
    apart = np.linalg.norm(nominal - campaign.commanded, axis=1)
    predicted = model.training.get("predicted_error") or {}
    allowed = predicted.get("nominal_p95_mm") or (model.training.get("residual_before") or {}).get("max_mm")
    if allowed is None or apart.max() <= allowed:
        return
    worst = int(np.argmax(apart))
    raise InputError(
        f"{campaign.path}: the commanded positions are not where the nominal robot of {model_path} puts the joint "
        f"commands (robot base frame): up to {apart.max():.1f} mm apart (line {campaign.rows[worst]}), where that "
        f"robot's own error allows {allowed:.1f} mm; the campaign's tool or frame is not the model's. Command the "
        "campaign from the model's robot file (robocal iso9283 plan), or calibrate the model with the campaign's "
        "tool")


def model_iso_section(campaign_path, model_path):
    """The ISO page of the campaign file ``campaign_path`` with the predicted figures of the
    robot compensated by ``model_path``, as a section of ``robocal report``."""
    from .report_iso import iso_section

    result = iso9283_job(campaign_path, model=model_path)
    return iso_section(read_iso_campaign(campaign_path), result)
