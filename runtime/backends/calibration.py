"""A drive's calibration file: what a user tells the runtime of its robot's errors (issue #36).

A robot told nothing gets the worst-case wheel prior and the shared match floor
(:meth:`~clomp.runtime.estimation.prior.OdometryPrior.worst`): its 95 % position bound is
wide, and a robot truly at its goal often ends GOAL_UNCONFIRMED. A user knows their drive
(its wheels' tolerance, how much they slip, how late it answers, whether the IMU's gain is
trimmed): ``clomp run --calibration FILE`` and ``clomp ros node --calibration FILE`` tell the
estimator, which sizes its prior to it
(:meth:`~clomp.runtime.estimation.prior.OdometryPrior.from_noise`). ``clomp emulate world
--calibration-out FILE`` writes the emulated world's.

The file is a JSON object or a TOML table (by the ``.toml`` suffix) of noise terms by name
(:data:`~clomp.planner.noise.NOISE_FIELDS`, SI units, standard deviations: the terms of
``specs/noise_presets.json``), each a finite number >= 0; a term left out is 0 — told *not
to exist*, so leave out only what the robot truly lacks. One more key, ``note`` (a string), is
free text. A told error source the filter does not model
(:data:`~clomp.planner.noise.UNMODELLED_FIELDS`: a wandering bias, slip events, pushes, …)
keeps the shared match floor on, and on a robot without a heading sensor the worst-case
wheels too: a calibration does not make such a robot claim more, it makes it claim honestly.

>>> told = parse_calibration({"wheel_sd": 0.02, "wheel_bias": 0.005, "note": "bench run, 2026-12"})
>>> told.wheel_bias, told.slip_rate
(0.005, 0.0)
>>> parse_calibration({"wheel_bias": -0.1})
Traceback (most recent call last):
...
clomp.runtime.backends.calibration.CalibrationError: calibration.wheel_bias: expected a finite number >= 0, got -0.1
"""

from __future__ import annotations

import json
import math
import os
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from clomp.planner.noise import NOISE_FIELDS, UNMODELLED_FIELDS, NoiseError, NoiseTerms

__all__ = ["CalibrationError", "ToldCalibration", "calibration_text", "load_calibration", "parse_calibration",
           "write_calibration"]

#: the one key of a calibration file that is no noise term: free text
NOTE = "note"
_MAX_BYTES = 1 << 16  # a calibration is a few lines; anything larger is the wrong file


class CalibrationError(ValueError):
    """A calibration file that cannot be used; the message names the file and the key."""


def parse_calibration(data: Any, where: str = "calibration") -> NoiseTerms:
    """The noise terms a calibration file's content ``data`` tells (see the module);
    CalibrationError naming the first bad key: not an object, an unknown key, a value that is
    not a finite number >= 0 (NaN, negative, a string, a boolean), ``dropout`` >= 1.

    >>> parse_calibration({"slip": 0.01}) == NoiseTerms(slip=0.01)
    True
    >>> parse_calibration({"wheel_bais": 0.01})
    Traceback (most recent call last):
    ...
    clomp.runtime.backends.calibration.CalibrationError: calibration: unknown key 'wheel_bais' (the keys are the noise terms: range_sd, angle_sd, dropout, wheel_sd, wheel_bias, drift, slip, latency, rate_sd, rate_bias, rate_scale, bias_walk, slip_rate, slip_duration, lidar_x, far_range, rate_asymmetry, push_rate, push_size; and note)
    """
    if not isinstance(data, Mapping):
        raise CalibrationError(f"{where}: expected an object of noise terms by name, got {type(data).__name__}")
    unknown = [k for k in data if k not in NOISE_FIELDS and k != NOTE]
    if unknown:
        raise CalibrationError(f"{where}: unknown key {unknown[0]!r} (the keys are the noise terms: "
                               f"{', '.join(NOISE_FIELDS)}; and {NOTE})")
    if NOTE in data and not isinstance(data[NOTE], str):
        raise CalibrationError(f"{where}.{NOTE}: expected a string, got {data[NOTE]!r}")
    terms = {str(k): v for k, v in data.items() if k != NOTE}
    try:
        return NoiseTerms(**terms)
    except NoiseError as exc:
        raise CalibrationError(str(exc).replace("noise.", f"{where}.", 1)) from None


