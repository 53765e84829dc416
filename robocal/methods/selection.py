"""Choosing a model by what it does where it was not trained: ``robocal compare`` and
``calibrate --method auto``.

One engine serves both: every registered method says whether and how it is a candidate
(its ``candidates`` classmethod, :mod:`robocal.methods.candidacy`), the splits hold poses
out (:mod:`robocal.methods.splits`: random folds, or leave-one-out on a small campaign, and
regions of configuration space), and every candidate is scored on them
(:mod:`robocal.methods.scoring`).

The recommendation (:func:`recommend`) answers inside the training domain, where targets lie
among the training poses as the random folds hold them out, so it is judged on those, with
the regions as a guard: the baseline (the first candidate: the default calibration, ``full``
under its tolerances, which the prior keeps well posed on any number of poses) stays chosen
unless another model is better on the random folds by more than the spread of that gain from
fold to fold, and not worse on the regions by more than the spread there; of the models that
pass, the one with the lowest random-fold error is taken, or, among those the random folds
cannot tell from it, the one that models most (a residual above its kinematic model, then the
parameter set).  A residual model (hybrid, network) that does not beat its own base model on
the region split is dropped, with a line that says so.  (Judging by the regions first, as
this module first did, kept the rigid calibration on UR10 series A where the hybrid was three
times better on a random half: ``bench/model_choice.py``.)  A small campaign has no region
split to guard with: the choice then rests on the random folds, and says so.

Beyond the training data no split can judge a model; there ``calibrate --method auto``
answers with the kinematic calibration without joint gains (:func:`outside_choice`,
:mod:`robocal.methods.fallback`), target by target.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from .candidacy import PARAMETER_SETS, Candidate
from .fallback import wrap
from .scoring import (NOMINAL, Score, _Nominal, _Refits, _groups, held_out_errors, score, score_all, score_task,
                      unfitted)
from .splits import (BRANCH_MIN_SHARE, FOLDS, MIN_TRAINING_POSES, TIME_TAIL, Split, branch_split, cluster_split,
                     joint_features, leave_one_out, placement_split, random_split, repeated_split, splits, time_split)

# Kept importable from here (earlier homes of these names).
_held_out_errors = held_out_errors
_score_all = score_all
__all__ = ["BRANCH_MIN_SHARE", "FOLDS", "MIN_TRAINING_POSES", "NOMINAL", "PARAMETER_SETS", "TIME_TAIL", "Candidate",
           "Comparison", "Score", "Split", "_Nominal", "_Refits", "_groups", "branch_split", "candidates", "choose",
           "cluster_split", "compare", "joint_features", "leave_one_out", "outside_alternative", "outside_choice",
           "placement_split", "random_split", "recommend", "repeated_split", "score", "score_task", "splits",
           "time_split"]

# calibrate --method auto: the meta-method that fits the model compare recommends.
AUTO = "auto"
# The registered nominal robot, the baseline of every table, is registered on each training
# part: that takes 4 poses (robocal.estimation.registration).
REGISTRATION_POSES = 4
# Differences of held-out mean error below this (mm) are ties whatever their spread: no
# tracker resolves them, and two models that differ only where a parameter was left out (a
# compliance not told from zero) otherwise differ by 1e-4 mm with a spread of 0.
RESOLUTION = 1e-3


def candidates(observations, *, chain=None, training=None, network=None, folds=FOLDS):
    """(models, notes): the models every registered method offers for ``observations`` of
    ``chain`` (its ``candidates`` classmethod), the baseline first, and lines saying which
    were left out and why.  ``training``: the poses a comparison fit sees (default: the
    ``folds``-fold training part); ``network`` True/False forces the network in or out."""
    from . import REGISTRY

    if training is None:
        training = observations.n_poses * (folds - 1) // folds
    if chain is None:
        raise InputError("candidates() needs the robot the observations were read for: pass chain=")
    out, notes = [], []
    forced = {} if network is None else {"ann": network}
    for method in REGISTRY.values():
        offered, said = method.candidates(chain, observations, training, forced)
        out += offered
        notes += said
    return out, notes


def _fitting(candidate_list, split, n):
    """(candidates whose fit the split's training parts can take, notes on the others,
    [(labels, poses to measure)]): a linearised fit on a small campaign's split is fitted on
    all ``n`` poses (deletion); any other on the training part of each fold."""
    refit = n - max(len(t) for t in split.tests)
    kept, short = [], {}
    for candidate in candidate_list:
        sees = n if (candidate.linear and split.deletion) else refit
        if sees >= candidate.minimum_poses:
            kept.append(candidate)
            continue
        # Poses to measure so that its fits see enough: one more than it needs when one pose is
        # held out at a time, else the k-fold total whose training parts hold that many.
        folds = len(split.tests) if split.groups is None and not split.deletion else None
        measure = (candidate.minimum_poses + 1 if folds is None
                   else int(np.ceil(candidate.minimum_poses * folds / (folds - 1))))
        short.setdefault((candidate.minimum_poses, sees, measure), []).append(candidate.label)
    notes = [f"{', '.join(labels)} left out: {'its' if len(labels) == 1 else 'their'} fit needs {need} poses, the "
             f"comparison's fits see {sees}; measure at least {measure}"
             for (need, sees, measure), labels in short.items()]
    return kept, notes, [(labels, measure) for (_, _, measure), labels in short.items()]


# ---------------------------------------------------------------------------- the choice
@dataclass
class Comparison:
    """What :func:`compare` measured and recommends.

    Attributes: ``poses``, ``file``; ``splits`` (names and kinds); ``scores``:
    {label: {split name: Score}} with the registered nominal under "nominal (registered)";
    ``candidates`` (the :class:`Candidate` list); ``recommended`` (a Candidate); ``reasons``:
    lines that say why; ``dropped``: lines naming the residual models that did not beat their
    base; ``notes``: splits and candidates left out; ``seconds``: {label: total s};
    ``outside``: what answers outside the training domain (:func:`outside_choice`) or None;
    ``verdicts``: per candidate, whether the random folds told it from the baseline
    ({label, verdict, gain_mm, spread_mm}); ``advice``: what to measure to let a richer
    model win.
    """

    poses: int
    file: str
    splits: list
    scores: dict
    candidates: list
    recommended: Candidate
    reasons: list
    dropped: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    seconds: dict = field(default_factory=dict)
    outside: Candidate | None = None
    verdicts: list = field(default_factory=list)
    advice: list = field(default_factory=list)

    def _method_of(self, label):
        """The method and settings of a compared model ({} for the registered nominal)."""
        for candidate in self.candidates:
            if candidate.label == label:
                return {"method": candidate.method, "settings": candidate.settings}
        return {}

    def to_dict(self):
        return {"file": self.file, "poses": self.poses,
                "splits": [{"name": s.name, "kind": s.kind, "folds": list(s.fold_names)} for s in self.splits],
                "models": [{"label": label, **self._method_of(label),
                            "scores": {name: score.to_dict() for name, score in by_split.items()},
                            "seconds": self.seconds.get(label)}
                           for label, by_split in self.scores.items()],
                "recommended": {"label": self.recommended.label, "method": self.recommended.method,
                                "settings": self.recommended.settings},
                "outside_domain": None if self.outside is None else {
                    "label": self.outside.label, "method": self.outside.method, "settings": self.outside.settings},
                "reasons": self.reasons, "dropped": self.dropped, "notes": self.notes,
                "verdicts": self.verdicts, "advice": self.advice}


def _behind(scores, label, best, splits_):
    """(how far ``label`` is behind ``best`` per fold, its spread), mm."""
    gain, spread = _gain(scores, label, best, splits_)
    return -gain, spread


def _beyond(gain, spread):
    """Whether a mean ``gain`` (mm) exceeds its fold-to-fold ``spread`` and RESOLUTION."""
    return gain > max(spread, RESOLUTION)


def _gain(scores, better, worse, splits_):
    """Mean and fold-to-fold standard deviation of the per-fold gain (mm) of ``better`` over
    ``worse`` over the folds of ``splits_`` (paired by fold; :meth:`Score.judged` means, folds
    with no held-out pose inside their training domain left out)."""
    if not splits_:
        return 0.0, 0.0
    gain = np.concatenate([scores[worse][s.name].judged()[0] - scores[better][s.name].judged()[0] for s in splits_])
    gain = gain[np.isfinite(gain)]
    if not gain.size:
        return 0.0, 0.0
    spread = float(gain.std(ddof=1)) if gain.size > 1 else 0.0
    return float(gain.mean()), spread


def recommend(comparison_scores, candidate_list, split_list):
    """(chosen Candidate, reasons, dropped): the rule of the module docstring.

    The chosen model answers inside its training domain (outside, :func:`outside_choice`'s
    does), where targets lie among the training poses as random folds hold them out: it is
    judged there, with the held-out regions as a guard (their folds pooled; on each, the
    held-out poses inside the fold's training domain, :meth:`Score.judged`).  Residual
    models that do not beat their own base model on the regions are dropped.  The contenders
    are the models whose gain over the baseline (the first candidate) on the random folds is
    larger on average than its fold-to-fold standard deviation, and that are not worse than
    the baseline on the regions by more than the fold-to-fold deviation of that difference.
    The contender with the lowest random-fold error is the best; of the models not guarded out
    whose random-fold error is within the fold-to-fold spread of the best's, the one that
    models most (:meth:`Candidate.richness`) is chosen.  With no contender, the baseline.
    With no region split (a small campaign), no guard."""
    regions = [s for s in split_list if s.kind == "region"]
    random = next((s for s in split_list if s.kind == "random"), regions[0] if regions else None)
    # A region split whose held-out poses all lie outside their training domain (the other
    # arm branch) is the fallback's to answer, not the chosen model's: it is left out here
    # unless every region split is like that.
    some_inside = [s for s in regions if all(np.isfinite(comparison_scores[c.label][s.name].inside_mean)
                                             for c in candidate_list)]
    regions = some_inside or regions
    where = "the held-out regions" if len(regions) > 1 else regions[0].name if regions else None
    by_label = {c.label: c for c in candidate_list}

    def region(label):
        if not regions:
            return float("nan")
        return float(np.mean([comparison_scores[label][s.name].judged()[1] for s in regions]))

    def at_random(label):
        return comparison_scores[label][random.name].judged()[1]

    dropped, eligible = [], []
    for candidate in candidate_list:
        base = candidate.base
        if regions and base is not None and base in comparison_scores and region(candidate.label) >= region(base):
            dropped.append(f"{candidate.label} dropped: on {where} it does not beat its base model {base} "
                           f"({region(candidate.label):.4f} mm against {region(base):.4f} mm)")
            continue
        eligible.append(candidate)
    simplest = eligible[0]
    contenders, guarded, unguarded = [], [], [simplest]
    for candidate in eligible[1:]:
        gain, spread = _gain(comparison_scores, candidate.label, simplest.label, [random])
        region_gain, region_spread = _gain(comparison_scores, candidate.label, simplest.label, regions)
        if _beyond(-region_gain, region_spread):
            if _beyond(gain, spread):
                guarded.append(f"{candidate.label} not taken: {gain:.4f} mm better on {random.name}, but worse on "
                               f"{where} by {-region_gain:.4f} mm, more than the fold-to-fold spread "
                               f"({region_spread:.4f} mm)")
            continue
        unguarded.append(candidate)
        if _beyond(gain, spread):
            contenders.append((at_random(candidate.label), candidate, gain, spread))
    on_regions = (f", {region(simplest.label):.4f} mm on {where} (judged on the held-out poses inside each fold's "
                  "training domain, where the chosen model answers)" if regions else
                  " (no region split: the training parts would be too small, so the random folds alone judge)")
    reasons = [f"the baseline, {simplest.label}: {at_random(simplest.label):.4f} mm held out on {random.name}"
               f"{on_regions}"] + guarded
    guard = f" without losing on {where}" if regions else ""
    if not contenders:
        reasons.append(f"no other model beats it on {random.name} by more than the fold-to-fold spread of its gain"
                       f"{guard}: keep it")
        return simplest, reasons, dropped
    _, best, gain, spread = min(contenders, key=lambda item: item[0])
    others = len(contenders) - 1
    not_worse = f", is not worse on {where} ({region(best.label):.4f} mm)" if regions else ""
    reasons.append(f"{best.label} beats it by {gain:.4f} mm per fold on {random.name}, more than the fold-to-fold "
                   f"spread of that gain ({spread:.4f} mm){not_worse}, "
                   f"and has the lowest held-out error on {random.name} ({at_random(best.label):.4f} mm)"
                   + (f" of the {others + 1} models that pass so" if others else ""))
    # Models the random folds cannot tell from the best: the one that models most of the robot
    # (UR5 and UR10 A: the hybrids differ by 1 % in cross-validation; the richest was the best
    # held out by 3-5 %).
    ties = [c for c in unguarded if not _beyond(*_behind(comparison_scores, c.label, best.label, [random]))]
    chosen = max(ties, key=Candidate.richness)
    if chosen.richness() > best.richness():
        behind, spread = _gain(comparison_scores, best.label, chosen.label, [random])
        within = (f"within the fold-to-fold spread ({spread:.4f} mm)" if spread >= RESOLUTION
                  else f"less than the {RESOLUTION * 1e3:.0f} µm a tracker resolves")
        reasons.append(f"{chosen.label} is {behind:.4f} mm behind it on {random.name}, {within}, and models more of "
                       "the robot: take it")
        return by_label[chosen.label], reasons, dropped
    reasons[-1] += ": take it"
    return by_label[best.label], reasons, dropped


def _richness(candidate):
    """Kept for callers of the earlier name: :meth:`Candidate.richness`."""
    return candidate.richness()


def outside_choice(comparison_scores, candidate_list, split_list, recommended):
    """(Candidate or None, reason): what answers for configurations outside the training
    domain (see :mod:`robocal.methods.fallback` for why): the kinematic calibration without
    joint gains — with joint compliance, which models gravity wherever the arm goes, unless
    the held-out regions show it worse than the rigid one by more than the fold-to-fold
    spread of the difference, or there is no region split to show it either way (a small
    campaign: the rigid one, which the tolerances hold nearest the drawing).  None when there
    is no kinematic candidate (ball-in-socket data) or when it is the recommended model itself."""
    kinematic = {c.settings.get("parameters"): c for c in candidate_list if c.method == "kinematic"}
    rigid, compliant = kinematic.get("full"), kinematic.get("full+compliance")
    if rigid is None and compliant is None:
        return None, None
    regions = [s for s in split_list if s.kind == "region"]
    chosen, why = rigid or compliant, "the rigid kinematic calibration"
    if rigid is not None and compliant is not None:
        gain, spread = _gain(comparison_scores, compliant.label, rigid.label, regions)
        if not regions:
            why = "no region split tells whether the compliance holds beyond the poses: the rigid one"
        elif _beyond(-gain, spread):
            why = (f"{compliant.label} is worse than {rigid.label} on the held-out regions by {-gain:.4f} mm, more "
                   f"than the fold-to-fold spread ({spread:.4f} mm)")
        else:
            chosen, why = compliant, "joint compliance models gravity on every branch"
    if chosen.label == recommended.label:
        return None, None
    return chosen, (f"outside the training domain (another arm branch, a joint beyond its measured range) it "
                    f"answers with {chosen.label}: error models know nothing there and joint gains extrapolate; "
                    f"{why}")


# -------------------------------------------------------------------------- the reasoning
def verdicts(comparison_scores, candidate_list, split_list, baseline):
    """Per candidate, what the random folds tell of it against ``baseline``: {label,
    verdict ('baseline', 'better', 'worse' or 'not told apart'), gain_mm, spread_mm}."""
    random = next((s for s in split_list if s.kind == "random"), split_list[0])
    out = []
    for candidate in candidate_list:
        if candidate.label == baseline.label:
            out.append({"label": candidate.label, "verdict": "baseline", "gain_mm": 0.0, "spread_mm": 0.0})
            continue
        gain, spread = _gain(comparison_scores, candidate.label, baseline.label, [random])
        verdict = "better" if _beyond(gain, spread) else "worse" if _beyond(-gain, spread) else "not told apart"
        out.append({"label": candidate.label, "verdict": verdict, "gain_mm": gain, "spread_mm": spread})
    return out


def advice(found, candidate_list, chosen, split_list, wants, poses):
    """Lines saying what to measure to let a richer model than ``chosen`` win: poses for the
    models left out by their minimum (``wants``: [(labels, poses)]), the regions' guard, and,
    for a richer model whose gain lay within its spread, about how many poses would tell it
    (the spread of a fold's mean shrinks as one over the root of its poses)."""
    lines = [f"{', '.join(labels)}: measure at least {measure} poses" for labels, measure in wants]
    by_label = {c.label: c for c in candidate_list}
    hopeful = [v for v in found if v["verdict"] == "not told apart" and v["gain_mm"] > RESOLUTION
               and by_label[v["label"]].richness() > chosen.richness()]
    for v in sorted(hopeful, key=lambda v: -v["gain_mm"] / max(v["spread_mm"], 1e-12))[:2]:
        need = int(np.ceil(poses * (v["spread_mm"] / v["gain_mm"]) ** 2))
        lines.append(f"{v['label']}: {v['gain_mm']:.4f} mm better per fold but within the spread "
                     f"({v['spread_mm']:.4f} mm); about {need} poses spread like these would tell it")
    if not any(s.kind == "region" for s in split_list):
        least = int(np.ceil(MIN_TRAINING_POSES * FOLDS / (FOLDS - 1)))
        lines.append(f"no region split guards the choice: measure at least {least} poses spread over the workspace "
                     f"(each of {FOLDS} regions left out then trains on {MIN_TRAINING_POSES})")
    return lines


def compare(chain, observations, *, folds=None, seed=0, network=None, on_fit=None, only=None):
    """Score every :func:`candidates` model (``only``: a list of labels to keep) on every
    :func:`~robocal.methods.splits.splits` split of ``observations`` of ``chain``, beside the
    registered nominal, and recommend one (:func:`recommend`).  ``folds``: of the random split
    and the joint-space regions (default 5; leave-one-out on a small campaign).
    ``on_fit(steps=1)`` is called as fits finish.  The fits run on the active
    :func:`robocal.parallel.executor` when there is one.  Returns a :class:`Comparison`."""
    if folds is not None and folds < 2:
        raise InputError(f"--folds must be at least 2, got {folds}")
    split_list, notes = splits(chain, observations, folds=folds, seed=seed)
    random = split_list[0]
    n = observations.n_poses
    offered, left_out = candidates(observations, chain=chain, training=n - max(len(t) for t in random.tests),
                                   network=network)
    candidate_list, too_few, wants = _fitting(offered, random, n)
    held = max(len(t) for t in random.tests)
    if not candidate_list or n - held < REGISTRATION_POSES:
        least = min(offered, key=lambda c: c.minimum_poses)
        need = max(least.minimum_poses + (0 if least.linear and random.deletion else held), REGISTRATION_POSES + held)
        raise InputError(f"{observations.path or 'the data'} holds {n} poses: the simplest model, {least.label}, "
                         f"needs {need} to be fitted and judged on poses it did not see; measure more poses")
    notes = notes + left_out + too_few
    if only is not None:
        unknown = sorted(set(only) - {c.label for c in candidate_list})
        if unknown:
            raise InputError(f"no candidate model is called {', '.join(unknown)}; the candidates are "
                             f"{', '.join(c.label for c in candidate_list)}")
        candidate_list = [c for c in candidate_list if c.label in only]
    scores, seconds = score_all(chain, observations, candidate_list, split_list, on_fit)
    chosen, reasons, dropped = recommend(scores, candidate_list, split_list)
    outside, why = outside_choice(scores, candidate_list, split_list, chosen)
    if why:
        reasons.append(why)
    found = verdicts(scores, candidate_list, split_list, candidate_list[0])
    return Comparison(n, observations.path, split_list, scores, candidate_list, chosen, reasons, dropped, notes,
                      seconds, outside, found, advice(found, candidate_list, chosen, split_list, wants, n))


def choose(chain, observations, *, folds=None, seed=0, network=None, on_fit=None, progress=None):
    """``calibrate --method auto``: :func:`compare`, then the recommended method fitted on all
    of ``observations``, answering with the :func:`outside_choice` model (fitted on all of
    them too) outside its training domain (:mod:`robocal.methods.fallback`).  Returns (fitted
    method, :class:`Comparison`)."""
    comparison = compare(chain, observations, folds=folds, seed=seed, network=network, on_fit=on_fit)
    fitted = unfitted(comparison.recommended).fit(chain, observations, progress=progress)
    if comparison.outside is not None:
        fallback = unfitted(comparison.outside).fit(chain, observations)
        wrap(fitted, fallback, comparison.outside.label)
        other = outside_alternative(comparison)
        if other is not None:
            # Kept for a re-registration, whose new poses may show it carries to a new set-up
            # better than the fallback (robocal.methods.reregistration).
            fitted.outside_alternative_ = (other.label, unfitted(other).fit(chain, observations).compensator_)
    return fitted, comparison


def outside_alternative(comparison):
    """The other of the two kinematic candidates :func:`outside_choice` chose between (the
    rigid one when it chose the compliant one, and back), or None: what could answer outside
    the domain instead of the fallback."""
    outside = comparison.outside
    pair = ("full", "full+compliance")
    if outside is None or outside.settings.get("parameters") not in pair:
        return None
    wanted = pair[1 - pair.index(outside.settings["parameters"])]
    return next((c for c in comparison.candidates if c.method == "kinematic"
                 and c.settings.get("parameters") == wanted and c.label != comparison.recommended.label), None)
