"""The experiment file (TOML) parsed, once, into a frozen :class:`Experiment`."""

from __future__ import annotations

import copy
import dataclasses
import difflib
import hashlib
import math
import os
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from .._errors import InputFileError
from .._validate import range_text
from ..model import (Ball, Domain, damping_unit, mindlin_stiffness_ratio, model_parameters,
                     parameter_domain)
from ._priors import LogNormal, Normal, Prior, Uniform
from ._schema import (CANDIDATE_FIXED, CANDIDATE_KEYS, CANDIDATE_TABLES, OPTIONAL, PARAMETERS,
                      PRIOR_KEYS, REQUIRED_SECTIONS, SECTIONS, Key)
from ._toml import dumps


@dataclass(frozen=True)
class Incidence:
    """Nominal incidence at first contact and its bounce-to-bounce spread."""

    speed: float  #: m/s
    angle: float  #: deg from the normal
    spin: float = 0.0  #: rad/s
    speed_sd: float = 0.0  #: m/s
    angle_sd: float = 0.0  #: deg
    spin_sd: float = 0.0  #: rad/s


@dataclass(frozen=True)
class Experiment:
    """Everything known about an experiment, and what is to be inferred.

    ``priors`` maps each inferred parameter (of :attr:`model_parameters`: ``mu``, ``eta`` or
    ``restitution``, ``youngs_modulus`` or ``normal_stiffness``, ``spin``,
    ``tangential_stiffness_ratio``) to its prior; every other parameter is fixed at
    :meth:`fixed_value`. ``trajectories``, ``synth`` and ``inference`` hold those tables with
    defaults filled in. :meth:`model_options` and :meth:`bounce_model` give the contact law to
    the forward model.
    """

    name: str
    description: str
    ball: Ball
    inclination: float  #: deg, positive: the ball travels down-slope
    incidence: Incidence
    normal_law: str
    gravity: float  #: m/s^2
    contact: MappingProxyType  #: the values given in [contact]
    priors: MappingProxyType  #: name -> Prior, in file order
    trajectories: MappingProxyType
    synth: MappingProxyType
    source: str = "<string>"
    text_sha256: str = field(default="", compare=False)
    tangential: str = "none"  #: tangential compliance: none, mindlin or linear
    inference: MappingProxyType = field(default_factory=lambda: MappingProxyType(
        {k: v.default for k, v in SECTIONS["inference"].items()}))  #: [inference], filled
    #: the candidate models of [models.NAME] (``bouncebayes compare``), by name, in file order
    models: MappingProxyType = field(default_factory=lambda: MappingProxyType({}),
                                     compare=False)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """The inferred parameters, in file order."""
        return tuple(self.priors)

    @property
    def model_parameters(self) -> tuple[str, ...]:
        """Every per-bounce parameter of the experiment's contact law, inferred or fixed
        (``bouncebayes.model.model_parameters``)."""
        return model_parameters(self.normal_law, self.tangential)

    @property
    def model_options(self) -> dict[str, Any]:
        """The contact law and surface as keyword arguments of the forward model
        (``simulate``, ``simulate_history``, ``BounceModel``): ``normal_law``,
        ``tangential``, ``inclination``, ``gravity``."""
        return {"normal_law": self.normal_law, "tangential": self.tangential,
                "inclination": self.inclination, "gravity": self.gravity}

    def model_values(self, values: dict | None = None) -> dict[str, Any]:
        """Every parameter of the contact law as keyword arguments of the forward model:
        ``values`` (arrays or numbers, e.g. posterior draws) where given, the fixed value
        otherwise."""
        values = values or {}
        return {name: values[name] if name in values else self.fixed_value(name)
                for name in self.model_parameters}

    def bounce_model(self, *, speed, angle, spin=None, values: dict | None = None,
                     varying: tuple[str, ...] = (), **kwargs: Any):
        """The experiment's :class:`bouncebayes.model.BounceModel` under the incidence
        conditions ``speed``, ``angle`` (and ``spin``, default the parameter's value), with
        the contact law's parameters from ``values`` or fixed (those in ``varying`` come
        with each call); ``kwargs`` go to the model (``solver``, ``errors``)."""
        from ..model import BounceModel

        given = {} if values is None else dict(values)
        if spin is not None:
            given["spin"] = spin
        params: dict[str, Any] = {name: given[name] if name in given else (
            self.priors[name].ppf(0.5) if name in varying else self.fixed_value(name))
            for name in self.model_parameters}
        return BounceModel(self.ball, speed=speed, angle=angle, **params,
                           **self.model_options, varying=varying, **kwargs)

    def unit(self, name: str) -> str:
        """Unit of a parameter (the damping unit depends on the normal law)."""
        return damping_unit(self.normal_law) if name == "eta" else PARAMETERS[name][0]

    def fixed_value(self, name: str) -> float:
        """The value of a parameter that is not inferred, from the file (the ball's modulus,
        the incident spin, Mindlin's stiffness ratio where [contact] does not give one)."""
        if name in ("mu", "eta", "restitution", "normal_stiffness"):
            if name not in self.contact:
                raise InputFileError(self.source, f"missing; `{name}` is not inferred (no "
                                     f"[parameters.{name}]) so its value is needed",
                                     field=f"contact.{name}")
            return self.contact[name]
        if name == "tangential_stiffness_ratio":
            return self.contact.get(name, mindlin_stiffness_ratio(self.ball.poisson_ratio))
        return {"youngs_modulus": self.ball.youngs_modulus,
                "spin": self.incidence.spin}[name]

    def true_value(self, name: str) -> float:
        """The value used as the truth of synthetic campaigns (same source as fixed values)."""
        return self.fixed_value(name)


