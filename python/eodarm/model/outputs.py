"""The ``outputs=`` argument of :func:`eodarm.solve` and :func:`eodarm.solve_sequence`: which
of their arrays a call computes and returns (docs/python.md, "Asking for some outputs").

``outputs=None`` is every output. Otherwise the call returns exactly the keys asked for plus
``status``, always: it says which rows of the asked arrays the small-deflection model can
be trusted in (docs/model.md §7), and the compiled core computes it from the solved pose
whether or not the arrays it reads are returned. The compiled core allocates and writes only
the asked arrays; the numpy reference and ``model="fem"`` compute every output and return the
asked ones.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from eodarm.errors import InputError

__all__ = ["FEM_KEYS", "SOLVE_KEYS", "check_outputs", "core_outputs", "select"]

#: The arrays every analytic solve returns besides ``status`` (``solve``: (N, ...);
#: ``solve_sequence``: (N, S, ...)), in the compiled core's order.
SOLVE_KEYS = (
    "force_n",
    "reaction_n",
    "dforce_n",
    "torque_nmm",
    "dtorque_nmm",
    "dx_mm",
    "dy_mm",
    "dalpha_deg",
    "dl_mm",
    "dlength_mm",
    "length_mm",
)
#: What ``model="fem"`` adds (docs/fem.md).
FEM_KEYS = (
    "pin_force_n",
    "moment_nmm",
    "dmoment_nmm",
    "moment_x_mm",
    "node_xy",
    "node_disp",
    "segments",
    "segment_kind",
    "node_kind",
    "n_dof",
)
#: What ``uncertainty=True`` adds (:data:`eodarm.model.uncertainty.PART_KEYS`), listed in
#: messages by their totals.
SIGMA_TOTALS = ("sigma_dx_mm", "sigma_dy_mm", "sigma_dalpha_deg")
SIGMA_KEYS = tuple(f"sigma{p}_{k[6:]}" for p in ("", "_param", "_model") for k in SIGMA_TOTALS)


def check_outputs(
    outputs: Iterable[str] | None, model: str = "analytic", uncertainty: bool = False
) -> tuple[str, ...] | None:
    """The keys ``outputs`` asks for, in its order (None: every output), or an InputError in
    one line naming the bad key and listing the valid ones: an unknown or repeated key, a
    bare string (``outputs="dx_mm"`` is not ``("dx_mm",)``), a key that is not a string, an
    empty sequence. The valid keys are :data:`SOLVE_KEYS` and ``status``, with
    :data:`FEM_KEYS` for ``model="fem"`` and the sigma keys for ``uncertainty=True``."""
    if outputs is None:
        return None
    valid = [*SOLVE_KEYS, "status"]
    listed = ", ".join(valid)
    if model == "fem":
        valid += FEM_KEYS
        listed = ", ".join(valid)
    if uncertainty:
        valid += SIGMA_KEYS
        listed += f", {', '.join(SIGMA_TOTALS)} (and their sigma_param_, sigma_model_ parts)"
    if isinstance(outputs, (str, bytes)):
        raise InputError(
            f"outputs: a bare string {_short(outputs)}; give a sequence of keys, e.g. "
            f"({_short(outputs)},); valid: {listed}"
        )
    try:
        keys = tuple(outputs)
    except TypeError:
        raise InputError(
            f"outputs: expected a sequence of keys, got {type(outputs).__name__}; valid: {listed}"
        ) from None
    if not keys:
        raise InputError(f"outputs: empty (no key asked for); valid: {listed}")
    seen: set[str] = set()
    for key in keys:
        if not isinstance(key, str) or key not in valid:
            hint = " (sigma keys need uncertainty=True)" if _sigma(key, uncertainty) else ""
            raise InputError(f"outputs: unknown key {_short(key)}{hint}; valid: {listed}")
        if key in seen:
            raise InputError(f"outputs: key {key!r} asked for twice; valid: {listed}")
        seen.add(key)
    return keys


def core_outputs(asked: tuple[str, ...] | None, need_dy: bool) -> list[str] | None:
    """What to ask the compiled core for: the asked keys of :data:`SOLVE_KEYS` (None: every
    one), and ``dy_mm`` when ``need_dy`` (the failed rows are read from it, see
    :func:`eodarm.model.kinematics._refuse_unloaded_singular`)."""
    if asked is None:
        return None
    keys = [k for k in asked if k in SOLVE_KEYS]
    if need_dy and "dy_mm" not in keys:
        keys.append("dy_mm")
    return keys


def select(res: Mapping[str, Any], asked: tuple[str, ...] | None) -> dict[str, Any]:
    """The asked keys of a solve's results, in the asked order, then ``status`` (every key
    when ``asked`` is None)."""
    if asked is None:
        return dict(res)
    out = {k: res[k] for k in asked if k != "status"}
    out["status"] = res["status"]
    return out


def _short(key: object) -> str:
    """``repr`` of a key, cut to 40 characters (the message stays one short line)."""
    text = repr(key)
    return text if len(text) <= 40 else text[:37] + "..."


def _sigma(key: object, uncertainty: bool) -> bool:
    return not uncertainty and isinstance(key, str) and key in SIGMA_KEYS