def load_calibration(path: str | os.PathLike[str]) -> NoiseTerms:
    """The noise terms the calibration file at ``path`` tells: TOML for a ``.toml`` name,
    JSON otherwise; CalibrationError naming the file when it is missing, unreadable, not
    JSON/TOML or fails :func:`parse_calibration`."""
    p = Path(path)
    try:
        if not p.is_file():
            raise CalibrationError(f"{p}: no such calibration file")
        raw = p.read_bytes()[: _MAX_BYTES + 1]
    except OSError as exc:
        raise CalibrationError(f"{p}: cannot read the calibration: {exc.strerror or exc}") from None
    if len(raw) > _MAX_BYTES:
        raise CalibrationError(f"{p}: not a calibration file (larger than {_MAX_BYTES} bytes)")
    try:
        text = raw.decode("utf-8")
        # JSON's NaN and Infinity are refused as the values they are, not as bad syntax
        data = tomllib.loads(text) if p.suffix.lower() == ".toml" else json.loads(text, parse_constant=float)
    except (UnicodeDecodeError, json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        kind = "TOML" if p.suffix.lower() == ".toml" else "JSON"
        raise CalibrationError(f"{p}: not a {kind} calibration file: {exc}") from None
    return parse_calibration(data, where=str(p))


def _unmodelled(terms: NoiseTerms) -> list[str]:
    return [name for name in UNMODELLED_FIELDS if getattr(terms, name) > 0]


def calibration_text(terms: NoiseTerms, fmt: str = "toml", source: str = "") -> str:
    """The calibration file telling ``terms`` (``fmt`` ``toml`` or ``json``), its note saying
    where they come from (``source``) and what they leave on: told error sources the filter
    does not model keep the shared match floor on.

    >>> print(calibration_text(NoiseTerms.preset("paper"), source="paper").splitlines()[0])
    # clomp run --calibration: the drive's noise terms (standard deviations, SI units), from paper
    >>> t = NoiseTerms.preset("harsh")
    >>> load = parse_calibration(json.loads(calibration_text(t, "json")))
    >>> load == t
    True
    """
    unmodelled = _unmodelled(terms)
    head = f"the drive's noise terms (standard deviations, SI units){', from ' + source if source else ''}"
    note = (f"{head}. Told error sources the filter does not model ({', '.join(unmodelled)}): the estimator "
            "keeps the shared match floor on (a wide bound), and without a heading sensor the worst-case wheels"
            if unmodelled else
            f"{head}. Every told error source is one the filter models: the shared match floor is off")
    values = terms.to_dict()
    if fmt == "json":
        return json.dumps({NOTE: note, **values}, indent=2) + "\n"
    if fmt != "toml":
        raise ValueError(f"fmt must be 'toml' or 'json', got {fmt!r}")
    lines = [f"# clomp run --calibration: {head}", f"# {note.split('. ', 1)[1]}"]
    lines += [f"{name} = {float(v)!r}" for name, v in values.items() if math.isfinite(v)]
    return "\n".join(lines) + "\n"


def write_calibration(path: str | os.PathLike[str], terms: NoiseTerms, source: str = "") -> Path:
    """Write :func:`calibration_text` to ``path`` (TOML for a ``.toml`` name, JSON otherwise); the path."""
    p = Path(path)
    p.write_text(calibration_text(terms, "toml" if p.suffix.lower() == ".toml" else "json", source), encoding="utf-8")
    return p


class ToldCalibration:
    """A backend told its drive's calibration (:class:`~clomp.runtime.interface.Calibrated`):
    mixed into a robot class before it, set by :meth:`tell` in its constructor.

    >>> class R(ToldCalibration):
    ...     def __init__(self) -> None:
    ...         self.tell(NoiseTerms(wheel_sd=0.02))
    >>> R().calibration()["wheel_sd"]
    0.02
    """

    told: NoiseTerms

    def tell(self, terms: NoiseTerms) -> None:
        """Set the terms :meth:`calibration` reports."""
        if not isinstance(terms, NoiseTerms):
            raise TypeError(f"a calibration is a NoiseTerms, got {type(terms).__name__}")
        self.told = terms

    def calibration(self) -> dict[str, float]:
        """The told noise terms by name (Calibrated)."""
        return self.told.to_dict()