@dataclass(frozen=True)
class Candidate:
    """A candidate model of [models.NAME]: the experiment with its own contact law and priors
    (``experiment``), and that experiment as a whole TOML document of its own (``toml``), for
    a run folder that ``bouncebayes report`` can reopen."""

    name: str
    description: str
    experiment: Experiment
    document: dict = field(repr=False, compare=False)

    def toml(self) -> str:
        """The candidate's experiment file."""
        return dumps(self.document, header=f"candidate model {self.name!r} of "
                     f"{self.experiment.source} (bouncebayes compare): that file with its "
                     f"[models.{self.name}] table applied")


def load_experiment(path: str | os.PathLike) -> Experiment:
    """Read and validate an experiment file; every problem names the key and what is allowed."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputFileError(path, f"cannot read the experiment file ({exc.strerror})") from None
    try:
        doc = tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError:
        raise InputFileError(path, "not UTF-8 text; an experiment file is TOML") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputFileError(path, f"not valid TOML: {exc}") from None
    return parse_experiment(doc, source=str(path), sha256=hashlib.sha256(raw).hexdigest())


def parse_experiment(doc: dict, *, source: str = "<string>", sha256: str = "") -> Experiment:
    """Validate a parsed TOML document into an :class:`Experiment`."""
    p = _Parser(source)
    p.check_keys(doc, SECTIONS.keys() | {"parameters", "models"}, "", what="section")
    for name in REQUIRED_SECTIONS:
        if name not in doc:
            raise InputFileError(source, f"missing section [{name}]", field=name)
    t = {name: p.section(doc, name) for name in SECTIONS}
    ball = _ball(p, t["ball"])
    inc = t["incidence"]
    incidence = Incidence(inc["speed_m_s"], inc["angle_deg"], inc["spin_rad_s"],
                          inc["speed_sd_m_s"], inc["angle_sd_deg"], inc["spin_sd_rad_s"])
    priors = _priors(p, doc.get("parameters", {}), t["model"])
    _check_values_in_domain(p, t)
    experiment = Experiment(
        name=t["experiment"]["name"], description=t["experiment"]["description"], ball=ball,
        inclination=t["surface"]["inclination_deg"], incidence=incidence,
        normal_law=t["model"]["normal"], gravity=t["model"]["gravity_m_s2"],
        contact=MappingProxyType({k: v for k, v in t["contact"].items() if v is not None}),
        priors=MappingProxyType(priors), trajectories=MappingProxyType(t["trajectories"]),
        synth=MappingProxyType(t["synth"]), source=source, text_sha256=sha256,
        tangential=t["model"]["tangential"], inference=MappingProxyType(t["inference"]))
    candidates = _candidates(p, doc, experiment)
    return dataclasses.replace(experiment, models=MappingProxyType(candidates)) if candidates \
        else experiment


class _Parser:
    def __init__(self, source: str):
        self.source = source

    def error(self, key_path: str, message: str) -> InputFileError:
        return InputFileError(self.source, message, field=key_path)

    def check_keys(self, table: dict, allowed, prefix: str, *, what: str = "key") -> None:
        for key in table:
            if key not in allowed:
                hint = difflib.get_close_matches(key, allowed, n=1)
                where = f" in [{prefix}]" if prefix else ""
                suggestion = f" (did you mean `{hint[0]}`?)" if hint else ""
                raise self.error(f"{prefix}.{key}" if prefix else key,
                                 f"unknown {what}{suggestion}; allowed {what}s{where}: "
                                 f"{', '.join(sorted(allowed))}")

    def section(self, doc: dict, name: str) -> dict[str, Any]:
        table = doc.get(name, {})
        if not isinstance(table, dict):
            raise self.error(name, f"must be a table [{name}]; got {_kind(table)}")
        schema = SECTIONS[name]
        self.check_keys(table, schema, name)
        return {key: self.value(f"{name}.{key}", table, key, spec)
                for key, spec in schema.items()}

    def value(self, key_path: str, table: dict, key: str, spec: Key) -> Any:
        if key not in table:
            if spec.default is None:
                raise self.error(key_path, f"missing; required: {_describe(spec)}")
            return None if spec.default is OPTIONAL else spec.default
        v = table[key]
        if spec.kind is str:
            if not isinstance(v, str):
                raise self.error(key_path, f"must be a string; got {_kind(v)}")
            if spec.choices and v not in spec.choices:
                raise self.error(key_path, f"must be one of "
                                 f"{', '.join(repr(c) for c in spec.choices)}; got {v!r}")
            return v
        if isinstance(v, bool) or not isinstance(v, int | float) or (
                spec.kind is int and not isinstance(v, int)):
            noun = "an integer" if spec.kind is int else "a number"
            raise self.error(key_path, f"must be {noun}{_unit(spec.unit)}; got {_kind(v)}")
        ok = math.isfinite(v) or (spec.default in (math.inf, -math.inf) and not math.isnan(v))
        if spec.low is not None:
            ok &= v > spec.low if spec.low_open else v >= spec.low
        if spec.high is not None:
            ok &= v < spec.high if spec.high_open else v <= spec.high
        if not ok:
            raise self.error(key_path, f"must be {_describe(spec)}; got {v!r}")
        return spec.kind(v)


def _ball(p: _Parser, b: dict) -> Ball:
    for one, other in (("diameter_m", "radius_m"), ("mass_kg", "density_kg_m3")):
        if (b[one] is None) == (b[other] is None):
            got = "both" if b[one] is not None else "neither"
            raise p.error(f"ball.{one}", f"give exactly one of `ball.{one}` and "
                                         f"`ball.{other}`; got {got}")
    diameter = b["diameter_m"] if b["diameter_m"] is not None else 2.0 * b["radius_m"]
    try:
        return Ball.from_diameter(diameter, mass=b["mass_kg"], density=b["density_kg_m3"],
                                  youngs_modulus=b["youngs_modulus_Pa"],
                                  poisson_ratio=b["poisson_ratio"],
                                  inertia_factor=b["inertia_factor"])
    except ValueError as exc:  # outside the model's physical domain of a ball
        raise p.error("ball", str(exc)) from None


def _priors(p: _Parser, table: Any, model: dict) -> dict[str, Prior]:
    if not isinstance(table, dict):
        raise p.error("parameters", f"must hold tables [parameters.NAME]; got {_kind(table)}")
    p.check_keys(table, PARAMETERS, "parameters", what="parameter")
    used = model_parameters(model["normal"], model["tangential"])
    for name in table:
        if name not in used:
            raise p.error(f"parameters.{name}", f"not a parameter of the contact law "
                                                f"(normal = {model['normal']!r}, tangential = "
                                                f"{model['tangential']!r}), whose parameters "
                                                f"are {', '.join(used)}")
    return {name: _prior(p, name, spec, model["normal"]) for name, spec in table.items()}


def _prior(p: _Parser, name: str, spec: Any, normal_law: str, prefix: str = "parameters"
           ) -> Prior:
    path = f"{prefix}.{name}"
    if not isinstance(spec, dict):
        raise p.error(path, f"must be a table [{path}] with a prior; got {_kind(spec)}")
    kind = spec.get("prior", "uniform")
    if kind not in PRIOR_KEYS:
        raise p.error(f"{path}.prior", f"must be one of "
                      f"{', '.join(repr(k) for k in PRIOR_KEYS)}; got {kind!r}")
    keys = PRIOR_KEYS[kind]
    p.check_keys({k: v for k, v in spec.items() if k != "prior"}, keys, path)
    v = {k: p.value(f"{path}.{k}", spec, k, s) for k, s in keys.items()}
    if "low" in v and "high" in v and not v["low"] < v["high"]:
        raise p.error(path, f"`low` ({v['low']!r}) must be less than `high` ({v['high']!r})")
    prior: Prior
    if kind == "uniform":
        prior = Uniform(v["low"], v["high"])
    elif kind == "normal":
        prior = Normal(v["mean"], v["sd"], v["low"], v["high"])
    else:
        prior = LogNormal(v["median"], v["sd_log"])
    _check_prior_domain(p, path, name, kind, prior, parameter_domain(name, normal_law))
    return prior


# ------------------------------------------------------------ [models.NAME] (compare)

_CANDIDATE_NAME = re.compile(r"[A-Za-z0-9_-]+")


def _candidates(p: _Parser, doc: dict, base: Experiment) -> dict[str, Candidate]:
    """The candidate models of [models.NAME], each checked with its key paths."""
    table = doc.get("models", {})
    if not isinstance(table, dict):
        raise p.error("models", f"must hold tables [models.NAME]; got {_kind(table)}")
    out = {}
    for name, spec in table.items():
        if not _CANDIDATE_NAME.fullmatch(name):
            raise p.error(f"models.{name}", "a candidate's name may hold letters, digits, `-` "
                                            "and `_` only (it names a folder)")
        if not isinstance(spec, dict):
            raise p.error(f"models.{name}", f"must be a table [models.{name}]; got "
                                            f"{_kind(spec)}")
        out[name] = _candidate(p, doc, name, spec, base)
    return out


def _candidate(p: _Parser, doc: dict, name: str, spec: dict, base: Experiment) -> Candidate:
    """One candidate: its own keys checked where they are, then the merged document parsed."""
    path = f"models.{name}"
    p.check_keys(spec, set(SECTIONS["model"]) | set(CANDIDATE_KEYS)
                 | {CANDIDATE_FIXED, *CANDIDATE_TABLES}, path)
    model = {k: p.value(f"{path}.{k}", spec, k, s) for k, s in SECTIONS["model"].items()
             if k in spec}
    merged = copy.deepcopy({k: v for k, v in doc.items() if k != "models"})
    merged["model"] = {**merged.get("model", {}), **model}
    law = {k: merged["model"].get(k, SECTIONS["model"][k].default)
           for k in ("normal", "tangential")}
    merged["contact"] = {**merged.get("contact", {}), **_candidate_contact(p, spec, path)}
    merged["parameters"] = _candidate_priors(p, doc, spec, path, law)
    description = p.value(f"{path}.description", spec, "description",
                          CANDIDATE_KEYS["description"])
    merged["experiment"] = {**merged.get("experiment", {}),
                            "name": f"{base.name} [model {name}]"}
    if description:
        merged["experiment"]["description"] = description
    try:
        experiment = parse_experiment(merged, source=p.source)
    except InputFileError as exc:
        raise InputFileError(exc.path, f"{exc.reason} (for the candidate model [{path}], "
                                       f"which takes this value from the file's other tables)",
                             line=exc.line, field=exc.field) from None
    return Candidate(name, description, experiment, merged)


def _candidate_contact(p: _Parser, spec: dict, path: str) -> dict:
    table = spec.get("contact", {})
    if not isinstance(table, dict):
        raise p.error(f"{path}.contact", f"must be a table [{path}.contact]; got "
                                         f"{_kind(table)}")
    p.check_keys(table, SECTIONS["contact"], f"{path}.contact")
    return {k: p.value(f"{path}.contact.{k}", table, k, SECTIONS["contact"][k]) for k in table}


def _candidate_priors(p: _Parser, doc: dict, spec: dict, path: str, law: dict) -> dict:
    """The candidate's [parameters]: the file's for the parameters its law has, less ``fixed``,
    with its own added or replacing them."""
    used = model_parameters(law["normal"], law["tangential"])
    base = doc.get("parameters", {}) if isinstance(doc.get("parameters", {}), dict) else {}
    fixed = spec.get(CANDIDATE_FIXED, [])
    if not (isinstance(fixed, list) and all(isinstance(f, str) for f in fixed)):
        raise p.error(f"{path}.{CANDIDATE_FIXED}", f"must be an array of parameter names; got "
                                                   f"{_kind(fixed)}")
    for f in fixed:
        if f not in base:
            raise p.error(f"{path}.{CANDIDATE_FIXED}", f"{f!r} is not inferred in [parameters] "
                                                       f"(which has {', '.join(base) or 'none'})"
                                                       f"; only those can be kept fixed")
    own = spec.get("parameters", {})
    if not isinstance(own, dict):
        raise p.error(f"{path}.parameters", f"must hold tables [{path}.parameters.NAME]; got "
                                            f"{_kind(own)}")
    p.check_keys(own, PARAMETERS, f"{path}.parameters", what="parameter")
    for name, prior in own.items():
        if name not in used:
            raise p.error(f"{path}.parameters.{name}", f"not a parameter of this candidate's "
                          f"law (normal = {law['normal']!r}, tangential = "
                          f"{law['tangential']!r}), whose parameters are {', '.join(used)}")
        _prior(p, name, prior, law["normal"], prefix=f"{path}.parameters")
    out = {k: v for k, v in base.items() if k in used and k not in fixed} | own
    if not out:
        raise p.error(path, "this candidate infers nothing: its law has none of the parameters "
                            "of [parameters] (or `fixed` keeps them all); give it a "
                            f"[{path}.parameters.NAME] prior")
    return out


# Values of the file that are inputs of the model: key path -> the model's input name.
_MODEL_INPUTS = {("contact", "mu"): "mu", ("contact", "eta"): "eta",
                 ("contact", "restitution"): "restitution",
                 ("contact", "normal_stiffness"): "normal_stiffness",
                 ("contact", "tangential_stiffness_ratio"): "tangential_stiffness_ratio",
                 ("incidence", "speed_m_s"): "speed", ("incidence", "spin_rad_s"): "spin",
                 ("model", "gravity_m_s2"): "gravity"}


def _check_values_in_domain(p: _Parser, t: dict) -> None:
    """Fixed values that feed the model must lie in its physical domain (an incident speed of
    1e5 m/s would otherwise fail later, far from the key that caused it). [contact] values of
    parameters the contact law does not have are left alone (other models may use them)."""
    used = model_parameters(t["model"]["normal"], t["model"]["tangential"])
    for (section, key), name in _MODEL_INPUTS.items():
        value = t[section][key]
        if value is None or (section == "contact" and name not in used):
            continue
        domain = parameter_domain(name, t["model"]["normal"])
        if not domain.contains(value):
            raise p.error(f"{section}.{key}", f"must be {domain.describe()} ({domain.reason}); "
                                              f"got {value!r}")


# Prior mass allowed beyond the model's domain in an unbounded tail (a normal or lognormal
# prior); draws there are impossible parameter values (status INVALID_INPUT, likelihood zero).
TAIL_MASS = 1e-9


def _check_prior_domain(p: _Parser, path: str, name: str, kind: str, prior: Any,
                        domain: Domain) -> None:
    """A uniform prior must lie inside the parameter's physical domain; the tails of the other
    priors may leave it only with negligible mass."""
    low, high = prior.support
    for side, end, bound, key in (("below", low, domain.low, "low"),
                                  ("above", high, domain.high, "high")):
        outside = end < bound if side == "below" else end > bound
        if not outside:
            continue
        if kind != "uniform":
            mass = float(prior.dist.cdf(bound) if side == "below" else prior.dist.sf(bound))
            if mass <= TAIL_MASS:
                continue
        op = ">=" if side == "below" else "<="
        fix = (f"set `{key}` {op} {bound:g}" if kind == "uniform" or
               (kind == "normal" and not math.isinf(end))
               else f"truncate it with `{key} = {bound:g}`" if kind == "normal"
               else "narrow it (or use a truncated normal prior)")
        unit = f" {domain.unit}" if domain.unit else ""
        raise p.error(path, f"the prior ({prior.describe()}) puts mass {side} {bound:g}{unit}, "
                            f"where `{name}` is not physical; {fix} (the model's domain of "
                            f"`{name}`: {domain.describe()}, {domain.reason})")


def _describe(spec: Key) -> str:
    if spec.kind is str:
        allowed = (f"one of {', '.join(repr(c) for c in spec.choices)}" if spec.choices
                   else "a string")
        return f"{spec.doc}, {allowed}"
    words = range_text(spec.low, spec.high, spec.low_open, spec.high_open, spec.unit)
    if spec.kind is int:
        words = words.replace("a finite number", "an integer")
    return f"{words} ({spec.doc})"


def _unit(unit: str) -> str:
    return f" (in {unit})" if unit else ""


def _kind(v: Any) -> str:
    names = {str: "the string", bool: "the boolean", dict: "a table", list: "an array"}
    for t, noun in names.items():
        if isinstance(v, t):
            return f"{noun} {v!r}" if t in (str, bool) else noun
    return f"{v!r}"
